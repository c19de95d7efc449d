#pragma once
// Sub-command registry of the `palplab` command line. Each app/cmd_*.cpp registers its
// commands with a static CommandRegistration; main() builds the CLI11 parser from them.
// A command's run function returns the process exit code; it throws palplab::InputError for
// bad input (exit 2, message on stderr).
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace palplab::app {

// Adds the sub-command(s) to `root`; the registered callback stores its exit code in `*code`.
using CommandSetup = std::function<void(CLI::App& root, int* code)>;

struct CommandRegistration {
  CommandRegistration(std::string name, CommandSetup setup);
};

struct RegisteredCommand {
  std::string name;
  CommandSetup setup;
};

std::vector<RegisteredCommand>& command_registry();

}  // namespace palplab::app
