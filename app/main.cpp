// The `palplab` command line: a thin layer that parses arguments and calls the libraries.
// Exit codes: 0 success, 1 a command's own "found something" result (e.g. mesh defects),
// 2 bad input (flags, files, JSON, CSV) with a located message on stderr, 3 internal error.
#include <algorithm>
#include <iostream>

#include "app/command.hpp"
#include "common/input_error.hpp"
#include "palplab/version.hpp"

namespace palplab::app {

std::vector<RegisteredCommand>& command_registry() {
  static std::vector<RegisteredCommand> registry;
  return registry;
}

CommandRegistration::CommandRegistration(std::string name, CommandSetup setup) {
  command_registry().push_back({std::move(name), std::move(setup)});
}

}  // namespace palplab::app

int main(int argc, char** argv) {
  using namespace palplab::app;
  CLI::App cli{"palplab — experiment runner and evaluation for haptic palpation-training studies"};
  cli.set_version_flag(
      "--version", std::string("palplab ") + palplab::kVersion + " (" + palplab::kGitCommit + ")");
  cli.require_subcommand(1);
  int code = 0;
  auto& reg = command_registry();
  std::sort(reg.begin(), reg.end(), [](auto& a, auto& b) { return a.name < b.name; });
  for (auto& c : reg) c.setup(cli, &code);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return cli.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return cli.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return cli.exit(e);
  } catch (const CLI::ParseError& e) {
    // Usage errors are bad input too: exit 2 whatever CLI11's own code would be.
    cli.exit(e);
    return 2;
  } catch (const palplab::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "internal error: " << e.what() << "\n";
    return 3;
  }
  return code;
}
