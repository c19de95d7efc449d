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
        // Ids and titles come from the file: never echo a terminal escape sequence raw.
        std::cout << palplab::escape_controls(plan_summary(s, p) + "valid: " + *study) << "\n";
        *code = 0;
      });
    }};
}  // namespace
