// `palplab stats --csv FILE --value COL --group COL [--where COL=VALUE ...]
//                [--df-mode exact|floor] [--margin M | --margins LOW,HIGH] [--alpha A] [--json]`:
//                descriptives per group, classical and
// Welch ANOVA, every pairwise Welch t-test (Holm/Bonferroni), post-hoc tests, assumption
// checks; APA lines. Bad input (missing column, non-numeric value, a group with < 2 values,
// bad --where) → InputError → exit 2 with the CSV line.
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>

#include "analysis/csv.hpp"
#include "analysis/grouped.hpp"
#include "analysis/report.hpp"
#include "analysis/summary.hpp"
#include "app/command.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "results/store.hpp"

namespace {
struct StatsArgs {
  std::string csv, value, group, df_mode = "exact";
  std::vector<std::string> where;
  bool json = false, skip_empty = false;
  std::optional<double> margin;
  std::vector<double> margins;
  double alpha = 0.05;
};

palplab::app::CommandRegistration reg{
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
                      "|mean difference| < M and a verdict (equivalent/different/inconclusive)");
      cmd->add_option("--margins", a->margins,
                      "Asymmetric equivalence margins LOW,HIGH (LOW < HIGH, data units)")
          ->delimiter(',')
          ->expected(2);
      cmd->add_option("--alpha", a->alpha, "Level of the equivalence tests (default 0.05)");
      cmd->add_flag("--json", a->json, "Print JSON instead of tables");
      cmd->callback([a, code] {
        using namespace palplab::analysis;
        std::vector<WhereFilter> where;
        for (const auto& w : a->where) where.push_back(parse_where(w));
        CsvTable t = read_csv(a->csv);
        GroupedData data = group_table(t, a->value, a->group, where, 2, 2, a->skip_empty);
        StatsOptions opt;
        opt.df_mode = a->df_mode == "floor" ? DfMode::Floor : DfMode::Exact;
        if (!(a->alpha > 0 && a->alpha < 0.5))
          throw palplab::InputError(
              palplab::SourceLocation{"--alpha"},
              "expected a level in (0, 0.5), got " + std::to_string(a->alpha));
        opt.alpha = a->alpha;
        if (a->margin && !a->margins.empty())
          throw palplab::InputError(palplab::SourceLocation{"--margin"},
                                    "give either --margin or --margins, not both");
        if (a->margin) {
          if (!(*a->margin > 0) || !std::isfinite(*a->margin))
            throw palplab::InputError(palplab::SourceLocation{"--margin"},
                                      "expected a finite margin > 0");
          opt.margins = std::make_pair(-*a->margin, *a->margin);
        }
        if (!a->margins.empty()) {
          if (!(a->margins[0] < a->margins[1]) || !std::isfinite(a->margins[0]) ||
              !std::isfinite(a->margins[1]))
            throw palplab::InputError(palplab::SourceLocation{"--margins"},
                                      "expected LOW,HIGH with LOW < HIGH (finite numbers)");
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
          std::cout << "palplab stats: " << a->value << " by " << a->group << " (" << data.rows_used
                    << " rows of " << a->csv
                    << (data.rows_skipped_empty > 0
                            ? ", " + std::to_string(data.rows_skipped_empty) +
                                  " empty values skipped"
                            : std::string())
                    << ")\n\n"
                    << to_text(s);
        }
        *code = 0;
      });
    }};
}  // namespace

// `palplab report DB --out DIR`: report.md, self-contained report.html and figures/*.svg from a
// results database (analysis/report.hpp). Registered here because it is the statistics' front
// end; bad input (missing or foreign database) → exit 2.
namespace {
palplab::app::CommandRegistration reg_report{
    "report", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "report",
          "Write report.md, a self-contained report.html and SVG figures from a results DB");
      auto db = std::make_shared<std::string>();
      auto out = std::make_shared<std::string>();
      cmd->add_option("db", *db, "Results database (palplab run --db)")->required();
      cmd->add_option("--out", *out, "Output directory (created if needed)")->required();
      cmd->callback([db, out, code] {
        // An INCOMPLETE run still reports, on the sessions stored, but says so (issue 10).
        const std::string warning = palplab::results::Store::open(*db).incomplete_warning();
        if (!warning.empty()) std::cerr << palplab::escape_controls(warning, false) << "\n";
        auto files = palplab::analysis::write_report(*db, *out);
        std::cout << "report: " << files.analyses << " analyses, " << files.figures.size()
                  << " figures\n  " << files.markdown << "\n  " << files.html << "\n";
        *code = 0;
      });
    }};
}  // namespace
