#include "analysis/report.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"
#include "analysis/summary.hpp"
#include "analysis/svg.hpp"
#include "common/input_error.hpp"
#include "palplab/version.hpp"
#include "results/store.hpp"

namespace palplab::analysis {

namespace fs = std::filesystem;

namespace {

std::string fmt(double v, const char* f = "%.4g") {
  if (!std::isfinite(v)) return "n/a";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// "[lo, hi]" (a helper rather than operator+ chains: GCC 12 warns falsely on those).
std::string interval(double lo, double hi, const char* f = "%.4g") {
  std::string s = "[";
  s += fmt(lo, f);
  s += ", ";
  s += fmt(hi, f);
  s += "]";
  return s;
}

std::string md_cell(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '|' ? std::string("\\|") : std::string(1, c);
  return o;
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

}  // namespace

ReportFiles write_report(const std::string& db_path, const std::string& out_dir,
                         const ReportOptions& options) {
  if (!fs::exists(db_path)) throw InputError("no such results database", db_path);
  results::Store store = results::Store::open(db_path);
  const results::StudyRecord study = store.read_study();
  const auto participants = store.read_participants();
  const auto sessions = store.read_sessions();
  const auto measures = store.read_measures();
  const auto prototypes = store.read_prototypes();

  nlohmann::json sj;
  try {
    sj = nlohmann::json::parse(study.json);
  } catch (const std::exception& e) {
    throw InputError(SourceLocation{db_path, 0, 0, -1, "study.json"},
                     std::string("the stored study JSON does not parse: ") + e.what());
  }
  // Group order: as the study declares them, then any others in participant order.
  std::vector<std::string> groups;
  if (sj.contains("groups") && sj["groups"].is_array())
    for (const auto& g : sj["groups"])
      if (g.contains("id") && g["id"].is_string()) groups.push_back(g["id"]);
  std::map<std::string, std::string> group_of;
  for (const auto& p : participants) {
    group_of[p.participant] = p.group;
    if (std::find(groups.begin(), groups.end(), p.group) == groups.end()) groups.push_back(p.group);
  }
  auto group_index = [&](const std::string& g) {
    return static_cast<int>(std::find(groups.begin(), groups.end(), g) - groups.begin());
  };
  std::map<std::string, std::string> unit_of;
  for (const auto& m : measures) unit_of[m.name] = m.unit;
  std::vector<std::string> phase_order;
  std::map<std::string, std::string> phase_kind;
  if (sj.contains("phases") && sj["phases"].is_array())
    for (const auto& p : sj["phases"])
      if (p.contains("id") && p["id"].is_string()) {
        phase_order.push_back(p["id"]);
        phase_kind[p["id"]] = p.value("kind", std::string("other"));
      }
  for (const auto& s : sessions)
    if (std::find(phase_order.begin(), phase_order.end(), s.phase) == phase_order.end())
      phase_order.push_back(s.phase);

  // The analyses the study declares, merged per (measure, phase, pooled); a study without any
  // gets ANOVA + pairwise t of every measure in its last phase.
  std::vector<Unit> units;
  auto unit_for = [&](const std::string& m, const std::string& ph, bool pooled) -> Unit& {
    for (auto& u : units)
      if (u.measure == m && u.phase == ph && u.pooled == pooled) return u;
    units.push_back({m, ph, pooled, true, {}});
    return units.back();
  };
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
  if (units.empty() && !phase_order.empty()) {
    std::set<std::string> names;
    for (const auto& m : measures) names.insert(m.name);
    for (const auto& n : names) {
      Unit& u = unit_for(n, phase_order.back(), false);
      u.kinds = {"descriptives", "anova_oneway", "pairwise_t"};
    }
  }

  fs::create_directories(fs::path(out_dir) / "figures");
  ReportFiles files;
  Doc doc;
  auto save_figure = [&](const std::string& name, const std::string& svg, const std::string& cap) {
    std::ofstream(fs::path(out_dir) / "figures" / name) << svg;
    files.figures.push_back((fs::path(out_dir) / "figures" / name).string());
    doc.figure(svg, name, cap);
  };

  // ---- Study and provenance
  doc.md << "# " << study.title << "\n\n";
  doc.html << "<h1>" << xml_escape(study.title) << "</h1>\n";
  if (sj.contains("description") && sj["description"].is_string()) doc.para(sj["description"]);
  if (study.finished_at.empty())
    doc.para(
        "**Warning: INCOMPLETE database.** The run did not finish (study.finished_at is NULL): "
        "sessions or participants may be missing, and every result below is provisional.");
  doc.heading(2, "Study and provenance");
  std::map<std::string, int> per_group;
  for (const auto& p : participants) per_group[p.group]++;
  std::string design;
  for (const auto& g : groups)
    design += (design.empty() ? "" : ", ") + g + ": " + std::to_string(per_group[g]);
  std::string phases_text;
  for (const auto& ph : phase_order) {
    int n = 0;
    for (const auto& s : sessions) n += s.phase == ph;
    phases_text += (phases_text.empty() ? "" : ", ") + ph + " (" + std::to_string(n) + " sessions)";
  }
  doc.table({"item", "value"},
            {{"study id", study.study_id},
             {"study file SHA-256", study.sha256},
             {"seed", std::to_string(study.seed)},
             {"run by palplab", study.palplab_version + " (" + study.git_commit + ")"},
             {"started", study.started_at},
             {"finished",
              study.finished_at.empty() ? "INCOMPLETE (run not finished)" : study.finished_at},
             {"participants per group", design},
             {"sessions stored", std::to_string(sessions.size()) + " — " + phases_text},
             {"report by palplab", std::string(kVersion) + " (" + kGitCommit + ")"},
             {"database", db_path}});
  if (!prototypes.empty()) {
    std::vector<std::vector<std::string>> rows;
    for (const auto& p : prototypes) rows.push_back({p.prototype, p.path, p.sha256});
    doc.para("Prototype files used (as stored with the results):");
    doc.table({"prototype", "file", "SHA-256"}, rows);
  }
  doc.para(
      "Statistics: palplab analysis (GSL; own studentized range). Pairwise t-tests use "
      "Welch's unequal-variance test unless the study says otherwise; p-values are "
      "Holm-adjusted over the pairs; Hedges' g with a 95 % noncentral-t interval that inverts "
      "the same t as the test beside it (Welch's t and df for a Welch test). "
      "APA style: p < .001 below .001.");

  // ---- Analyses
  for (const auto& u : units) {
    ++files.analyses;
    const std::string unit = unit_of.count(u.measure) ? unit_of[u.measure] : "";
    const std::string label = u.measure + (unit.empty() || unit == "1" ? "" : " (" + unit + ")");
    const bool means = u.pooled && !u.pool_sessions;
    doc.heading(
        2, "Analysis: " + u.measure + " — phase " + u.phase +
               (means ? " (participant means over all sessions)"
                      : (u.pooled ? " (all sessions pooled)" : " (last session of the phase)")));
    if (u.pooled && u.pool_sessions)
      doc.para(
          "**Warning: pseudo-replication.** The study asks for every session to be pooled as an "
          "independent observation, but sessions of one participant are not independent: "
          "degrees of freedom and p-values below overstate the evidence. Participant means "
          "(the default for pooled analyses) or a mixed model are the valid analyses.");
    // Values: per participant the last session of the phase, or every session when pooled.
    std::map<std::string, int> last_index;
    for (const auto& m : measures)
      if (m.phase == u.phase && m.name == u.measure)
        last_index[m.participant] = std::max(
            last_index.count(m.participant) ? last_index[m.participant] : -1, m.phase_index);
    GroupedData data;
    data.names = groups;
    data.values.assign(groups.size(), {});
    std::vector<int> undefined(groups.size(), 0);
    std::vector<ParticipantPoint> points;
    // Participant means: the defined values of each participant's sessions, averaged in
    // participant order of first appearance (one value per participant).
    std::map<std::string, std::pair<long double, int>> sums;
    std::vector<std::pair<std::string, int>> order;
    for (const auto& m : measures) {
      if (m.phase != u.phase || m.name != u.measure) continue;
      if (!u.pooled && m.phase_index != last_index[m.participant]) continue;
      int g = group_index(m.group);
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
      if (u.pooled) {
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
    int total = 0, excluded = 0;
    for (size_t g = 0; g < groups.size(); ++g)
      total += data.values[g].size(), excluded += undefined[g];
    if (total == 0) {
      doc.para("No defined values of " + u.measure + " in phase " + u.phase + " (" +
               std::to_string(excluded) + " undefined).");
      continue;
    }
    if (excluded > 0) {
      std::string t =
          "Undefined values left out (e.g. force when the feature was not identified): ";
      for (size_t g = 0; g < groups.size(); ++g)
        t += (g ? ", " : "") + groups[g] + " " + std::to_string(undefined[g]);
      doc.para(t + ".");
    }
    // Descriptives (always).
    doc.heading(3, "Descriptives");
    std::vector<std::vector<std::string>> rows;
    for (size_t g = 0; g < groups.size(); ++g) {
      if (data.values[g].empty()) {
        rows.push_back({groups[g], "0", "", "", "", "", "", "", "", ""});
        continue;
      }
      Descriptives d = describe(data.values[g]);
      rows.push_back({groups[g], std::to_string(d.n), fmt(d.mean), fmt(d.sd), fmt(d.se),
                      fmt(d.median), fmt(d.iqr), fmt(d.min), fmt(d.max),
                      d.n >= 2 ? interval(d.ci_low, d.ci_high) : std::string("n/a")});
    }
    doc.table({"group", "n", "mean", "SD", "SE", "median", "IQR", "min", "max", "95% CI"}, rows);
    const std::string base = slug(u.measure + "_" + u.phase + (u.pooled ? "_pooled" : ""));
    save_figure(base + "_box.svg",
                svg_box_plot(groups, data.values, u.measure + " by group, " + u.phase, label),
                "Range and box plot per group (box: quartiles, line: median, whiskers: min–max; "
                "dots: every value) of " +
                    u.measure + ", phase " + u.phase + ".");
    save_figure(
        base + "_participants.svg",
        svg_participant_plot(groups, points, u.measure + " per participant, " + u.phase, label),
        "Individual values per participant of " + u.measure + ", phase " + u.phase + ".");

    // Inference needs two groups with two values each.
    std::vector<int> usable;
    for (size_t g = 0; g < groups.size(); ++g)
      if (data.values[g].size() >= 2) usable.push_back(static_cast<int>(g));
    if (usable.size() < 2 || usable.size() < groups.size()) {
      doc.para("Not enough data for tests: every group needs at least 2 defined values.");
      continue;
    }
    StatsOptions opt;
    opt.welch_pairwise = u.welch;
    // Equivalence margins: the study's, else ±7 % (force Weber fraction) of the grand mean for
    // a force; other measures without a declared margin get no equivalence test.
    std::string margin_source;
    if (u.margin > 0) {
      opt.margins = std::make_pair(-u.margin, u.margin);
      margin_source = "declared by the study";
    } else if (unit == "N") {
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
        margin_source = "default: ±7 % (force Weber fraction) of the grand mean";
      }
    }
    StatsSummary s = summarize(data, opt);
    const bool want_anova = u.kinds.count("anova_oneway") > 0;
    const bool want_pairs = u.kinds.count("pairwise_t") > 0 || want_anova;
    if (want_anova) {
      doc.heading(3, "One-way ANOVA");
      const auto& a = s.anova;
      doc.table({"source", "df", "SS", "MS", "F", "p"},
                {{"between groups", fmt(a.df_between, "%.0f"), fmt(a.ss_between), fmt(a.ms_between),
                  fmt(a.F, "%.3f"), format_p(a.p)},
                 {"within groups", fmt(a.df_within, "%.0f"), fmt(a.ss_within), fmt(a.ms_within), "",
                  ""}});
      doc.bullets(
          {"Classical: " + apa_anova(a) + ", η² = " + fmt(a.eta_squared, "%.3f") +
               ", ω² = " + fmt(a.omega_squared, "%.3f"),
           "Welch: " + (s.welch.defined
                            ? apa_f(s.welch.F, s.welch.df_between, s.welch.df_within, s.welch.p)
                            : std::string("undefined (a group has zero variance)"))});
    }
    if (want_pairs) {
      doc.heading(3, std::string("Pairwise ") + (u.welch ? "Welch" : "Student") + " t-tests");
      std::vector<std::vector<std::string>> pr;
      std::vector<std::string> apa;
      for (const auto& p : s.pairwise) {
        pr.push_back({groups[p.a] + " – " + groups[p.b], fmt(p.test.mean_diff),
                      fmt(p.test.t, "%.3f"), fmt(p.test.df, "%.2f"), format_p(p.test.p),
                      format_p(p.p_holm),
                      fmt(p.effect.g, "%.2f") + " " +
                          interval(p.effect.g_ci_low, p.effect.g_ci_high, "%.2f")});
        apa.push_back(
            groups[p.a] + " vs " + groups[p.b] + ": " +
            (p.test.defined ? apa_t(p.test.t, p.test.df, p.test.p) : std::string("undefined")) +
            " (Holm " + apa_p(p.p_holm) + "), g = " + fmt(p.effect.g, "%.2f"));
      }
      doc.table({"pair", "mean diff" + (unit.empty() || unit == "1" ? "" : " (" + unit + ")"), "t",
                 "df", "p", "p (Holm)", "Hedges g [95% CI]"},
                pr);
      doc.bullets(apa);
      if (!s.equivalence.empty()) {
        const auto& q0 = s.equivalence.front();
        doc.heading(3, "Equivalence (TOST)");
        doc.para(
            "Margins ±" + fmt(q0.high) + (unit.empty() || unit == "1" ? "" : " " + unit) + " (" +
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
        doc.table({"pair", "mean diff", "90% CI", "p (TOST)", "verdict"}, er);
      }
      if (want_anova) {
        doc.heading(3, "Post-hoc comparisons");
        std::vector<std::vector<std::string>> tr;
        for (size_t i = 0; i < s.tukey.size(); ++i) {
          const auto& t = s.tukey[i];
          const auto& g = s.games_howell[i];
          tr.push_back({groups[t.a] + " – " + groups[t.b], fmt(t.mean_diff), fmt(t.q, "%.3f"),
                        format_p(t.p), interval(t.ci_low, t.ci_high), fmt(g.q, "%.3f"),
                        fmt(g.df, "%.2f"), format_p(g.p)});
        }
        doc.table({"pair", "mean diff", "Tukey q", "Tukey p", "Tukey 95% CI", "Games–Howell q",
                   "G–H df", "G–H p"},
                  tr);
      }
    }
    doc.heading(3, "Assumption checks and nonparametric tests");
    std::vector<std::string> checks = {
        "Levene (mean-centred): " + apa_anova(s.levene),
        "Brown–Forsythe (median-centred): " + apa_anova(s.brown_forsythe)};
    for (size_t g = 0; g < groups.size(); ++g)
      checks.push_back("Shapiro–Wilk " + groups[g] + ": " +
                       (s.shapiro[g].defined
                            ? "W = " + fmt(s.shapiro[g].W, "%.3f") + ", " + apa_p(s.shapiro[g].p)
                            : std::string("n/a (n < 3 or constant)")));
    checks.push_back("Kruskal–Wallis: H(" + fmt(s.kruskal.df, "%.0f") +
                     ") = " + fmt(s.kruskal.H, "%.2f") + ", " + apa_p(s.kruskal.p));
    doc.bullets(checks);
  }

  // ---- Learning curves over training sessions
  doc.heading(2, "Learning curves");
  std::vector<std::string> training;
  for (const auto& ph : phase_order)
    if (phase_kind.count(ph) ? phase_kind[ph] == "training" : ph.find("train") != std::string::npos)
      training.push_back(ph);
  std::set<std::string> curve_measures;
  for (const auto& u : units) curve_measures.insert(u.measure);
  bool any_curve = false;
  for (const auto& mname : curve_measures) {
    // session number across the training phases (1-based) per group
    std::map<std::pair<int, int>, std::vector<double>> cell;  // (group, session) -> values
    int offset = 0, max_s = 0;
    for (const auto& ph : training) {
      int top = -1;
      for (const auto& m : measures)
        if (m.phase == ph && m.name == mname) {
          top = std::max(top, m.phase_index);
          if (m.value && std::isfinite(*m.value))
            cell[{group_index(m.group), offset + m.phase_index + 1}].push_back(*m.value);
        }
      offset += top + 1;
      max_s = offset;
    }
    if (cell.empty()) continue;
    any_curve = true;
    std::vector<Series> ser;
    for (size_t g = 0; g < groups.size(); ++g) {
      Series s;
      s.name = groups[g];
      s.colour = static_cast<int>(g);
      for (int k = 1; k <= max_s; ++k) {
        auto it = cell.find({static_cast<int>(g), k});
        if (it == cell.end() || it->second.empty()) continue;
        s.x.push_back(k);
        s.y.push_back(mean(it->second));
        s.err.push_back(it->second.size() >= 2 ? sd(it->second) / std::sqrt(it->second.size())
                                               : NAN);
      }
      ser.push_back(s);
    }
    const std::string unit = unit_of.count(mname) ? unit_of[mname] : "";
    save_figure("learning_" + slug(mname) + ".svg",
                svg_line_plot(ser, mname + " over training sessions", "training session",
                              mname + (unit.empty() || unit == "1" ? "" : " (" + unit + ")")),
                "Learning curve of " + mname + ": group mean ± SE per training session.");
  }
  if (!any_curve) doc.para("No training sessions with analysed measures in this database.");

  // ---- Example force trace per group
  doc.heading(2, "Example force traces");
  {
    // The first participant of each group with stored samples, in the first phase that has
    // them: the analysed phases first (in declaration order), then the others from the last.
    std::vector<std::string> candidates;
    for (const auto& u : units) candidates.push_back(u.phase);
    for (auto it = phase_order.rbegin(); it != phase_order.rend(); ++it) candidates.push_back(*it);
    std::vector<Series> ser;
    std::string phase;
    for (const auto& cand : candidates) {
      phase = cand;
      for (size_t g = 0; g < groups.size(); ++g) {
        for (const auto& p : participants) {
          if (p.group != groups[g]) continue;
          const results::SessionRecord* pick = nullptr;
          for (const auto& s : sessions)
            if (s.participant == p.participant && s.phase == phase) {
              pick = &s;
              break;
            }
          if (!pick) continue;
          results::SampleSeries smp = store.read_samples(pick->session);
          if (smp.size() == 0) continue;
          Series s;
          s.name = groups[g] + " (" + pick->participant + ")";
          s.colour = static_cast<int>(g);
          // Decimate to max |F| per bin so peaks (the palpation force) survive.
          const size_t n = smp.size(), bins = std::max<size_t>(1, options.max_trace_points);
          const size_t per = std::max<size_t>(1, (n + bins - 1) / bins);
          for (size_t i = 0; i < n; i += per) {
            double best = 0;
            for (size_t j = i; j < std::min(n, i + per); ++j)
              best = std::max(best, std::sqrt(smp.F[3 * j] * smp.F[3 * j] +
                                              smp.F[3 * j + 1] * smp.F[3 * j + 1] +
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
      doc.para("No force samples stored in this database (run with --samples full).");
    } else {
      save_figure(
          "force_traces.svg",
          svg_line_plot(ser, "Force magnitude, first participant of each group (" + phase + ")",
                        "time (s)", "|F| (N)", false),
          "Example force trace per group: |F| on the hand during one " + phase +
              " session (decimated to at most " + std::to_string(options.max_trace_points) +
              " points, keeping the peak |F| of each bin).");
    }
  }

  files.markdown = (fs::path(out_dir) / "report.md").string();
  files.html = (fs::path(out_dir) / "report.html").string();
  std::ofstream(files.markdown) << doc.md.str();
  std::ofstream html(files.html);
  html << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>"
       << xml_escape(study.title) << "</title>\n<style>\n"
       << "body{font-family:Helvetica,Arial,sans-serif;max-width:960px;margin:2em auto;padding:0 "
          "1em;color:#222}\n"
       // Wide tables scroll inside the page instead of being cut at the body width.
       << "table{border-collapse:collapse;margin:0.5em 0 1em;display:block;max-width:100%;"
          "overflow-x:auto}th,td{border:1px solid "
          "#ccc;padding:3px 8px;"
          "text-align:right}th:first-child,td:first-child{text-align:left}th{background:#f3f3f3}\n"
       << "figure{margin:1em "
          "0}figcaption{font-size:0.9em;color:#555}svg{max-width:100%;height:auto}\n"
       << "</style>\n</head>\n<body>\n"
       << doc.html.str() << "</body>\n</html>\n";
  if (!html) throw InputError("cannot write the report", files.html);
  return files;
}

}  // namespace palplab::analysis
