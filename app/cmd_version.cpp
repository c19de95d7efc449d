// `palplab version [--json]`: version and git commit (what every result stores).
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "palplab/version.hpp"

namespace {
palplab::app::CommandRegistration reg_version{
    "version", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand("version", "Print the palplab version and git commit");
      auto json = std::make_shared<bool>(false);
      cmd->add_flag("--json", *json, "Print as JSON");
      cmd->callback([json, code] {
        if (*json)
          std::cout << "{\"version\": \"" << palplab::kVersion << "\", \"git_commit\": \""
                    << palplab::kGitCommit << "\"}\n";
        else
          std::cout << "palplab " << palplab::kVersion << " (" << palplab::kGitCommit << ")\n";
        *code = 0;
      });
    }};
}  // namespace
