// `palplab stats --csv FILE --value COL --group COL [--where COL=VALUE ...]
//                [--df-mode exact|floor] [--margin M | --margins LOW,HIGH] [--alpha A] [--json]`:
//                descriptives per group, classical and
// Welch ANOVA, every pairwise Welch t-test (Holm/Bonferroni), post-hoc tests, assumption
// checks; APA lines. Bad input (missing column, non-numeric value, a group with < 2 values,
// more than 100 groups (the pairwise tests grow with their square; analysis/grouped.cpp), bad
// --where) → InputError → exit 2 with the CSV line.
#include <cmath>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include <nlohmann/json.hpp>

#include "analysis/csv.hpp"
#include "analysis/grouped.hpp"
#include "analysis/report.hpp"
#include "analysis/summary.hpp"
#include "app/command.hpp"
#include "app/output_dir.hpp"
#include "app/stills.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "common/remove_on_signal.hpp"
#include "results/store.hpp"

namespace {

// A still's file name as the report writes it: "<prototype>_pressed.png" or "<prototype>_rest.png".
bool named_like_a_still(const std::string& name) {
  for (const std::string_view suffix : {"_pressed.png", "_rest.png"})
    if (name.size() > suffix.size() && name.ends_with(suffix)) return true;
  return false;
}

struct StatsArgs {
  std::string csv, value, group, df_mode = "exact";
  std::vector<std::string> where;
  bool json = false, skip_empty = false;
  std::optional<double> margin;
  std::vector<double> margins;
  double alpha = 0.05;
};

// A participant with several rows (sessions, phases) among those analysed is allowed, but said,
// since the tests take every row as an independent observation; different measures (or units)
// are an error (analysis::check_one_measure).
void check_one_measure(const palplab::analysis::CsvTable& t, const std::vector<int>& rows,
                       const std::string& value_column) {
  palplab::analysis::check_one_measure(t, rows, value_column, "--where ");
  auto column = [&](const std::string& name) {
    for (std::size_t c = 0; c < t.header.size(); ++c)
      if (t.header[c] == name && name != value_column) return static_cast<int>(c);
    return -1;
  };
  const int p = column("participant");
  if (p < 0) return;
  std::map<std::string, int> count;
  for (const int r : rows) ++count[palplab::analysis::trim_blanks(t.rows[r][p])];
  int repeated = 0;
  std::string example;
  for (const auto& [id, k] : count)
    if (k > 1 && repeated++ == 0)
      example = "'" + palplab::analysis::shown_text(id) + "' " + std::to_string(k) + " rows";
  if (repeated > 0)
    std::cerr << "warning: " << t.file << ": " << repeated
              << " participant(s) have more than one row among those analysed (" << example
              << "); the tests take every row as an independent observation: select one row per "
                 "participant (--where session=..., --where phase=...) or average each "
                 "participant's rows first\n";
}

palplab::app::CommandRegistration reg_stats{
    "stats", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "stats",
          "One-way analysis of a CSV column by group: descriptives, ANOVA (classical and "
          "Welch), pairwise Welch t-tests, post-hoc and assumption tests");
      auto a = std::make_shared<StatsArgs>();
      cmd->add_option("--csv", a->csv, "CSV file (RFC 4180, header row)")->required();
      cmd->add_option("--value", a->value, "Column with the measured values")->required();
      cmd->add_option("--group", a->group, "Column with the group labels")->required();
      cmd->add_option("--where", a->where,
                      "Keep rows with COL=VALUE (repeatable; same column: OR, different: AND)");
      cmd->add_option("--df-mode", a->df_mode,
                      "Welch df: exact (Welch-Satterthwaite) or floor (truncated, as MINITAB)")
          ->check(CLI::IsMember({"exact", "floor"}));
      cmd->add_flag("--skip-empty", a->skip_empty,
                    "Leave out rows whose value is empty or NA (undefined measures) instead of "
                    "failing; their number is reported");
      cmd->add_option("--margin", a->margin,
                      "Equivalence margin M (> 0, data units): every pair also gets a TOST of "
                      "|mean difference| < M and a verdict (equivalent/different/inconclusive)")
          ->check(palplab::app::finite_range(0, std::numeric_limits<double>::max(), true));
      cmd->add_option("--margins", a->margins,
                      "Asymmetric equivalence margins LOW,HIGH (LOW < 0 < HIGH, data units)")
          ->delimiter(',')
          ->expected(2)
          ->check(palplab::app::finite_range(-std::numeric_limits<double>::max(),
                                             std::numeric_limits<double>::max()));
      auto* alpha_opt =
          cmd->add_option("--alpha", a->alpha, "Level of the equivalence tests (default 0.05)")
              ->check(palplab::app::finite_range(1e-9, 0.5, false, true));
      cmd->add_flag("--json", a->json, "Print JSON instead of tables");
      cmd->callback([a, alpha_opt, code] {
        palplab::app::flag_only_with(alpha_opt, a->margin || !a->margins.empty(),
                                     "--margin or --margins (it is the equivalence tests' level)");
        using namespace palplab::analysis;
        // One column as both values and labels makes every value its own group's label: a
        // meaningless analysis (it ran, or failed on "group '1' has 1 value").
        if (a->value == a->group)
          throw palplab::InputError(palplab::SourceLocation{"--group"},
                                    "--value and --group name the same column ('" +
                                        shown_text(a->value) +
                                        "'); --group takes the column of group labels");
        std::vector<WhereFilter> where;
        for (const auto& w : a->where) where.push_back(parse_where(w));
        CsvTable t = read_csv(a->csv);
        GroupedData data = group_table(t, a->value, a->group, where, 2, 2, a->skip_empty);
        check_one_measure(t, filter_rows(t, where), a->value);
        StatsOptions opt;
        opt.df_mode = a->df_mode == "floor" ? DfMode::Floor : DfMode::Exact;
        opt.alpha = a->alpha;  // in [1e-9, 0.5) (the option's check)
        if (a->margin && !a->margins.empty())
          throw palplab::InputError(palplab::SourceLocation{"--margin"},
                                    "give either --margin or --margins, not both");
        if (a->margin) opt.margins = std::make_pair(-*a->margin, *a->margin);  // > 0 (checked)
        if (!a->margins.empty()) {
          // An equivalence region holds "no difference", as a study's tost margins must.
          if (!(a->margins[0] < 0 && a->margins[1] > 0))
            throw palplab::InputError(
                palplab::SourceLocation{"--margins"},
                "expected LOW,HIGH with LOW < 0 < HIGH (the region of differences taken as "
                "equivalent), got " +
                    palplab::app::shown_number(a->margins[0]) + "," +
                    palplab::app::shown_number(a->margins[1]));
          opt.margins = std::make_pair(a->margins[0], a->margins[1]);
        }
        StatsSummary s = summarize(data, opt);
        if (a->json) {
          auto j = to_json(s);
          j["input"] = {{"csv", a->csv},
                        {"value", a->value},
                        {"group", a->group},
                        {"where", a->where},
                        {"rows_used", data.rows_used},
                        {"rows_skipped_empty", data.rows_skipped_empty}};
          std::cout << j.dump(2) << "\n";
        } else {
          std::cout << "palplab stats: " << palplab::escape_controls(a->value, false) << " by "
                    << palplab::escape_controls(a->group, false) << " (" << data.rows_used
                    << " rows of " << palplab::escape_controls(a->csv, false)
                    << (data.rows_skipped_empty > 0
                            ? ", " + std::to_string(data.rows_skipped_empty) +
                                  " rows with an empty value or group skipped"
                            : std::string())
                    << ")\n\n"
                    << to_text(s);
        }
        *code = 0;
      });
    }};
}  // namespace

