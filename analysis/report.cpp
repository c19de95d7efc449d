#include "analysis/report.hpp"

#include "results/measure_kind.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numeric>
#include <set>
#include <sstream>

#include "analysis/anova.hpp"
#include "analysis/csv.hpp"
#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"
#include "analysis/lmm.hpp"
#include "analysis/posthoc.hpp"
#include "analysis/summary.hpp"
#include "analysis/svg.hpp"
#include "analysis/two_sample.hpp"
#include "common/input_error.hpp"
#include "common/remove_on_signal.hpp"
#include "common/write_file.hpp"
#include "palplab/version.hpp"
#include "results/store.hpp"

namespace palplab::analysis {

namespace fs = std::filesystem;

namespace {

// printf of one number into a string of the size needed (never cut); "n/a" when not finite.
// Statistics (t, F, q, g) go through stat_text / f_text (summary.hpp), as the stats APA lines.
std::string fmt(double v, const char* f = "%.4g") {
  if (!std::isfinite(v)) return "n/a";
  const int n = std::snprintf(nullptr, 0, f, v);
  std::string out(static_cast<size_t>(std::max(n, 0)), '\0');
  if (n > 0) std::snprintf(out.data(), out.size() + 1, f, v);
  return out;
}

// A t for a table: stat_text, or a bound when it overflows a double (an SE of subnormal size).
std::string t_text(double t) {
  if (std::isinf(t)) return t < 0 ? "< -1.8e+308" : "> 1.8e+308";
  return stat_text(t, 3);
}

// "[lo, hi]" (a helper rather than operator+ chains: GCC 12 warns falsely on those).
std::string bracket(const std::string& lo, const std::string& hi) {
  std::string s = "[";
  s += lo;
  s += ", ";
  s += hi;
  s += "]";
  return s;
}

// "[lo, hi]" of a statistic (a g interval) with stat_text.
std::string stat_interval(double lo, double hi, int decimals) {
  return bracket(stat_text(lo, decimals), stat_text(hi, decimals));
}

std::string interval(double lo, double hi, const char* f = "%.4g") {
  return bracket(fmt(lo, f), fmt(hi, f));
}

// A table cell's text: palplab::markdown_text (no markup from a name or a path).
std::string md_cell(const std::string& s) {
  return markdown_text(s);
}

// Builds the Markdown and the HTML documents side by side.
struct Doc {
  std::ostringstream md, html;
  void heading(int level, const std::string& text) {
    md << "\n" << std::string(level, '#') << " " << text << "\n\n";
    html << "<h" << level << ">" << xml_escape(text) << "</h" << level << ">\n";
  }
  void para(const std::string& text) {
    md << text << "\n\n";
    html << "<p>" << xml_escape(text) << "</p>\n";
  }
  void bullets(const std::vector<std::string>& items) {
    html << "<ul>\n";
    for (const auto& i : items) {
      md << "- " << i << "\n";
      html << "<li>" << xml_escape(i) << "</li>\n";
    }
    md << "\n";
    html << "</ul>\n";
  }
  void table(const std::vector<std::string>& head,
             const std::vector<std::vector<std::string>>& rows) {
    md << "|";
    for (const auto& h : head) md << " " << md_cell(h) << " |";
    md << "\n|";
    for (size_t i = 0; i < head.size(); ++i) md << (i ? "---:|" : "---|");
    md << "\n";
    html << "<table>\n<tr>";
    for (const auto& h : head) html << "<th>" << xml_escape(h) << "</th>";
    html << "</tr>\n";
    for (const auto& r : rows) {
      md << "|";
      html << "<tr>";
      for (const auto& c : r) {
        md << " " << md_cell(c) << " |";
        html << "<td>" << xml_escape(c) << "</td>";
      }
      md << "\n";
      html << "</tr>\n";
    }
    md << "\n";
    html << "</table>\n";
  }
  void figure(const std::string& svg, const std::string& file, const std::string& caption) {
    md << "![" << caption << "](figures/" << file << ")\n\n*" << caption << "*\n\n";
    html << "<figure>\n"
         << svg << "<figcaption>" << xml_escape(caption) << "</figcaption>\n</figure>\n";
  }
};

// The thresholds of the feature region in a phase (the region's own, else "*").
const results::ThresholdRecord* feature_thresholds(const results::PhaseRecord& p) {
  const results::ThresholdRecord* any = nullptr;
  for (const auto& t : p.thresholds) {
    if (t.region == p.feature) return &t;
    if (t.region == "*") any = &t;
  }
  return any;
}

struct Unit {  // one analysis: a measure in a phase, pooled over its sessions or the last one
  std::string measure, phase;
  bool pooled = false, welch = true;
  std::set<std::string> kinds;
  double margin = 0;  // equivalence margin the study declares ("margin", data units); 0: default
  // pooled: sessions are averaged per participant (one value each) unless the study asks for
  // pooling the sessions themselves ("pool_sessions": true), which treats repeated sessions of
  // one person as independent observations (pseudo-replication) and is flagged in the report.
  bool pool_sessions = false;
};

// Force Weber fraction: the default equivalence margin of a force measure (unit N) is ±7 % of
// its reference level when the study declares none.
constexpr double kForceWeberFraction = 0.07;

std::string slug(const std::string& s) {
  std::string o;
  for (char c : s) o += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return o;
}

std::string with_unit(const std::string& text, const std::string& unit) {
  return text + (unit.empty() || unit == "1" ? "" : " (" + unit + ")");
}

// Where the stills are drawn before the report is complete (then moved into stills/).
constexpr const char* kStillsStage = "stills.partial";

// Everything the sections read: the store's records and the study structure stored at run time.
struct Context {
  std::string db_path, out_dir;
  ReportOptions options;
  results::Store store;
  results::StudyRecord study;
  results::StudyStructure structure;
  std::vector<results::ParticipantRecord> participants;
  std::vector<results::SessionRecord> sessions;
  std::vector<results::MeasureRow> measures;
  std::vector<results::PrototypeRecord> prototypes;
  nlohmann::json declared;  // the stored study JSON: its description and declared analyses only
  std::vector<std::string> groups, phase_order;
  std::map<std::string, std::string> unit_of;
  std::map<std::string, double> scale_of;  // proportion_scale()
  std::map<std::string, bool> binary_of;   // binary_proportion()
  Doc doc;
  ReportFiles files;
  // Files written only once the whole report is made (commit_files): a report that fails
  // half-way (a corrupt sample blob found by the force-trace section) replaced figures of the
  // previous report with figures of the damaged database, linked from the old report.md
  // (review 2026-12-07). Figures and stills.json wait here; the PNG stills are rendered into
  // `stills_stage` and moved into stills/.
  std::vector<std::pair<std::string, std::string>> pending;  // (file, content)
  fs::path stills_stage;
  // The stage and the stills in it are removed on SIGINT/SIGTERM/SIGHUP until they are moved
  // (an interrupted report left OUT/stills.partial/*.png: review 2026-12-07).
  std::vector<std::unique_ptr<RemoveOnSignal>> stage_on_signal;

