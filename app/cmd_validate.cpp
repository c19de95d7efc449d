// `palplab validate STUDY.json`: checks the study and every prototype it names; exit 0 and a
// one-screen plan summary when valid, exit 2 with every problem (FILE:LINE:COL: $.path: what)
// otherwise.
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "common/escape.hpp"
#include "protocols/plan.hpp"
#include "protocols/study.hpp"

namespace {
palplab::app::CommandRegistration reg{
    "validate", [](CLI::App& root, int* code) {
      auto* cmd =
          root.add_subcommand("validate", "Validate a study JSON file and summarise its plan");
      auto study = std::make_shared<std::string>();
      cmd->add_option("STUDY", *study, "Study file (JSON)")->required();
      cmd->callback([study, code] {
        using namespace palplab::protocols;
        Study s = load_study(*study, engine_prototype_inspector());
        Plan p = make_plan(s);
        std::cout << palplab::escape_controls(plan_summary(s, p));
        if (!s.hypotheses.empty()) {
          std::cout << "hypotheses (confirmatory, run first by `palplab report`):";
          for (const auto& h : s.hypotheses) {
            std::cout << " " << palplab::escape_controls(h.id) << "=" << h.test << "(" << h.measure
                      << " @ " << palplab::escape_controls(h.phase);
            for (const auto& [a, b] : h.pairs)
              std::cout << " " << palplab::escape_controls(a) << "-" << palplab::escape_controls(b);
            std::cout << ", alpha " << h.alpha << ", " << h.correction << ")";
          }
          std::cout << "\n";
        }
        std::cout << palplab::escape_controls("valid: " + *study) << "\n";
        // Valid but questionable: pooling repeated sessions as independent observations.
        for (std::size_t i = 0; i < s.analyses.size(); ++i)
          if (s.analyses[i].pooled && s.analyses[i].pool_sessions)
            std::cerr << palplab::escape_controls(*study) << ": warning: $.analyses[" << i
                      << "]: pool_sessions: true treats "
                      << "every session of a participant as an independent observation "
                      << "(pseudo-replication: df and p-values overstate the evidence); "
                      << "participant means (the default) or `palplab lmm` are valid\n";
        *code = 0;
      });
    }};
}  // namespace