// `palplab report DB --out DIR [--no-stills] [--still-size WxH] [--overwrite]`: report.md,
// self-contained report.html, figures/*.svg and stills/*.png from a results database
// (analysis/report.hpp).
// Registered here because it is the statistics' front end; bad input (missing or foreign
// database, bad size) → exit 2. Stills need EGL: without it the report is written all the same
// and says in one line why it has none.
namespace {
struct ReportArgs {
  std::string db, out, still_size = "480x360";
  bool no_stills = false, overwrite = false;
};

// A report.md / report.html written by `palplab report` (the same opening and provenance
// heading since its first version), replaced without --overwrite.
bool is_report_md(const std::string& path) {
  return palplab::app::output_head_has(path, "# ", "\n## Study and provenance\n");
}
bool is_report_html(const std::string& path) {
  return palplab::app::output_head_has(path, "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n",
                                       "<h2>Study and provenance</h2>");
}

// Before the report is written into --out: the database is not where the report writes
// (DIR/report.md, DIR/figures/x.svg: it was truncated and replaced by the report), and a
// report.md or report.html that is not a palplab report (the user's own) is replaced only with
// --overwrite (app/output_dir.hpp).
void check_report_out(const ReportArgs& a) {
  using namespace palplab::app;
  // The report writes into (and removes an earlier report's files from) DIR/figures and
  // DIR/stills: a link there would make it write or remove files outside --out.
  for (const char* sub : {"figures", "stills"}) {
    const std::string p = (std::filesystem::path(a.out) / sub).string();
    std::error_code ec;
    if (std::filesystem::is_symlink(std::filesystem::symlink_status(p, ec)))
      throw palplab::InputError(
          palplab::SourceLocation{"--out"},
          "\"" + p + "\" is a symbolic link; the report writes its " + sub +
              " there and never through a link (it could write or remove files outside --out): "
              "remove the link or choose another --out");
  }
  const std::vector<CommandInput> inputs{{"the results database", a.db}};
  const std::string contents = "report.md, report.html, figures/ and stills/";
  require_replaceable_dir_outputs("--out", a.out, contents,
                                  {{"report.md", "palplab report (report.md)", is_report_md},
                                   {"report.html", "palplab report (report.html)", is_report_html}},
                                  inputs, "--overwrite", a.overwrite);
  require_no_input_under("--out", a.out, "figures", {".svg"}, {}, inputs, "its SVG figures");
  if (!a.no_stills)
    require_no_input_under("--out", a.out, "stills", {".png"}, {"stills.json"}, inputs,
                           "the stills");
  // The figures' and stills' names are known only as the report runs: a foreign file that could
  // carry one of them (any SVG under figures/; a PNG named like a still, or stills.json) is
  // refused unless --overwrite. palplab's own figures open as analysis/svg.cpp writes them; its
  // stills are the files its stills.json lists.
  require_own_files_under(
      "--out", a.out, "figures", [](const std::string& n) { return n.ends_with(".svg"); },
      "palplab report figure",
      [](const std::string& p) {
        return palplab::app::output_head_has(p,
                                             "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"",
                                             "font-family=\"Helvetica, Arial, sans-serif\"", 4096);
      },
      "--overwrite", a.overwrite);
  if (a.no_stills) return;
  const std::string listing = (std::filesystem::path(a.out) / "stills" / "stills.json").string();
  // The listing first: a foreign one would make palplab's own stills look foreign.
  require_own_files_under(
      "--out", a.out, "stills", [](const std::string& n) { return n == "stills.json"; },
      "palplab report stills listing",
      [](const std::string& p) {
        return palplab::app::output_head_has(p, "{", "\"camera_convention\"");
      },
      "--overwrite", a.overwrite);
  require_own_files_under(
      "--out", a.out, "stills", named_like_a_still, "palplab report still",
      [&](const std::string& p) {
        const std::string name = std::filesystem::path(p).filename().string();
        return palplab::app::output_head_has(listing, "{", "\"stills/" + name + "\"");
      },
      "--overwrite", a.overwrite);
}

// The files of an earlier palplab report in DIR that a new report may not write again: its
// figures (figures/*.svg as analysis/svg.cpp writes them) and its stills (the PNGs
// DIR/stills/stills.json lists, and that listing). Regular files only; a file that is not
// recognised as palplab's is not among them.
std::vector<std::filesystem::path> earlier_report_files(const std::string& out) {
  namespace fs = std::filesystem;
  std::vector<fs::path> found;
  std::error_code ec;
  auto regular = [](const fs::path& p) {
    std::error_code e;
    return fs::is_regular_file(fs::symlink_status(p, e));
  };
  for (fs::directory_iterator it(fs::path(out) / "figures", ec), end; !ec && it != end;
       it.increment(ec))
    if (it->path().extension() == ".svg" && regular(it->path()) &&
        palplab::app::output_head_has(it->path().string(),
                                      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"",
                                      "font-family=\"Helvetica, Arial, sans-serif\"", 4096))
      found.push_back(it->path().lexically_normal());
  const fs::path listing = fs::path(out) / "stills" / "stills.json";
  if (!regular(listing) ||
      !palplab::app::output_head_has(listing.string(), "{", "\"camera_convention\""))
    return found;
  nlohmann::json js;
  try {
    js = nlohmann::json::parse(palplab::app::file_head(listing.string(), std::size_t{64} << 20));
  } catch (const nlohmann::json::exception&) {
    return found;  // not a listing this palplab can read: its stills are left alone
  }
  found.push_back(listing.lexically_normal());
  if (!js.contains("stills") || !js["stills"].is_array()) return found;
  for (const auto& s : js["stills"])
    for (const char* key : {"pressed", "rest"}) {
      if (!s.is_object() || !s.contains(key) || !s[key].is_string()) continue;
      // Only a still directly in DIR/stills, named as the report names them
      // ("stills/A_pressed.png"): any other name a listing holds is left alone.
      const fs::path rel = s[key].get<std::string>();
      const std::string name = rel.filename().string();
      if (rel.parent_path() != "stills" || !named_like_a_still(name)) continue;
      const fs::path p = fs::path(out) / "stills" / rel.filename();
      if (regular(p)) found.push_back(p.lexically_normal());
    }
  return found;
}

// After the report is written: the files of an earlier report (earlier_report_files) that this
// one did not write are removed, so that DIR holds one report (review 2026-12-06: a report into
// a directory with another study's report kept that study's figures and stills beside it).
struct StaleFiles {
  std::vector<std::string> removed;
  std::vector<palplab::Problem> kept;  // could not be removed (said after the summary: exit 2)
};
StaleFiles remove_stale_report_files(const std::vector<std::filesystem::path>& earlier,
                                     const palplab::analysis::ReportFiles& files,
                                     const std::string& db) {
  namespace fs = std::filesystem;
  std::set<fs::path> written;
  for (const auto& f : files.figures) written.insert(fs::path(f).lexically_normal());
  for (const auto& f : files.stills) written.insert(fs::path(f).lexically_normal());
  if (!files.stills_listing.empty())
    written.insert(fs::path(files.stills_listing).lexically_normal());
  StaleFiles out;
  for (const auto& p : earlier) {
    std::error_code ec;
    if (written.count(p) || fs::equivalent(p, db, ec)) continue;  // the database: never
    fs::remove(p, ec);
    if (ec)
      out.kept.push_back({palplab::SourceLocation{p.string()},
                          "cannot remove this file of an earlier report, which the new report "
                          "does not have (" +
                              ec.message() + "); the new report is written: remove it by hand"});
    else
      out.removed.push_back(p.string());
  }
  return out;
}

palplab::app::CommandRegistration reg_report{
    "report", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "report",
          "Write report.md, a self-contained report.html, SVG figures and PNG stills of the "
          "prototypes from a results DB");
      auto a = std::make_shared<ReportArgs>();
      cmd->add_option("db", a->db, "Results database (palplab run --db)")->required();
      cmd->add_option("--out", a->out, "Output directory (created if needed)")->required();
      cmd->add_flag("--no-stills", a->no_stills,
                    "Leave out the stills of the prototypes under the same press (they need "
                    "headless OpenGL and take about a second per prototype)");
      auto* size_opt =
          cmd->add_option("--still-size", a->still_size,
                          "Size of each still, WIDTHxHEIGHT in pixels (default 480x360)");
      cmd->add_flag("--overwrite", a->overwrite,
                    "Replace a report.md, report.html, figures/*.svg or stills file in --out "
                    "that palplab did not write (the database itself is never replaced)");
      cmd->callback([a, size_opt, code] {
        palplab::analysis::ReportOptions opt;
        const auto [w, h] = palplab::app::parse_image_size("--still-size", a->still_size);
        palplab::app::flag_only_with(size_opt, !a->no_stills, "stills (not with --no-stills)");
        // The input before the outputs: a missing or foreign database is refused before --out
        // is created (it made an empty directory and then exit 2). An INCOMPLETE run still
        // reports, on the sessions stored, but says so (issue 10).
        const std::string warning = palplab::results::Store::open(a->db).incomplete_warning();
        check_report_out(*a);
        // The outermost directory of --out this run creates (none when --out exists).
        std::error_code ec;
        std::filesystem::path made;
        for (std::filesystem::path p = a->out; !p.empty() && !std::filesystem::exists(p, ec);
             p = p.parent_path())
          made = p;
        palplab::app::require_writable_dir("--out", a->out);
        opt.still_width = w;
        opt.still_height = h;
        if (a->no_stills)
          opt.no_stills_reason = "switched off (--no-stills)";
        else
          opt.stills = palplab::app::make_still_maker();
        if (!warning.empty()) std::cerr << palplab::escape_controls(warning, false) << "\n";
        const auto earlier = earlier_report_files(a->out);
        // An interrupted report leaves them neither (removed on SIGINT/SIGTERM/SIGHUP when
        // empty: review of the fixes, 2026-12-07).
        std::vector<std::unique_ptr<palplab::RemoveOnSignal>> made_on_signal;
        if (!made.empty())
          for (std::filesystem::path p = a->out; !p.empty(); p = p.parent_path()) {
            made_on_signal.push_back(std::make_unique<palplab::RemoveOnSignal>(p.string()));
            if (p == made) break;
          }
        palplab::analysis::ReportFiles files;
        try {
          files = palplab::analysis::write_report(a->db, a->out, opt);
          made_on_signal.clear();
        } catch (...) {
          // A failed report writes no file (analysis/report.cpp): nor leaves the directories it
          // made for --out (each removed only when empty).
          if (!made.empty())
            for (std::filesystem::path p = a->out; !p.empty(); p = p.parent_path()) {
              std::filesystem::remove(p, ec);
              if (p == made) break;
            }
          throw;
        }
        const StaleFiles stale = remove_stale_report_files(earlier, files, a->db);
        if (!files.stills_skipped.empty())
          std::cerr << "palplab report: stills skipped: "
                    << palplab::escape_controls(files.stills_skipped, false) << "\n";
        for (const auto& m : files.stills_missing)
          std::cerr << "palplab report: no still of prototype "
                    << palplab::escape_controls(m, false) << "\n";
        // Declared analyses of one measure and phase share a section: say how they were merged.
        std::cout << "report: " << files.analyses << " analyses ("
                  << (files.declared > 0
                          ? "the study's " + std::to_string(files.declared) +
                                " declared, one per measure and phase"
                          : std::string("none declared: the study's measures in the last phase"))
                  << "), " << files.figures.size()
                  << (files.figures.size() == 1 ? " figure, " : " figures, ") << files.still_figures
                  << (files.still_figures == 1 ? " still" : " stills");
        if (files.still_figures > 0)
          std::cout << " (" << std::lround(files.stills_seconds * 1000) << " ms)";
        std::cout << "\n  " << files.markdown << "\n  " << files.html << "\n";
        const auto& removed = stale.removed;
        if (!removed.empty()) {
          std::cout << "removed " << removed.size() << (removed.size() == 1 ? " file" : " files")
                    << " of an earlier report in " << palplab::escape_controls(a->out, false)
                    << " that this report does not have:";
          for (const auto& r : removed) std::cout << "\n  " << palplab::escape_controls(r, false);
          std::cout << "\n";
        }
        if (!stale.kept.empty()) throw palplab::InputError(stale.kept);
        *code = 0;
      });
    }};
}  // namespace
