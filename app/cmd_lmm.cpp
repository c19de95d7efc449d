// `palplab lmm --csv FILE --formula "value ~ group * session + (1 | participant)"
//              [--where COL=VALUE]... [--ml] [--json]`: linear mixed model (analysis/lmm.hpp),
// REML by default, with Satterthwaite t-tests and type III F tests as lmerTest prints them.
// Bad input (formula outside the grammar, missing column, non-numeric response) → exit 2.
#include <iostream>
#include <memory>

#include "analysis/csv.hpp"
#include "analysis/grouped.hpp"
#include "analysis/lmm.hpp"
#include "app/command.hpp"

namespace {
struct LmmArgs {
  std::string csv, formula;
  std::vector<std::string> where;
  bool ml = false, json = false;
};

palplab::app::CommandRegistration reg_lmm{
    "lmm", [](CLI::App& root, int* code) {
      auto a = std::make_shared<LmmArgs>();
      auto* cmd = root.add_subcommand(
          "lmm", "Linear mixed model (lme4/lmerTest-compatible REML/ML fit, Satterthwaite tests)");
      cmd->add_option("--csv", a->csv, "CSV file (RFC 4180, header row)")->required();
      cmd->add_option("--formula", a->formula,
                      "Model, e.g. \"value ~ group * session + (1 | participant)\" or "
                      "\"y ~ x + (1 + x | g)\"")
          ->required();
      cmd->add_option("--where", a->where,
                      "Keep rows with COL=VALUE (repeatable; same column = OR, different = AND)");
      cmd->add_flag("--ml", a->ml, "Maximum likelihood instead of REML");
      cmd->add_flag("--json", a->json, "Print JSON instead of tables");
      cmd->callback([a, code] {
        using namespace palplab::analysis;
        LmmFormula f = parse_lmm_formula(a->formula);
        std::vector<WhereFilter> where;
        for (const auto& w : a->where) where.push_back(parse_where(w));
        CsvTable t = read_csv(a->csv);
        LmmFit fit = fit_lmm(t, f, where, !a->ml);
        if (a->json) {
          auto j = to_json(fit);
          j["input"] = {{"csv", a->csv}, {"formula", a->formula}, {"where", a->where}};
          std::cout << j.dump(2) << "\n";
        } else {
          std::cout << to_text(fit, a->formula);
        }
        *code = 0;
      });
    }};
}  // namespace
