#pragma once
// Sub-command registry of the `palplab` command line. Each app/cmd_*.cpp registers its
// commands with a static CommandRegistration; main() builds the CLI11 parser from them.
// A command's run function returns the process exit code; it throws palplab::InputError for
// bad input (exit 2, message on stderr).
#include <CLI/CLI.hpp>
#include <cmath>
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

// A real-valued flag in [lo, hi]: CLI::Range lets NaN through (every comparison with it is
// false), so "--alpha nan" would be accepted; this refuses NaN and +-inf too, echoing the value.
inline CLI::Validator finite_range(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(text, v)) return "expected a number, got '" + text + "'";
        if (!std::isfinite(v) || v < lo || v > hi)
          return "expected a finite number in [" + CLI::detail::to_string(lo) + ", " +
                 CLI::detail::to_string(hi) + "], got '" + text + "'";
        return std::string();
      },
      "FINITE in [" + CLI::detail::to_string(lo) + ", " + CLI::detail::to_string(hi) + "]");
}

}  // namespace palplab::app