  int group_index(const std::string& g) const {
    return static_cast<int>(std::find(groups.begin(), groups.end(), g) - groups.begin());
  }
  std::string unit(const std::string& measure) const {
    auto it = unit_of.find(measure);
    return it == unit_of.end() ? "" : it->second;
  }
  // A measure that is a proportion: unit "1" (0..1) or "%" (0..100) with every stored value on
  // that scale, and not one of palplab's counts (results/measure_kind.hpp); its scale maximum, 0
  // for any other measure. A dimensionless count (palpations, insertion_attempts, layers_passed:
  // unit "1" too) is no proportion: it was given intervals clipped to [0, 1] ("[11.23, 1]" for a
  // mean of 12.67) and error bars that missed the mean, and with every value 1 (one insertion
  // each) a Wilson interval [0.34, 1].
  double proportion_scale(const std::string& measure) const {
    auto it = scale_of.find(measure);
    return it == scale_of.end() ? 0.0 : it->second;
  }
  // A proportion of single trials: every stored value of the measure (all groups and sessions)
  // 0 or the scale maximum. Only then is a group's share a binomial one (Wilson); decided per
  // group, two sessions of 100 % of a measure that elsewhere holds 75 % got a Wilson interval
  // [34, 100] as if they were two trials, and one table two contradictory captions (review
  // 2026-12-07).
  bool binary_proportion(const std::string& measure) const {
    auto it = binary_of.find(measure);
    return it != binary_of.end() && it->second;
  }
  const results::PhaseRecord* phase(const std::string& id) const {
    for (const auto& p : structure.phases)
      if (p.phase == id) return &p;
    return nullptr;
  }
  void save_figure(const std::string& name, const std::string& svg, const std::string& caption) {
    const fs::path file = fs::path(out_dir) / "figures" / name;
    pending.emplace_back(file.string(), svg);
    files.figures.push_back(file.string());
    doc.figure(svg, name, caption);
  }
};

// A directory the report writes into (`what`), created if needed: a file in its place is said
// as such (exit 2), never a filesystem_error.
void make_out_dir(const fs::path& dir, const std::string& what) {
  std::error_code ec;
  if (fs::exists(fs::status(dir, ec)) && !fs::is_directory(fs::status(dir, ec)))
    throw InputError("exists and is not a directory (the report writes " + what + " there)",
                     dir.string());
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw InputError("cannot create the directory for " + what + " (" +
                         (ec ? ec.message() : std::string("not a directory")) + ")",
                     dir.string());
}

// Everything the report will write under DIR, checked before the work starts: a file where the
// report puts a directory (figures/, stills/) or a directory where it puts a file (report.md,
// report.html) is refused naming it; nothing is deleted or replaced to make room.
void check_out_dir(const std::string& out_dir, bool stills) {
  make_out_dir(out_dir, "report.md, report.html, figures/ and stills/");
  std::error_code ec;
  const fs::path out(out_dir);
  auto no_file_at = [&](const fs::path& p, const std::string& what) {
    const auto st = fs::status(p, ec);
    if (fs::exists(st) && !fs::is_directory(st))
      throw InputError("exists and is not a directory (the report writes " + what + " there)",
                       p.string());
  };
  no_file_at(out / "figures", "its SVG figures");
  if (stills) no_file_at(out / "stills", "the stills");
  for (const char* name : {"report.md", "report.html"})
    if (fs::is_directory(out / name, ec))
      throw InputError(std::string("is a directory (expected the report's file ") + name +
                           "; move it out of the way)",
                       (out / name).string());
}

Context load(const std::string& db_path, const std::string& out_dir, const ReportOptions& o) {
  if (!fs::exists(db_path)) throw InputError("no such results database", db_path);
  Context c{db_path, out_dir, o, results::Store::open(db_path)};
  c.structure = c.store.read_structure();
  // Schema-1 databases (before the structure tables) are refused rather than guessed at: their
  // phase kinds, cues and thresholds are known only from re-parsing the study file.
  if (!c.structure.has_structure)
    throw InputError(
        "results schema version " + std::to_string(c.store.schema_version()) +
            " does not store the study structure (phase kinds, cues, thresholds) the report "
            "needs; re-run the study with this palplab (`palplab run STUDY --db NEW.db`) to get "
            "a schema-" +
            std::to_string(results::kSchemaVersion) + " database",
        db_path);
  c.study = c.store.read_study();
  c.participants = c.store.read_participants();
  c.sessions = c.store.read_sessions();
  c.measures = c.store.read_measures();
  c.prototypes = c.store.read_prototypes();
  try {
    c.declared = nlohmann::json::parse(c.study.json);
  } catch (const std::exception& e) {
    throw InputError(SourceLocation{db_path, 0, 0, -1, "study.json"},
                     std::string("the stored study JSON does not parse: ") + e.what());
  }
  // Group order: as the study declared them, then any others in participant order.
  for (const auto& g : c.structure.groups) c.groups.push_back(g.group);
  for (const auto& p : c.participants)
    if (std::find(c.groups.begin(), c.groups.end(), p.group) == c.groups.end())
      c.groups.push_back(p.group);
  for (const auto& m : c.measures) c.unit_of[m.name] = m.unit;
  for (const auto& [name, unit] : c.unit_of)
    c.scale_of[name] = results::is_count_measure(name) ? 0.0
                       : unit == "1"                   ? 1.0
                       : unit == "%"                   ? 100.0
                                                       : 0.0;
  for (const auto& m : c.measures)
    if (m.value && !(*m.value >= 0 && *m.value <= c.scale_of[m.name])) c.scale_of[m.name] = 0;
  for (const auto& [name, scale] : c.scale_of) c.binary_of[name] = scale > 0;
  for (const auto& m : c.measures)
    if (m.value && *m.value != 0 && *m.value != c.scale_of[m.name]) c.binary_of[m.name] = false;
  for (const auto& p : c.structure.phases) c.phase_order.push_back(p.phase);
  for (const auto& s : c.sessions)
    if (std::find(c.phase_order.begin(), c.phase_order.end(), s.phase) == c.phase_order.end())
      c.phase_order.push_back(s.phase);
  return c;
}

// The analyses the study declares, merged per (measure, phase, pooled); a study without any
// gets ANOVA + pairwise t of each of its measures in its last phase.
std::vector<Unit> analysis_units(const Context& c) {
  std::vector<Unit> units;
  auto unit_for = [&](const std::string& m, const std::string& ph, bool pooled) -> Unit& {
    for (auto& u : units)
      if (u.measure == m && u.phase == ph && u.pooled == pooled) return u;
    units.push_back({m, ph, pooled, true, {}});
    return units.back();
  };
  const auto& sj = c.declared;
  if (sj.contains("analyses") && sj["analyses"].is_array())
    for (const auto& a : sj["analyses"]) {
      Unit& u = unit_for(a.value("measure", std::string()), a.value("phase", std::string()),
                         a.value("pooled", false));
      u.kinds.insert(a.value("kind", std::string("descriptives")));
      if (a.contains("welch")) u.welch = a.value("welch", true);
      if (a.value("pool_sessions", false)) u.pool_sessions = true;
      if (a.contains("margin") && a["margin"].is_number() && a["margin"].get<double>() > 0)
        u.margin = a["margin"].get<double>();
    }
  if (units.empty() && !c.phase_order.empty()) {
    // The study's measures ($.measures, else its task's default list), those the database
    // holds. Every measure stored was analysed before: the two counts a palpation session always
    // records (palpations, sft_reached) too, though the study left them out (review 2026-12-07).
    std::set<std::string> stored;
    for (const auto& m : c.measures) stored.insert(m.name);
    std::vector<std::string> declared;
    if (sj.contains("measures") && sj["measures"].is_array()) {
      for (const auto& m : sj["measures"])
        if (m.is_string()) declared.push_back(m.get<std::string>());
    } else {
      const std::string task = sj.contains("task") && sj["task"].is_object() &&
                                       sj["task"].contains("kind") && sj["task"]["kind"].is_string()
                                   ? sj["task"]["kind"].get<std::string>()
                                   : std::string();
      for (const auto& k : results::kMeasureKinds)
        if (k.by_default && k.task == results::measure_task(task)) declared.emplace_back(k.name);
    }
    // In the study's order (then any unknown to the table: a later palplab's, as stored).
    std::vector<std::string> names;
    for (const auto& n : declared)
      if (stored.count(n) && std::find(names.begin(), names.end(), n) == names.end())
        names.push_back(n);
    for (const auto& n : stored)
      if (!results::find_measure_kind(n)) names.push_back(n);
    for (const auto& n : names) {
      Unit& u = unit_for(n, c.phase_order.back(), false);
      u.kinds = {"descriptives", "anova_oneway", "pairwise_t"};
    }
  }
  return units;
}

std::string cue_text(const std::optional<bool>& v) {
  return v ? (*v ? "on" : "off") : "as prototype";
}

// ---- Study and provenance, with the phases as run (kind, cues, thresholds)
void section_provenance(Context& c) {
  Doc& doc = c.doc;
  doc.md << "# " << c.study.title << "\n\n";
  doc.html << "<h1>" << xml_escape(c.study.title) << "</h1>\n";
  if (c.declared.contains("description") && c.declared["description"].is_string())
    doc.para(c.declared["description"]);
  if (c.study.finished_at.empty())
    doc.para(
        "**Warning: INCOMPLETE database.** The run did not finish (study.finished_at is NULL): "
        "sessions or participants may be missing, and every result below is provisional.");
  doc.heading(2, "Study and provenance");
  std::map<std::string, int> per_group, stored_per_group;
  std::set<std::string> with_sessions;
  for (const auto& s : c.sessions) with_sessions.insert(s.participant);
  for (const auto& p : c.participants) {
    per_group[p.group]++;
    stored_per_group[p.group] += with_sessions.count(p.participant) ? 1 : 0;
  }
  // An incomplete run: the participants with sessions stored, of those planned.
  const bool partial = c.study.finished_at.empty();
  std::string design;
  for (const auto& g : c.groups)
    design += (design.empty() ? "" : ", ") + g + ": " +
              (partial ? std::to_string(stored_per_group[g]) + " of " : "") +
              std::to_string(per_group[g]);
  std::string phases_text;
  for (const auto& ph : c.phase_order) {
    int n = 0;
    for (const auto& s : c.sessions) n += s.phase == ph;
    phases_text += (phases_text.empty() ? "" : ", ") + ph + " (" + std::to_string(n) + " session" +
                   (n == 1 ? "" : "s") + ")";
  }
  const auto& st = c.study;
  doc.table(
      {"item", "value"},
      {{"study id", st.study_id},
       {"study file SHA-256", st.sha256},
       {"seed", std::to_string(st.seed)},
       {"run by palplab", st.palplab_version + " (" + st.git_commit + ")"},
       {"started", st.started_at},
       {"finished", st.finished_at.empty() ? "INCOMPLETE (run not finished)" : st.finished_at},
       {partial ? "participants per group (with sessions stored, of planned)"
                : "participants per group",
        design},
       {"sessions stored", std::to_string(c.sessions.size()) + " — " + phases_text},
       {"report by palplab", std::string(kVersion) + " (" + kGitCommit + ")"},
       {"database", c.db_path}});
  std::vector<std::vector<std::string>> rows;
  for (const auto& p : c.structure.phases) {
    std::string th;
    for (const auto& t : p.thresholds)
      th += (th.empty() ? "" : "; ") + t.region + ": " + fmt(t.st, "%.3g") + " / " +
            fmt(t.mpf, "%.3g") + " / " + fmt(t.sft, "%.3g");
    rows.push_back({p.phase, p.kind, std::to_string(p.sessions), fmt(p.session_duration, "%.4g"),
                    cue_text(p.haptic), cue_text(p.visual_deformation), cue_text(p.audio),
                    p.instructed ? "yes" : "no", th});
  }
  doc.para("Phases as run (stored with the results):");
  doc.table({"phase", "kind", "sessions", "duration (s)", "haptic", "visual deformation", "audio",
             "instructed", "ST / MPF / SFT (N)"},
            rows);
  if (!c.prototypes.empty()) {
    std::vector<std::vector<std::string>> pr;
    for (const auto& p : c.prototypes) pr.push_back({p.prototype, p.path, p.sha256});
    doc.para("Prototype files used (as stored with the results):");
    doc.table({"prototype", "file", "SHA-256"}, pr);
  }
  doc.para(
      "Statistics: palplab analysis (GSL; own studentized range). Pairwise t-tests use "
      "Welch's unequal-variance test unless the study says otherwise; p-values are "
      "Holm-adjusted over the pairs; Hedges' g with a 95 % noncentral-t interval that inverts "
      "the same t as the test beside it (Welch's t and df for a Welch test). Proportions get "
      "Wilson score intervals (never outside [0, 1]). APA style: p < .001 below .001.");
}

// Standard base64 (RFC 4648, padded): the PNG stills inline in report.html as data URIs.
std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string o;
  o.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 |
                       static_cast<unsigned char>(bytes[i + 1]) << 8 |
                       static_cast<unsigned char>(bytes[i + 2]);
    o += k[v >> 18 & 63];
    o += k[v >> 12 & 63];
    o += k[v >> 6 & 63];
    o += k[v & 63];
  }
  if (i < bytes.size()) {
    const bool two = i + 1 < bytes.size();
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 |
                       (two ? static_cast<unsigned char>(bytes[i + 1]) << 8 : 0u);
    o += k[v >> 18 & 63];
    o += k[v >> 12 & 63];
    o += two ? k[v >> 6 & 63] : '=';
    o += '=';
  }
  return o;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// ---- Every prototype the study used under the same press, side by side (PNG stills)
void section_stills(Context& c, const std::vector<std::string>& phase_candidates) {
  c.doc.heading(2, "Prototypes under the same press");
  auto skip = [&](const std::string& why) {
    c.files.stills_skipped = why;
    c.doc.para("Stills skipped: " + why + ".");
  };
  if (c.prototypes.empty()) return skip("the database stores no prototype files");
  // The press: the feature region of the first analysed phase (then the others, last first)
  // with a stored target force, the MPF of that region in that phase.
  const results::PhaseRecord* ph = nullptr;
  const results::ThresholdRecord* th = nullptr;
  for (const auto& cand : phase_candidates) {
    const auto* p = c.phase(cand);
    if (!p || p->feature.empty()) continue;
    const auto* t = feature_thresholds(*p);
    if (t && std::isfinite(t->mpf) && t->mpf > 0) {
      ph = p;
      th = t;
      break;
    }
  }
  if (!ph) return skip("no phase stores a feature region with a target force (MPF)");
  if (!c.options.stills) return skip(c.options.no_stills_reason);
  const auto t0 = std::chrono::steady_clock::now();
  if (const std::string why = c.options.stills->unavailable(); !why.empty()) return skip(why);

  // The groups that use each prototype: their own and their sessions' (phase prototypes).
  std::map<std::string, std::string> group_of;
  for (const auto& p : c.participants) group_of[p.participant] = p.group;
  std::map<std::string, std::set<int>> users;
  for (const auto& g : c.structure.groups) users[g.prototype].insert(c.group_index(g.group));
  for (const auto& s : c.sessions)
    if (auto it = group_of.find(s.participant); it != group_of.end())
      users[s.prototype].insert(c.group_index(it->second));
  std::vector<const results::PrototypeRecord*> protos;
  for (const auto& p : c.prototypes) protos.push_back(&p);
  auto first_user = [&](const results::PrototypeRecord* p) {
    auto it = users.find(p->prototype);
    return it == users.end() || it->second.empty() ? 1 << 30 : *it->second.begin();
  };
  std::stable_sort(protos.begin(), protos.end(),
                   [&](const auto* a, const auto* b) { return first_user(a) < first_user(b); });

  const fs::path dir = fs::path(c.out_dir) / "stills";
  c.stills_stage = fs::path(c.out_dir) / kStillsStage;
  make_out_dir(c.stills_stage, "the stills being drawn");
  c.stage_on_signal.push_back(std::make_unique<RemoveOnSignal>(c.stills_stage.string()));
  const int W = c.options.still_width, H = c.options.still_height;
  const std::string force_text = fmt(th->mpf, "%.3g") + " N";
  struct Done {
    const results::PrototypeRecord* proto;
    std::string groups, pressed, rest;
    StillResult r;
  };
  std::vector<Done> done;
  nlohmann::json side = {
      {"press",
       {{"phase", ph->phase},
        {"region", ph->feature},
        {"force", th->mpf},
        {"force_source", "MPF of region " + th->region + " in phase " + ph->phase},
        {"hold", c.options.still_hold}}},
      {"width", W},
      {"height", H},
      {"camera_convention", c.options.stills->camera_convention()},
      {"stills", nlohmann::json::array()}};
  std::vector<std::string> missing;
  for (const auto* p : protos) {
    std::string groups;
    if (auto it = users.find(p->prototype); it != users.end())
      for (int g : it->second)
        if (g >= 0 && g < static_cast<int>(c.groups.size()))
          groups += (groups.empty() ? "" : ", ") + c.groups[static_cast<size_t>(g)];
    StillRequest q;
    q.prototype = p->prototype;
    q.path = p->path;
    q.sha256 = p->sha256;
    q.json = p->json;
    q.region = ph->feature;
    q.force = th->mpf;
    q.hold = c.options.still_hold;
    q.width = W;
    q.height = H;
    q.pressed_png = (c.stills_stage / (slug(p->prototype) + "_pressed.png")).string();
    q.rest_png = (c.stills_stage / (slug(p->prototype) + "_rest.png")).string();
    StillResult r;
    for (const std::string& png : {q.pressed_png, q.rest_png})
      c.stage_on_signal.push_back(std::make_unique<RemoveOnSignal>(png));
    try {
      r = c.options.stills->make(q);
    } catch (const std::exception& e) {
      r.skipped = e.what();
    }
    // Said of the file the report writes (stills/…), not of its stage.
    for (const std::string& staged : {q.pressed_png, q.rest_png})
      for (std::size_t at; (at = r.skipped.find(staged)) != std::string::npos;)
        r.skipped.replace(at, staged.size(), (dir / fs::path(staged).filename()).string());
    nlohmann::json js = {{"prototype", p->prototype}, {"groups", groups}};
    if (!r.skipped.empty()) {
      missing.push_back(p->prototype + ": " + r.skipped);
      js["skipped"] = r.skipped;
      side["stills"].push_back(js);
      continue;
    }
    js["pressed"] = "stills/" + fs::path(q.pressed_png).filename().string();
    js["rest"] = "stills/" + fs::path(q.rest_png).filename().string();
    if (!r.note.empty()) js["note"] = r.note;
    js["node"] = r.node;
    js["force_at_still"] = r.force;
    js["force_reached"] = r.force_reached;
    js["visible_deformation"] = r.visible_deformation;
    js["camera"] = r.camera;
    side["stills"].push_back(js);
    c.files.stills.push_back((dir / fs::path(q.pressed_png).filename()).string());
    c.files.stills.push_back((dir / fs::path(q.rest_png).filename()).string());
    done.push_back({p, groups, q.pressed_png, q.rest_png, r});
  }
  c.doc.para(
      "Each prototype the study used, pressed at its surface node nearest the centroid "
      "of region " +
      ph->feature + " (the feature of phase " + ph->phase + ") with the target force " +
      force_text + " (that phase's MPF for " +
      (th->region == "*" ? std::string("every region, \"*\"") : th->region) + "), held " +
      fmt(c.options.still_hold, "%.3g") +
      " s on the lock-step clock; each prototype draws as its file defines (the phases' "
      "cue switches are not applied). " +
      c.options.stills->camera_convention() + " " + std::to_string(W) + "×" + std::to_string(H) +
      " px; top: under the press, below: the same view at rest. Files: stills/*.png, "
      "the press and cameras in stills/stills.json.");
  for (const auto& m : missing) c.doc.para("No still of prototype " + m + ".");
  c.files.stills_missing = missing;
  c.pending.emplace_back((dir / "stills.json").string(), side.dump(2) + "\n");
  c.files.stills_listing = (dir / "stills.json").string();
  if (done.empty()) {
    c.files.stills_skipped = "no prototype could be drawn";
  } else {
    auto caption = [&](const Done& d) {
      std::string t = d.proto->prototype;
      if (!d.groups.empty())
        t += (d.groups.find(',') == std::string::npos ? " (group " : " (groups ") + d.groups + ")";
      t += d.r.force_reached ? ": " + fmt(d.r.force, "%.3g") + " N at the still"
                             : ": the press did not reach " + force_text + " (" +
                                   fmt(d.r.force, "%.3g") + " N at the still)";
      t += ", visible deformation " + fmt(d.r.visible_deformation * 1e3, "%.2g") + " mm";
      if (!d.r.note.empty()) t += " (" + d.r.note + ")";
      return t;
    };
    // Markdown: a table, one column per prototype (pressed, rest, caption rows).
    std::string head = "|", rule = "|", row_p = "|", row_r = "|", row_c = "|";
    for (const auto& d : done) {
      const std::string pf = "stills/" + fs::path(d.pressed).filename().string();
      const std::string rf = "stills/" + fs::path(d.rest).filename().string();
      head += " " + md_cell(d.proto->prototype) + " |";
      rule += "---|";
      row_p += " ![" + md_cell(d.proto->prototype) + " under " + force_text + "](" + pf + ") |";
      row_r += " ![" + md_cell(d.proto->prototype) + " at rest](" + rf + ") |";
      row_c += " " + md_cell(caption(d)) + " |";
    }
    c.doc.md << head << "\n" << rule << "\n" << row_p << "\n" << row_r << "\n" << row_c << "\n\n";
    // HTML: one <figure> per prototype in a wrapping row, the PNGs inline (data URIs), so the
    // page stays self-contained.
    c.doc.html << "<div class=\"stills\">\n";
    for (const auto& d : done) {
      c.doc.html << "<figure class=\"still\">\n";
      for (const auto& [file, what] :
           {std::pair{d.pressed, "under " + force_text}, std::pair{d.rest, std::string("at rest")}})
        c.doc.html << "<img src=\"data:image/png;base64," << base64(read_bytes(file))
                   << "\" width=\"" << W << "\" height=\"" << H << "\" alt=\""
                   << xml_escape(d.proto->prototype + " " + what) << "\">\n";
      c.doc.html << "<figcaption>" << xml_escape(caption(d)) << "</figcaption>\n</figure>\n";
      ++c.files.still_figures;
    }
    c.doc.html << "</div>\n";
  }
  c.files.stills_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The 95 % CI cell of a group's values: Wilson for a binary proportion (every value 0 or the
// scale maximum), the t interval clipped to [0, scale] for other proportions (a mean of
// per-session percentages), the t interval otherwise. `note` says which was used.
std::string ci_cell(const std::vector<double>& v, const Descriptives& d, double scale,
                    bool binary_measure, std::set<std::string>& notes) {
  if (scale > 0) {
    int k = 0;
    bool binary = binary_measure;  // and these values too (a pooled mean is no trial)
    for (double x : v) {
      binary = binary && (x == 0 || x == scale);
      k += x == scale;
    }
    if (binary) {
      auto w = wilson_interval(k, static_cast<int>(v.size()));
      notes.insert("Wilson score interval of the proportion");
      return interval(scale * w.low, scale * w.high);
    }
    if (d.n < 2) return "n/a";
    notes.insert("t interval of the mean proportion, clipped to [0, " + fmt(scale) + "]");
    return interval(std::max(0.0, d.ci_low), std::min(scale, d.ci_high));
  }
  return d.n >= 2 ? interval(d.ci_low, d.ci_high) : std::string("n/a");
}

// The values of one measure in one phase, per group: each participant's last session of the
// phase, or (pooled) the participant's mean over the phase's sessions, or (pooled with
// pool_sessions) every session as its own value. Undefined values are counted per group.
struct Values {
  GroupedData data;
  std::vector<int> undefined;
  // Participants left out because they lack the phase's planned last session (an incomplete
  // run), per group; without the study structure (schema 1) the last session stored counts.
  std::vector<int> missing;
  // Participant means only: participants none of whose sessions has a defined value (left out
  // of n, which counts participants, while `undefined` counts sessions), per group.
  std::vector<int> undefined_participants;
  std::vector<ParticipantPoint> points;
};
Values collect_values(const Context& c, const std::string& measure, const std::string& phase,
                      bool pooled, bool pool_sessions) {
  // Values: per participant the last session of the phase, or every session when pooled. The
  // last session is the phase's planned last: in an incomplete run a participant whose stored
  // sessions end earlier is left out (counted), not represented by an earlier session (one
  // group's "post-training" value was P02's session 1 beside another's session 2: review
  // 2026-12-07).
  const results::PhaseRecord* planned = c.phase(phase);
  std::map<std::string, int> last_index;
  for (const auto& m : c.measures)
    if (m.phase == phase && m.name == measure)
      last_index[m.participant] =
          std::max(last_index.count(m.participant) ? last_index[m.participant] : -1, m.phase_index);
  Values out;
  out.missing.assign(c.groups.size(), 0);
  if (planned && planned->sessions >= 1)
    for (auto& [who, last] : last_index)
      if (last != planned->sessions - 1) {
        // Its group, from any of its rows.
        for (const auto& m : c.measures)
          if (m.participant == who) {
            ++out.missing[c.group_index(m.group)];
            break;
          }
        last = planned->sessions - 1;  // matches none of its rows
      }
  GroupedData& data = out.data;
  data.names = c.groups;
  data.values.assign(c.groups.size(), {});
  std::vector<int>& undefined = out.undefined;
  undefined.assign(c.groups.size(), 0);
  std::vector<ParticipantPoint>& points = out.points;
  const bool means = pooled && !pool_sessions;
  // Participant means: the defined values of each participant's sessions, averaged in
  // participant order of first appearance (one value per participant).
  std::map<std::string, std::pair<long double, int>> sums;
  std::vector<std::pair<std::string, int>> order;
  std::map<std::string, int> seen;  // every participant with a row (means): its group
  for (const auto& m : c.measures) {
    if (m.phase != phase || m.name != measure) continue;
    if (!pooled && m.phase_index != last_index[m.participant]) continue;
    int g = c.group_index(m.group);
    if (means) seen.emplace(m.participant, g);
    if (!m.value || !std::isfinite(*m.value)) {
      undefined[g]++;
      continue;
    }
    if (means) {
      auto [it, fresh] = sums.emplace(m.participant, std::make_pair(0.0L, 0));
      if (fresh) order.push_back({m.participant, g});
      it->second.first += *m.value;
      it->second.second += 1;
      continue;
    }
    data.values[g].push_back(*m.value);
    std::string who = m.participant;
    if (pooled) {
      who += '#';
      who += std::to_string(m.phase_index + 1);
    }
    points.push_back({who, g, *m.value});
  }
  for (const auto& [who, g] : order) {
    const auto& [sum, n] = sums[who];
    const double v = static_cast<double>(sum / n);
    data.values[g].push_back(v);
    points.push_back({who, g, v});
  }
  out.undefined_participants.assign(c.groups.size(), 0);
  for (const auto& [who, g] : seen)
    if (!sums.count(who)) ++out.undefined_participants[g];
  return out;
}

// A hypothesis the study declared ($.hypotheses, checked by `palplab validate` / the run).
struct Hypothesis {
  std::string id, statement, measure, phase, test;
  std::vector<std::pair<std::string, std::string>> pairs;  // empty: every pair of groups
  std::optional<std::pair<double, double>> margins;        // tost
  double alpha = 0.05;
  std::string correction = "holm";
  bool pooled = false;
};

std::vector<Hypothesis> declared_hypotheses(const Context& c) {
  std::vector<Hypothesis> out;
  const auto& sj = c.declared;
  if (!sj.contains("hypotheses") || !sj["hypotheses"].is_array()) return out;
  for (const auto& hj : sj["hypotheses"]) {
    Hypothesis h;
    h.id = hj.value("id", std::string("H") + std::to_string(out.size() + 1));
    h.statement = hj.value("statement", std::string());
    h.measure = hj.value("measure", std::string());
    h.phase = hj.value("phase", std::string());
    h.test = hj.value("test", std::string());
    if (hj.contains("pairs") && hj["pairs"].is_array())
      for (const auto& pr : hj["pairs"])
        if (pr.is_array() && pr.size() == 2 && pr[0].is_string() && pr[1].is_string())
          h.pairs.push_back({pr[0], pr[1]});
    if (hj.contains("margins")) {
      const auto& m = hj["margins"];
      if (m.is_number()) h.margins = std::make_pair(-m.get<double>(), m.get<double>());
      if (m.is_array() && m.size() == 2 && m[0].is_number() && m[1].is_number())
        h.margins = std::make_pair(m[0].get<double>(), m[1].get<double>());
    }
    h.alpha = hj.value("alpha", 0.05);
    h.correction = hj.value("correction", std::string("holm"));
    h.pooled = hj.value("pooled", false);
    out.push_back(h);
  }
  return out;
}

// Adjusted p-values; `is_bound` receives whether each is a bound (built from a p at the floor).
std::vector<double> corrected(const std::vector<double>& p, const std::string& correction,
                              std::vector<bool>* is_bound) {
  if (correction == "bonferroni") return bonferroni(p, is_bound);
  if (correction == "none") {
    is_bound->clear();
    for (double v : p) is_bound->push_back(p_is_bound(v));
    return p;
  }
  return holm(p, is_bound);
}

// ---- Confirmatory analyses: exactly the declared hypotheses, before anything exploratory
void section_confirmatory(Context& c, const std::vector<Hypothesis>& hyps) {
  Doc& doc = c.doc;
  doc.heading(2, "Confirmatory analyses (declared hypotheses)");
  doc.para("The study declared these " + std::to_string(hyps.size()) +
           " hypotheses before the run; each is tested exactly as declared (its test, α and "
           "correction over its own pairs). Every analysis after this section is exploratory.");
  for (const auto& h : hyps) {
    const std::string unit = c.unit(h.measure);
    doc.heading(3, h.id + (h.statement.empty() ? "" : ": " + h.statement));
    std::string test_name = h.test == "anova_oneway" ? "one-way ANOVA (classical F)"
                            : h.test == "welch_t"    ? "Welch t-test"
                            : h.test == "student_t"  ? "Student t-test"
                                                     : "equivalence, TOST on Welch's t";
    doc.bullets({"measure " + with_unit(h.measure, unit) + ", phase " + h.phase + " (" +
                     (h.pooled ? "participant means over the phase's sessions"
                               : "last session of the phase") +
                     ")",
                 "test: " + test_name + ", α = " + fmt(h.alpha, "%.3g") +
                     (h.test == "anova_oneway" ? std::string()
                                               : ", correction over its pairs: " + h.correction) +
                     (h.margins ? ", margins " + interval(h.margins->first, h.margins->second) +
                                      (unit.empty() || unit == "1" ? "" : " " + unit)
                                : std::string())});
    Values v = collect_values(c, h.measure, h.phase, h.pooled, false);
    bool enough = true;
    for (const auto& g : v.data.values) enough = enough && g.size() >= 2;
    if (!enough || v.data.values.size() < 2) {
      doc.para("Not testable: every group needs at least 2 defined values of " + h.measure +
               " in phase " + h.phase + ".");
      continue;
    }
    if (h.test == "anova_oneway") {
      Anova a = oneway_anova(v.data.values);
      const FEffectCi ci = a.defined ? f_effect_ci(a.F, a.df_between, a.df_within) : FEffectCi{};
      doc.table({"test", "F", "df", "p", "η² [95% CI]", "decision"},
                {{"one-way ANOVA", f_text(a.F, a.log10_F, 3),
                  fmt(a.df_between, "%.0f") + ", " + fmt(a.df_within, "%.0f"), format_p(a.p),
                  fmt(a.eta_squared, "%.3f") +
                      (ci.defined ? " " + interval(ci.pve_low, ci.pve_high, "%.3f") : ""),
                  a.p < h.alpha ? "reject H0 (groups differ)" : "H0 not rejected (inconclusive)"}});
      doc.para(apa_anova(a) + ".");
      continue;
    }
    // Pairs: the declared ones (in their order and direction), else every pair.
    std::vector<std::pair<int, int>> pairs;
    for (const auto& [a, b] : h.pairs) {
      const int ia = c.group_index(a), ib = c.group_index(b);
      if (ia < static_cast<int>(c.groups.size()) && ib < static_cast<int>(c.groups.size()))
        pairs.push_back({ia, ib});
    }
    if (h.pairs.empty())
      for (int a = 0; a < static_cast<int>(c.groups.size()); ++a)
        for (int b = a + 1; b < static_cast<int>(c.groups.size()); ++b) pairs.push_back({a, b});
    std::vector<std::vector<std::string>> rows;
    std::vector<double> p;
    std::vector<TTest> tests;
    std::vector<Equivalence> eqs;
    for (const auto& [a, b] : pairs) {
      const auto &va = v.data.values[a], &vb = v.data.values[b];
      if (h.test == "tost") {
        eqs.push_back(tost_welch(va, vb, h.margins->first, h.margins->second, h.alpha));
        p.push_back(eqs.back().p);
      } else {
        tests.push_back(h.test == "student_t" ? student_t(va, vb) : welch_t(va, vb));
        p.push_back(tests.back().p);
      }
    }
    std::vector<bool> padj_bound;
    const std::vector<double> padj = corrected(p, h.correction, &padj_bound);
    const std::string diff_head = with_unit("mean diff", unit);
    for (size_t i = 0; i < pairs.size(); ++i) {
      const auto [a, b] = pairs[i];
      const std::string pair = c.groups[a] + " – " + c.groups[b];
      if (h.test == "tost") {
        const auto& q = eqs[i];
        rows.push_back({pair, fmt(q.mean_diff), interval(q.ci_low, q.ci_high), format_p(q.p),
                        format_p(padj[i], padj_bound[i]),
                        padj[i] < h.alpha ? "equivalent" : "not shown equivalent"});
      } else {
        const auto& t = tests[i];
        const auto& va = v.data.values[a];
        const auto& vb = v.data.values[b];
        EffectSize e = h.test == "student_t" ? cohens_d(va, vb) : cohens_d_welch(va, vb, t);
        rows.push_back({pair, fmt(t.mean_diff), t_text(t.t), fmt(t.df, "%.2f"), format_p(t.p),
                        format_p(padj[i], padj_bound[i]),
                        stat_text(e.g, 2) + " " + stat_interval(e.g_ci_low, e.g_ci_high, 2),
                        padj[i] < h.alpha ? "different" : "not significant (inconclusive)"});
      }
    }
    const std::string padj_head = "p (" + h.correction + ")";
    if (h.test == "tost")
      doc.table({"pair", diff_head, fmt(100 * (1 - 2 * h.alpha), "%.3g") + "% CI", "p (TOST)",
                 padj_head, "decision"},
                rows);
    else
      doc.table({"pair", diff_head, "t", "df", "p", padj_head, "Hedges g [95% CI]", "decision"},
                rows);
  }
}

// ---- One analysis unit: descriptives, figures, tests
void section_analysis(Context& c, const Unit& u) {
  Doc& doc = c.doc;
  const auto& groups = c.groups;
  ++c.files.analyses;
  const std::string unit = c.unit(u.measure);
  const std::string label = with_unit(u.measure, unit);
  const bool means = u.pooled && !u.pool_sessions;
  doc.heading(2,
              "Analysis: " + u.measure + " — phase " + u.phase +
                  (means ? " (participant means over all sessions)"
                         : (u.pooled ? " (all sessions pooled)" : " (last session of the phase)")));
  if (u.pooled && u.pool_sessions)
    doc.para(
        "**Warning: pseudo-replication.** The study asks for every session to be pooled as an "
        "independent observation, but sessions of one participant are not independent: "
        "degrees of freedom and p-values below overstate the evidence. Participant means "
        "(the default for pooled analyses) or a mixed model are the valid analyses.");
  Values vals = collect_values(c, u.measure, u.phase, u.pooled, u.pool_sessions);
  GroupedData& data = vals.data;
  const std::vector<int>& undefined = vals.undefined;
  const std::vector<ParticipantPoint>& points = vals.points;
  int total = 0, excluded = 0;
  for (size_t g = 0; g < groups.size(); ++g)
    total += data.values[g].size(), excluded += undefined[g];
  if (!u.pooled && std::accumulate(vals.missing.begin(), vals.missing.end(), 0) > 0) {
    std::string t =
        "Participants left out because the database does not hold their last session "
        "of the phase (the run is incomplete): ";
    for (size_t g = 0; g < groups.size(); ++g)
      t += (g ? ", " : "") + groups[g] + " " + std::to_string(vals.missing[g]);
    doc.para(t + ".");
  }
  if (total == 0) {
    doc.para("No defined values of " + u.measure + " in phase " + u.phase + " (" +
             std::to_string(excluded) + " undefined).");
    return;
  }
  if (excluded > 0 && means) {
    // n counts participants here; the undefined values are sessions (review 2026-12-07).
    std::string t =
        "Undefined session values left out of the participant means (e.g. force when the feature "
        "was not identified), sessions per group: ";
    for (size_t g = 0; g < groups.size(); ++g)
      t += (g ? ", " : "") + groups[g] + " " + std::to_string(undefined[g]);
    t += ". Participants with no defined session, left out of n: ";
    for (size_t g = 0; g < groups.size(); ++g)
      t += (g ? ", " : "") + groups[g] + " " + std::to_string(vals.undefined_participants[g]);
    doc.para(t + ".");
  } else if (excluded > 0) {
    std::string t = "Undefined values left out (e.g. force when the feature was not identified): ";
    for (size_t g = 0; g < groups.size(); ++g)
      t += (g ? ", " : "") + groups[g] + " " + std::to_string(undefined[g]);
    doc.para(t + ".");
  }
  // Descriptives (always).
  doc.heading(3, "Descriptives");
  std::vector<std::vector<std::string>> rows;
  std::set<std::string> ci_notes;
  const double scale = c.proportion_scale(u.measure);
  for (size_t g = 0; g < groups.size(); ++g) {
    if (data.values[g].empty()) {
      rows.push_back({groups[g], "0", "", "", "", "", "", "", "", ""});
      continue;
    }
    Descriptives d = describe(data.values[g]);
    rows.push_back({groups[g], std::to_string(d.n), fmt(d.mean), fmt(d.sd), fmt(d.se),
                    fmt(d.median), fmt(d.iqr), fmt(d.min), fmt(d.max),
                    ci_cell(data.values[g], d, scale, c.binary_proportion(u.measure), ci_notes)});
  }
  doc.table(
      {"group", "n", with_unit("mean", unit), "SD", "SE", "median", "IQR", "min", "max", "95% CI"},
      rows);
  for (const auto& n : ci_notes) doc.para("95% CI: " + n + ".");
  const std::string base = slug(u.measure + "_" + u.phase + (u.pooled ? "_pooled" : ""));
  c.save_figure(base + "_box.svg",
                svg_box_plot(groups, data.values, u.measure + " by group, " + u.phase, label),
                "Range and box plot per group (box: quartiles, line: median, whiskers: min–max; "
                "dots: every value) of " +
                    u.measure + ", phase " + u.phase + ".");
  c.save_figure(
      base + "_participants.svg",
      svg_participant_plot(groups, points, u.measure + " per participant, " + u.phase, label),
      "Individual values per participant of " + u.measure + ", phase " + u.phase + ".");

  // Inference needs two groups with two values each.
  std::vector<int> usable;
  for (size_t g = 0; g < groups.size(); ++g)
    if (data.values[g].size() >= 2) usable.push_back(static_cast<int>(g));
  if (usable.size() < 2 || usable.size() < groups.size()) {
    doc.para("Not enough data for tests: every group needs at least 2 defined values.");
    return;
  }
  StatsOptions opt;
  opt.welch_pairwise = u.welch;
  // Equivalence margins: the study's, else ±7 % (force Weber fraction) of the target force —
  // the MPF the database stores for the phase's feature region — for a force; the grand mean
  // stands in only when no MPF is stored (a schema-1 database). Other measures without a
  // declared margin get no equivalence test.
  std::string margin_source;
  if (u.margin > 0) {
    opt.margins = std::make_pair(-u.margin, u.margin);
    margin_source = "declared by the study";
  } else if (unit == "N") {
    const results::PhaseRecord* ph = c.phase(u.phase);
    const results::ThresholdRecord* t = ph ? feature_thresholds(*ph) : nullptr;
    if (t && t->mpf > 0) {
      const double m = kForceWeberFraction * t->mpf;
      opt.margins = std::make_pair(-m, m);
      margin_source =
          "default: ±7 % (force Weber fraction) of the target force, MPF = " + fmt(t->mpf, "%.4g") +
          " N for region " + t->region + " in phase " + u.phase + ", from the study database";
    } else {
      long double sum = 0;
      int n = 0;
      for (const auto& gv : data.values)
        for (double v : gv) {
          sum += v + static_cast<long double>(data.offset);
          ++n;
        }
      const double m = kForceWeberFraction * std::fabs(static_cast<double>(sum / n));
      if (m > 0) {
        opt.margins = std::make_pair(-m, m);
        margin_source =
            "default: ±7 % (force Weber fraction) of the grand mean, as the database stores no "
            "MPF for phase " +
            u.phase;
      }
    }
  }
  StatsSummary s = summarize(data, opt);
  const bool want_anova = u.kinds.count("anova_oneway") > 0;
  const bool want_pairs = u.kinds.count("pairwise_t") > 0 || want_anova;
  const std::string diff_head = with_unit("mean diff", unit);
  if (want_anova) {
    doc.heading(3, "One-way ANOVA");
    const auto& a = s.anova;
    doc.table(
        {"source", "df", "SS", "MS", "F", "p"},
        {{"between groups", fmt(a.df_between, "%.0f"), fmt(a.ss_between), fmt(a.ms_between),
          f_text(a.F, a.log10_F, 3), format_p(a.p)},
         {"within groups", fmt(a.df_within, "%.0f"), fmt(a.ss_within), fmt(a.ms_within), "", ""}});
    doc.bullets(
        {"Classical: " + apa_anova(a) + ", η² = " + fmt(a.eta_squared, "%.3f") +
             ", ω² = " + fmt(a.omega_squared, "%.3f") +
             (s.anova_effect_ci.defined
                  ? "; 95 % CI of the population η² (= ω²) " +
                        interval(s.anova_effect_ci.pve_low, s.anova_effect_ci.pve_high, "%.3f") +
                        " (noncentral F, Steiger 2004)"
                  : std::string()),
         "Welch: " + (s.welch.defined
                          ? apa_f(s.welch.F, s.welch.df_between, s.welch.df_within, s.welch.p)
                          : std::string("undefined (a group has zero variance)"))});
  }
  if (want_pairs) {
    doc.heading(3, std::string("Pairwise ") + (u.welch ? "Welch" : "Student") + " t-tests");
    std::vector<std::vector<std::string>> pr;
    std::vector<std::string> apa;
    for (const auto& p : s.pairwise) {
      pr.push_back({groups[p.a] + " – " + groups[p.b], fmt(p.test.mean_diff), t_text(p.test.t),
                    fmt(p.test.df, "%.2f"), format_p(p.test.p),
                    format_p(p.p_holm, p.p_holm_is_bound),
                    stat_text(p.effect.g, 2) + " " +
                        stat_interval(p.effect.g_ci_low, p.effect.g_ci_high, 2)});
      apa.push_back(
          groups[p.a] + " vs " + groups[p.b] + ": " +
          (p.test.defined ? apa_t(p.test.t, p.test.df, p.test.p) : std::string("undefined")) +
          " (Holm " + apa_p(p.p_holm) + "), g = " + stat_text(p.effect.g, 2));
    }
    doc.table({"pair", diff_head, "t", "df", "p", "p (Holm)", "Hedges g [95% CI]"}, pr);
    doc.bullets(apa);
    if (!s.equivalence.empty()) {
      const auto& q0 = s.equivalence.front();
      doc.heading(3, "Equivalence (TOST)");
      doc.para("Margins ±" + fmt(q0.high) + (unit.empty() || unit == "1" ? "" : " " + unit) + " (" +
               margin_source +
               "). A pair is \"equivalent\" when both one-sided tests reject at α = .05 (its 90 % "
               "interval lies inside the margins), \"different\" when Welch's test rejects, "
               "and \"inconclusive\" otherwise — a non-significant test is not evidence of no "
               "difference.");
      std::vector<std::vector<std::string>> er;
      for (size_t i = 0; i < s.pairwise.size(); ++i) {
        const auto& q = s.equivalence[i];
        er.push_back({groups[s.pairwise[i].a] + " – " + groups[s.pairwise[i].b], fmt(q.mean_diff),
                      interval(q.ci_low, q.ci_high), format_p(q.p), q.verdict});
      }
      doc.table({"pair", diff_head, "90% CI", "p (TOST)", "verdict"}, er);
    }
    if (want_anova) {
      doc.heading(3, "Post-hoc comparisons");
      std::vector<std::vector<std::string>> tr;
      for (size_t i = 0; i < s.tukey.size(); ++i) {
        const auto& t = s.tukey[i];
        const auto& g = s.games_howell[i];
        tr.push_back({groups[t.a] + " – " + groups[t.b], fmt(t.mean_diff), stat_text(t.q, 3),
                      format_p(t.p), interval(t.ci_low, t.ci_high), stat_text(g.q, 3),
                      fmt(g.df, "%.2f"), format_p(g.p)});
      }
      doc.table({"pair", diff_head, "Tukey q", "Tukey p", "Tukey 95% CI", "Games–Howell q",
                 "G–H df", "G–H p"},
                tr);
    }
  }
  doc.heading(3, "Assumption checks and nonparametric tests");
  std::vector<std::string> checks = {
      "Levene (mean-centred): " + apa_spread_test(s.levene, s.levene.log10_F),
      "Brown–Forsythe (median-centred): " +
          apa_spread_test(s.brown_forsythe, s.brown_forsythe.log10_F)};
  for (size_t g = 0; g < groups.size(); ++g)
    checks.push_back("Shapiro–Wilk " + groups[g] + ": " +
                     (s.shapiro[g].defined
                          ? "W = " + fmt(s.shapiro[g].W, "%.3f") + ", " + apa_p(s.shapiro[g].p)
                          : std::string("n/a (n < 3 or constant)")));
  checks.push_back("Kruskal–Wallis: H(" + fmt(s.kruskal.df, "%.0f") +
                   ") = " + stat_text(s.kruskal.H, 2) + ", " + apa_p(s.kruskal.p));
  doc.bullets(checks);
}

// ---- Mixed model of a learning curve: value ~ group * session + (1 [+ session] | participant)
struct CurveObs {
  std::string participant;
  int group = 0, session = 0;
  double value = 0;
};
struct CurveModel {
  bool ok = false;
  std::string why_not;   // when !ok: why there is no fit
  std::string formula;   // the model that was kept
  std::string fallback;  // why the random-slope model was not kept ("" when it was)
  LmmFit fit;
  std::vector<int> levels;  // group indices present in the data, reference first
};

// Fits the model to the observations the section already collected. Group levels are coded
// "G000", "G001", ... in declaration order so the first declared group is the reference and a
// group called "1" is never read as a number. Never throws: a failure is returned with its reason.
CurveModel fit_learning_curve(const std::vector<CurveObs>& obs,
                              const std::vector<std::string>& groups) {
  CurveModel cm;
  std::map<int, std::set<std::string>> people;
  std::set<int> sessions;
  for (const auto& o : obs) people[o.group].insert(o.participant), sessions.insert(o.session);
  for (const auto& [g, ps] : people) {
    cm.levels.push_back(g);
    if (ps.size() < 2) {
      cm.why_not = "group " + groups[g] + " has " + std::to_string(ps.size()) +
                   " participant with training data, so group and participant are confounded "
                   "(the model needs at least 2 participants per group)";
      return cm;
    }
  }
  if (sessions.size() < 2) {
    cm.why_not = "there is only one training session, so there is no slope to fit";
    return cm;
  }
  CsvTable t;
  t.file = "learning curve";
  t.header = {"value", "group", "session", "participant"};
  char code[16], val[32];
  for (const auto& o : obs) {
    std::snprintf(code, sizeof code, "G%03d", o.group);
    std::snprintf(val, sizeof val, "%.17g", o.value);
    t.rows.push_back({val, code, std::to_string(o.session), "p:" + o.participant});
    t.line.push_back(static_cast<int>(t.rows.size()) + 1);
  }
  const std::string fixed = cm.levels.size() >= 2 ? "value ~ group * session" : "value ~ session";
  const std::string slope_model = fixed + " + (1 + session | participant)";
  const std::string icpt_model = fixed + " + (1 | participant)";
  try {
    cm.fit = fit_lmm(t, parse_lmm_formula(slope_model), {}, true);
    cm.formula = slope_model;
    for (const auto& w : cm.fit.warnings)
      if (w.rfind("singular fit", 0) == 0) cm.fallback = "its fit is singular (" + w + ")";
  } catch (const std::exception& e) {
    cm.fallback = std::string("it could not be fitted (") + e.what() + ")";
  }
  if (!cm.fallback.empty()) {
    try {
      cm.fit = fit_lmm(t, parse_lmm_formula(icpt_model), {}, true);
      cm.formula = icpt_model;
    } catch (const std::exception& e) {
      cm.why_not = std::string("the mixed model could not be fitted: ") + e.what();
      return cm;
    }
  }
  for (const auto& fe : cm.fit.fixed)
    if (!std::isfinite(fe.estimate) || !std::isfinite(fe.se)) {
      cm.why_not = "the mixed model's fixed effects are not finite (" + fe.name + ")";
      return cm;
    }
  cm.ok = true;
  return cm;
}

// "groupG001:session" -> "groupB:session" (the coded levels back to the group names).
std::string curve_term_name(std::string name, const std::vector<std::string>& groups) {
  const size_t at = name.find("groupG");
  if (at != std::string::npos && at + 9 <= name.size()) {
    const int g = std::atoi(name.substr(at + 6, 3).c_str());
    if (g >= 0 && g < static_cast<int>(groups.size()))
      name.replace(at + 5, 4, groups[static_cast<size_t>(g)]);
  }
  return name;
}

// Contrast vector of the fitted mean of group g at session x (x = NaN: the slope of group g).
std::vector<double> curve_contrast(const CurveModel& cm, int g, double x) {
  char code[16];
  std::snprintf(code, sizeof code, "G%03d", g);
  const std::string lvl = std::string("group") + code;
  std::vector<double> l(cm.fit.fixed.size(), 0.0);
  const bool slope_only = std::isnan(x);
  for (size_t j = 0; j < l.size(); ++j) {
    const std::string& n = cm.fit.fixed[j].name;
    if (n == "(Intercept)" || n == lvl)
      l[j] = slope_only ? 0 : 1;
    else if (n == "session" || n == lvl + ":session")
      l[j] = slope_only ? 1 : x;
  }
  return l;
}

std::pair<double, double> curve_estimate(const CurveModel& cm, const std::vector<double>& l) {
  double est = 0, var = 0;
  for (size_t a = 0; a < l.size(); ++a) {
    est += l[a] * cm.fit.fixed[a].estimate;
    for (size_t b = 0; b < l.size(); ++b) var += l[a] * cm.fit.vcov[a][b] * l[b];
  }
  return {est, std::sqrt(std::max(0.0, var))};
}

// ---- Learning curves over the phases the study declared as training (stored kind)
void section_learning_curves(Context& c, const std::vector<Unit>& units) {
  c.doc.heading(2, "Learning curves");
  std::vector<std::string> training;
  for (const auto& p : c.structure.phases)
    if (p.kind == "training") training.push_back(p.phase);
  std::set<std::string> curve_measures;
  for (const auto& u : units) curve_measures.insert(u.measure);
  bool any_curve = false;
  for (const auto& mname : curve_measures) {
    // session number across the training phases (1-based) per group
    std::map<std::pair<int, int>, std::vector<double>> cell;  // (group, session) -> values
    std::vector<CurveObs> obs;                                // the same values, per row
    int offset = 0, max_s = 0;
    for (const auto& ph : training) {
      int top = -1;
      for (const auto& m : c.measures)
        if (m.phase == ph && m.name == mname) {
          top = std::max(top, m.phase_index);
          if (m.value && std::isfinite(*m.value)) {
            cell[{c.group_index(m.group), offset + m.phase_index + 1}].push_back(*m.value);
            obs.push_back(
                {m.participant, c.group_index(m.group), offset + m.phase_index + 1, *m.value});
          }
        }
      offset += top + 1;
      max_s = offset;
    }
    if (cell.empty()) continue;
    any_curve = true;
    const std::string unit = c.unit(mname);
    const double scale = c.proportion_scale(mname);
    bool wilson = false;
    std::vector<Series> ser;
    for (size_t g = 0; g < c.groups.size(); ++g) {
      Series s;
      s.name = c.groups[g];
      s.colour = static_cast<int>(g);
      for (int k = 1; k <= max_s; ++k) {
        auto it = cell.find({static_cast<int>(g), k});
        if (it == cell.end() || it->second.empty()) continue;
        const auto& v = it->second;
        s.x.push_back(k);
        s.y.push_back(mean(v));
        const double se = v.size() >= 2 ? sd(v) / std::sqrt(v.size()) : NAN;
        int hits = 0;
        bool binary = c.binary_proportion(mname);  // one kind of bar per figure
        for (double x : v) binary = binary && (x == 0 || x == scale), hits += x == scale;
        if (binary) {  // a proportion: Wilson interval, inside [0, scale]
          auto w = wilson_interval(hits, static_cast<int>(v.size()));
          s.lo.push_back(scale * w.low);
          s.hi.push_back(scale * w.high);
          wilson = true;
        } else if (scale > 0) {  // mean of proportions: ±SE clipped to the scale
          s.lo.push_back(std::isfinite(se) ? std::max(0.0, s.y.back() - se) : NAN);
          s.hi.push_back(std::isfinite(se) ? std::min(scale, s.y.back() + se) : NAN);
        } else {
          s.lo.push_back(NAN);
          s.hi.push_back(NAN);
        }
        s.err.push_back(se);
      }
      ser.push_back(s);
    }
    const CurveModel cm = fit_learning_curve(obs, c.groups);
    std::vector<FittedLine> fits;
    // Pointwise 95 % band of the fixed-effects prediction, normal quantile (Wald).
    const double z = 1.959963984540054;
    if (cm.ok) {
      int min_s = max_s;
      for (const auto& o : obs) min_s = std::min(min_s, o.session);
      for (int g : cm.levels) {
        FittedLine fl;
        fl.colour = g;
        const int steps = 24;
        for (int i = 0; i <= steps; ++i) {
          const double x = min_s + (max_s - min_s) * static_cast<double>(i) / steps;
          auto [est, se] = curve_estimate(cm, curve_contrast(cm, g, x));
          fl.x.push_back(x);
          fl.y.push_back(est);
          fl.lo.push_back(est - z * se);
          fl.hi.push_back(est + z * se);
        }
        fits.push_back(fl);
      }
    }
    c.save_figure("learning_" + slug(mname) + ".svg",
                  svg_line_plot(ser, mname + " over training sessions", "training session",
                                with_unit(mname, unit), true, {}, fits),
                  "Learning curve of " + mname + ": group mean " +
                      (wilson      ? "with its 95 % Wilson interval"
                       : scale > 0 ? "± SE (clipped to [0, " + fmt(scale) + "])"
                                   : std::string("± SE")) +
                      " per training session (groups offset sideways so bars do not overlap)" +
                      (cm.ok ? "; dashed: the mixed model's fitted line per group (fixed effects) "
                               "with its pointwise 95 % confidence band (normal quantile)."
                             : "."));
    c.doc.heading(3, "Mixed model of the learning curve: " + mname);
    if (!cm.ok) {
      c.doc.para("No mixed model fitted: " + cm.why_not +
                 ". The figure shows the observed group means only.");
      continue;
    }
    const LmmFit& fit = cm.fit;
    std::string shown = cm.formula;  // the response under its measure name
    shown.replace(0, 5, mname);
    std::string model = "`" + shown + "`, REML, " + std::to_string(fit.n) + " observations of " +
                        std::to_string(fit.n_groups) +
                        " participants; session = training session number (1-based), reference "
                        "group " +
                        c.groups[static_cast<size_t>(cm.levels.front())] + ". Residual SD " +
                        fmt(fit.sigma) + ", participant intercept SD " + fmt(fit.sd_intercept);
    if (cm.fallback.empty())
      model += ", session slope SD " + fmt(fit.sd_slope) + " (correlation " +
               fmt(fit.correlation, "%.2f") + ").";
    else
      model +=
          ". The random-slope model `(1 + session | participant)` was not kept: " + cm.fallback +
          "; the random-intercept model is reported.";
    c.doc.para(model);
    for (const auto& w : fit.warnings) c.doc.para("Warning: " + w + ".");
    std::vector<std::vector<std::string>> fe;
    for (const auto& f : fit.fixed)
      fe.push_back({curve_term_name(f.name, c.groups), fmt(f.estimate), fmt(f.se),
                    fmt(f.df, "%.2f"), t_text(f.t), format_p(f.p)});
    c.doc.table({"fixed effect", "estimate", "SE", "df", "t", "p"}, fe);
    std::vector<std::vector<std::string>> sl;
    for (int g : cm.levels) {
      auto [est, se] = curve_estimate(cm, curve_contrast(cm, g, NAN));
      sl.push_back({c.groups[static_cast<size_t>(g)], fmt(est), fmt(se),
                    interval(est - z * se, est + z * se)});
    }
    c.doc.table({"group", "slope per session", "SE", "95% CI (normal)"}, sl);
    std::vector<std::vector<std::string>> an;
    for (const auto& a : fit.anova)
      an.push_back({a.term, std::to_string(a.num_df), fmt(a.den_df, "%.2f"), stat_text(a.f, 3),
                    format_p(a.p),
                    a.partial_eta_squared_ci.defined
                        ? fmt(a.partial_eta_squared, "%.3f") + " " +
                              interval(a.partial_eta_squared_ci.pve_low,
                                       a.partial_eta_squared_ci.pve_high, "%.3f")
                        : std::string("—")});
    c.doc.table(
        {"type III F test", "num df", "den df (Satterthwaite)", "F", "p", "partial η² [95% CI]"},
        an);
    c.doc.para(
        "Partial η² = F·num df / (F·num df + den df), its 95 % interval from the "
        "noncentral F inverted at the Satterthwaite den df (Steiger 2004; approximate, "
        "as the F of a mixed model is only approximately F-distributed).");
    if (cm.levels.size() >= 2)
      for (const auto& a : fit.anova)
        if (a.term == "group:session")
          c.doc.para("Do the groups learn differently? The group × session interaction: F(" +
                     std::to_string(a.num_df) + ", " + fmt(a.den_df, "%.2f") +
                     ") = " + stat_text(a.f, 2) + ", " + apa_p(a.p) + ".");
  }
  if (!any_curve)
    c.doc.para(training.empty() ? "The study declares no phase of kind \"training\"."
                                : "No training sessions with analysed measures in this database.");
}

// ---- Example force trace per group, with the phase's ST / MPF / SFT lines
void section_force_traces(Context& c, const std::vector<Unit>& units) {
  c.doc.heading(2, "Example force traces");
  // The first participant of each group with stored samples, in the first phase that has
  // them: the analysed phases first (in declaration order), then the others from the last.
  std::vector<std::string> candidates;
  for (const auto& u : units) candidates.push_back(u.phase);
  for (auto it = c.phase_order.rbegin(); it != c.phase_order.rend(); ++it)
    candidates.push_back(*it);
  std::vector<Series> ser;
  std::string phase;
  for (const auto& cand : candidates) {
    phase = cand;
    for (size_t g = 0; g < c.groups.size(); ++g) {
      for (const auto& p : c.participants) {
        if (p.group != c.groups[g]) continue;
        const results::SessionRecord* pick = nullptr;
        for (const auto& s : c.sessions)
          if (s.participant == p.participant && s.phase == phase) {
            pick = &s;
            break;
          }
        if (!pick) continue;
        results::SampleSeries smp = c.store.read_samples(pick->session);
        if (smp.size() == 0) continue;
        Series s;
        s.name = c.groups[g] + " (" + pick->participant + ")";
        s.colour = static_cast<int>(g);
        // Decimate to max |F| per bin so peaks (the palpation force) survive.
        const size_t n = smp.size(), bins = std::max<size_t>(1, c.options.max_trace_points);
        const size_t per = std::max<size_t>(1, (n + bins - 1) / bins);
        for (size_t i = 0; i < n; i += per) {
          double best = 0;
          for (size_t j = i; j < std::min(n, i + per); ++j)
            best = std::max(
                best, std::sqrt(smp.F[3 * j] * smp.F[3 * j] + smp.F[3 * j + 1] * smp.F[3 * j + 1] +
                                smp.F[3 * j + 2] * smp.F[3 * j + 2]));
          s.x.push_back(smp.t0 + (i + 1) * smp.dt);
          s.y.push_back(best);
        }
        ser.push_back(s);
        break;  // one participant per group
      }
    }
    if (!ser.empty()) break;
  }
  if (ser.empty()) {
    c.doc.para("No force samples stored in this database (run with --samples full).");
    return;
  }
  std::vector<ReferenceLine> refs;
  std::string thresholds_text;
  if (const auto* ph = c.phase(phase))
    if (const auto* t = feature_thresholds(*ph)) {
      refs = {{"ST " + fmt(t->st, "%.3g") + " N", t->st, "#B8860B"},
              {"MPF " + fmt(t->mpf, "%.3g") + " N", t->mpf, "#007A55"},
              {"SFT " + fmt(t->sft, "%.3g") + " N", t->sft, "#B22222"}};
      thresholds_text = " Dashed lines: the phase's thresholds for " + ph->feature +
                        " (ST sound threshold, MPF maximum palpation force, SFT stopping force).";
    }
  c.save_figure(
      "force_traces.svg",
      svg_line_plot(ser, "Force magnitude, first participant of each group (" + phase + ")",
                    "time (s)", "|F| (N)", false, refs),
      "Example force trace per group: |F| on the hand during one " + phase +
          " session (decimated to at most " + std::to_string(c.options.max_trace_points) +
          " points, keeping the peak |F| of each bin)." + thresholds_text);
}

// The report's files, once everything is made: figures and stills first, the documents that
// link them last.
void commit_files(Context& c) {
  make_out_dir(fs::path(c.out_dir) / "figures", "its SVG figures");
  if (!c.stills_stage.empty()) {
    const fs::path dir = fs::path(c.out_dir) / "stills";
    make_out_dir(dir, "the stills");
    for (const auto& png : c.files.stills) {
      std::error_code ec;
      fs::rename(c.stills_stage / fs::path(png).filename(), png, ec);
      if (ec) throw InputError("cannot write the still (" + ec.message() + ")", png);
    }
    std::error_code ec;
    fs::remove_all(c.stills_stage, ec);
    c.stage_on_signal.clear();
  }
  for (const auto& [file, content] : c.pending)
    write_file(file, content,
               fs::path(file).extension() == ".svg" ? "the figure" : "the stills' description");
}

void write_documents(Context& c) {
  c.files.markdown = (fs::path(c.out_dir) / "report.md").string();
  c.files.html = (fs::path(c.out_dir) / "report.html").string();
  write_file(c.files.markdown, c.doc.md.str(), "the report");
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>"
       << xml_escape(c.study.title) << "</title>\n<style>\n"
       << "body{font-family:Helvetica,Arial,sans-serif;max-width:960px;margin:2em auto;padding:0 "
          "1em;color:#222}\n"
       // Wide tables scroll inside the page instead of being cut at the body width.
       << "table{border-collapse:collapse;margin:0.5em 0 1em;display:block;max-width:100%;"
          "overflow-x:auto}th,td{border:1px solid "
          "#ccc;padding:3px 8px;"
          "text-align:right}th:first-child,td:first-child{text-align:left}th{background:#f3f3f3}\n"
       << "figure{margin:1em "
          "0}figcaption{font-size:0.9em;color:#555}svg{max-width:100%;height:auto}\n"
       // Stills side by side, wrapping to the next line on a narrow page.
       << ".stills{display:flex;flex-wrap:wrap;gap:12px}.stills figure{flex:1 1 220px;"
          "max-width:480px;margin:0.5em 0}.stills img{display:block;width:100%;height:auto;"
          "border:1px solid #ddd;margin-bottom:4px}\n"
       << "</style>\n</head>\n<body>\n"
       << c.doc.html.str() << "</body>\n</html>\n";
  write_file(c.files.html, html.str(), "the report");
}

// The whole report of the loaded database, every file written at the end (commit_files).
void make_report(Context& c) {
  const std::vector<Unit> units = analysis_units(c);
  if (c.declared.contains("analyses") && c.declared["analyses"].is_array())
    c.files.declared = static_cast<int>(c.declared["analyses"].size());
  const std::vector<Hypothesis> hypotheses = declared_hypotheses(c);
  section_provenance(c);
  {
    // The stills' press comes from the analysed phases first, then the others from the last.
    std::vector<std::string> phases;
    for (const auto& u : units) phases.push_back(u.phase);
    phases.insert(phases.end(), c.phase_order.rbegin(), c.phase_order.rend());
    section_stills(c, phases);
  }
  if (!hypotheses.empty()) {
    section_confirmatory(c, hypotheses);
    c.doc.heading(2, "Exploratory analyses");
    c.doc.para(
        "Not declared in advance: the analyses below describe the data and generate hypotheses; "
        "their p-values are not confirmatory evidence.");
  }
  for (const auto& u : units) section_analysis(c, u);
  section_learning_curves(c, units);
  section_force_traces(c, units);
  commit_files(c);
  write_documents(c);
}

}  // namespace

ReportFiles write_report(const std::string& db_path, const std::string& out_dir,
                         const ReportOptions& options) {
  Context c = load(db_path, out_dir, options);
  check_out_dir(out_dir, options.stills != nullptr);
  try {
    make_report(c);
  } catch (...) {
    // Nothing of a failed report is left: no file was written, and its stills' stage goes.
    std::error_code ec;
    if (!c.stills_stage.empty()) fs::remove_all(c.stills_stage, ec);
    throw;
  }
  return c.files;
}

}  // namespace palplab::analysis
