// The `palplab` command line: a thin layer that parses arguments and calls the libraries.
// Exit codes: 0 success, 1 a command's own "found something" result (e.g. mesh defects),
// 2 bad input (flags, files, JSON, CSV) with a located message on stderr, 3 internal error;
// out of memory is 1 with a message.
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <iostream>
#include <new>

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

namespace {

// glibc's allocator serves a block above its mmap threshold (128 KiB at the start, raised on the
// fly to the largest block freed, up to 32 MiB) with a fresh mapping and unmaps it on free, and
// returns the top of the heap to the kernel once 2x that threshold is free. palplab builds and
// drops scenes of MB-sized arrays one after another (a study's sessions, a scene file's load, a
// benchmark's repetitions): every drop gave the pages back and the next scene took them again, a
// page fault and a zeroed page per 4 KiB, at a time that depended on the dynamic threshold's
// history. `scene build` showed it as a load time that jumped between two values from run to run
// (B: 1.1-1.5 ms or 4-5 ms). A fixed threshold of 32 MiB and a 128 MiB trim threshold keep
// freed memory in the heap for the next scene: measured on `scene build --repeat 5` (load
// average 17) B's load 32 -> 1.3 ms, D's 109 -> 24 ms, page faults of the whole run -73 % (B) and
// -26 % (D), peak RSS +2.4 MB (B) and +1.3 MB (D) (docs/FORMATS.md, "Simulation files").
// MALLOC_MMAP_THRESHOLD_ / MALLOC_TRIM_THRESHOLD_ in the environment still take precedence.
void tune_allocator() {
  if (!std::getenv("MALLOC_MMAP_THRESHOLD_")) mallopt(M_MMAP_THRESHOLD, 32 << 20);
  if (!std::getenv("MALLOC_TRIM_THRESHOLD_")) mallopt(M_TRIM_THRESHOLD, 128 << 20);
}

// "palplab CMD SUB" of the command line being parsed (the deepest subcommand given).
std::string deepest_command(const CLI::App& cli) {
  std::string command = "palplab";
  for (const CLI::App* sub = &cli; !sub->get_subcommands().empty();) {
    sub = sub->get_subcommands().back();
    command += " " + sub->get_name();
  }
  return command;
}

// What the command printed must have reached standard output: `palplab stats --json >
// /dev/full` (a full disk, a closed pipe's file) lost it and exited 0; so did `--help` and
// `--version`, which CLI11 prints. The reason is known only when this last flush is the write
// that failed (an earlier one, e.g. cout flushed because stderr was written, left errno to
// later calls). `printed_errno`: errno after a print that began with errno 0 and did nothing
// but write (CLI11's help and version end with std::endl, which flushes: its failure is theirs).
int checked_stdout(int code, int printed_errno = 0) {
  const bool failed_before = std::ferror(stdout) != 0;
  errno = 0;
  std::cout.flush();
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    int why = failed_before ? printed_errno : errno;
    // A write that failed while the command printed (more than a buffer's worth: `recheck
    // --json > /dev/full`) left no reason: one more byte written directly to the lost output
    // asks the system again.
    if (why == 0) {
      errno = 0;
      if (::write(STDOUT_FILENO, "\n", 1) < 0) why = errno;
    }
    std::cerr << "error: cannot write to standard output ("
              << (why ? std::strerror(why) : "a write failed")
              << "); the output is lost (files the command wrote are not affected)\n";
    // 2 also where the command's verdict was 1 (recheck's "inconsistent", mesh check's
    // defects): a script must not read the lost output as that verdict.
    return code >= 2 ? code : 2;
  }
  return code;
}

// Under mpirun (`mpirun -np K palplab power ...`) every rank parses the same command line, and
// each printed the same usage error (review 2026-12-07). A rank other than 0 (as the launcher
// tells it: OpenMPI, MPICH, PMIx) says nothing until the command runs; it still exits 2.
int launcher_rank() {
  for (const char* var : {"OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"})
    if (const char* v = std::getenv(var); v && *v) return std::atoi(v);
  return 0;
}

struct Discard : std::streambuf {
  int overflow(int c) override { return c == EOF ? 0 : c; }
};

// The root command: `before_run` is called once the command line is parsed and checked, before
// the command's callback runs (CLI11 calls pre_callback there).
struct RootApp : CLI::App {
  using CLI::App::App;
  std::function<void()> before_run;
  void pre_callback() override {
    if (before_run) before_run();
  }
};

}  // namespace

int main(int argc, char** argv) {
  using namespace palplab::app;
  tune_allocator();
  Discard discard;
  std::streambuf* const cerr_buf = std::cerr.rdbuf();
  if (launcher_rank() > 0) std::cerr.rdbuf(&discard);
  struct Restore {  // before `discard` ends (std::cerr outlives main)
    std::streambuf* buf;
    ~Restore() { std::cerr.rdbuf(buf); }
  } restore{cerr_buf};
  RootApp cli{"palplab — experiment runner and evaluation for haptic palpation-training studies"};
  cli.before_run = [cerr_buf] { std::cerr.rdbuf(cerr_buf); };
  cli.set_version_flag(
      "--version", std::string("palplab ") + palplab::kVersion + " (" + palplab::kGitCommit + ")");
  cli.require_subcommand(1);
  int code = 0;
  auto& reg = command_registry();
  std::sort(reg.begin(), reg.end(), [](auto& a, auto& b) { return a.name < b.name; });
  for (auto& c : reg) c.setup(cli, &code);
  // A flag given twice (`--json --json`) was taken where an option given twice is refused
  // (review 2026-12-07): every flag of every command is refused a second time too.
  const std::function<void(CLI::App*)> once = [&](CLI::App* app) {
    for (CLI::Option* o : app->get_options())
      if (o->get_expected_max() == 0 && o->get_name() != "--help" && o->get_name() != "--version")
        o->multi_option_policy(CLI::MultiOptionPolicy::Throw);
    for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) once(sub);
  };
  once(&cli);
  // A first word that is no command: CLI11 said only "A subcommand is required".
  if (argc > 1 && argv[1][0] != '-' &&
      std::none_of(reg.begin(), reg.end(), [&](auto& c) { return c.name == argv[1]; })) {
    std::string names;
    for (const auto& c : reg) names += (names.empty() ? "" : ", ") + c.name;
    std::cerr << "error: unknown command '" << palplab::escape_controls(argv[1], false)
              << "'; the commands are: " << names << " (palplab --help describes them)\n";
    return 2;
  }
  try {
    cli.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help, --help-all, --version: CLI11 prints them
    errno = 0;
    const int c = cli.exit(e);
    return checked_stdout(c, errno);
  } catch (const CLI::ExtrasError&) {
    // CLI11 names the extra arguments in reverse order ("not expected: -1 --seed" for
    // `run --seed -1`): they are said in the order given, with the command they were given to,
    // and an unknown option first of all.
    const bool top = !cli.remaining(false).empty();
    const std::string command = top ? "palplab" : deepest_command(cli);
    std::string extras, unknown;
    for (const auto& a : cli.remaining(true)) {
      const std::string shown = palplab::escape_controls(a, false);
      extras += (extras.empty() ? "" : " ") + shown;
      const bool option = a.size() > 1 && a[0] == '-' &&
                          !(std::isdigit(static_cast<unsigned char>(a[1])) || a[1] == '.');
      if (option && unknown.empty()) unknown = shown;
    }
    if (!unknown.empty())
      std::cerr << "error: " << command << ": unknown option " << unknown << " (`" << command
                << " --help` lists its options)\n";
    else
      std::cerr << "error: " << command << ": unexpected argument(s): " << extras
                << " (more arguments than the command takes; `" << command
                << " --help` lists what it takes)\n";
    return 2;
  } catch (const CLI::RequiredError& e) {
    // A command group given without one of its commands, or with a word that is none of them
    // (`palplab mesh bogus`): CLI11 said only "A subcommand is required".
    const CLI::App* sub = &cli;
    while (!sub->get_subcommands().empty()) sub = sub->get_subcommands().back();
    if (sub != &cli && !sub->get_subcommands({}).empty() &&
        std::string(e.what()).find("subcommand") != std::string::npos) {
      std::string names;
      for (const CLI::App* c : sub->get_subcommands({}))
        names += (names.empty() ? "" : ", ") + c->get_name();
      const auto rest = cli.remaining(true);
      const std::string command = deepest_command(cli);
      std::cerr << "error: " << command << ": "
                << (rest.empty()
                        ? std::string("which command?")
                        : "unknown command '" + palplab::escape_controls(rest.front(), false) + "'")
                << " — its commands are: " << names << " (`" << command
                << " --help` describes them)\n";
      return 2;
    }
    cli.exit(e);
    return 2;
  } catch (const CLI::ArgumentMismatch& e) {
    // An option given twice was CLI11's "--sim-n: At Most 1 required but received 2".
    const std::string what = e.what();
    const auto at = what.find(": At Most 1 required but received ");
    if (at == std::string::npos) {
      cli.exit(e);
      return 2;
    }
    std::cerr << "error: " << deepest_command(cli) << ": "
              << palplab::escape_controls(what.substr(0, at), false)
              << " given more than once (give it once)\n";
    return 2;
  } catch (const CLI::ParseError& e) {
    // Usage errors are bad input too: exit 2 whatever CLI11's own code would be.
    cli.exit(e);
    return 2;
  } catch (const palplab::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    // Not an internal error: the machine's memory, or a limit on it (`ulimit -v`), ran out.
    std::cerr << "error: out of memory (the machine's memory, or a limit on the process's "
                 "address space such as `ulimit -v`, ran out)\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "internal error: " << e.what() << "\n";
    return 3;
  }
  return checked_stdout(code);
}
