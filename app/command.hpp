#pragma once
// Sub-command registry of the `palplab` command line. Each app/cmd_*.cpp registers its
// commands with a static CommandRegistration; main() builds the CLI11 parser from them.
// A command's run function returns the process exit code; it throws palplab::InputError for
// bad input (exit 2, message on stderr).
#include <unistd.h>
#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "common/input_error.hpp"

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

// Option validators with readable messages: CLI::Range lets NaN through (every comparison with
// it is false), so "--alpha nan" was accepted, and CLI::PositiveNumber printed its range as
// "0.000000 to 1797693134862315708...". These refuse NaN and +-inf and echo the value given.
inline std::string shown_number(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

// A finite number in [lo, hi] ((lo, hi] when lo_open).
inline CLI::Validator finite_range(double lo, double hi, bool lo_open = false) {
  const std::string range =
      (lo_open ? "(" : "[") + shown_number(lo) + ", " + shown_number(hi) + "]";
  return CLI::Validator(
      [lo, hi, lo_open, range](std::string& text) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(text, v) || !std::isfinite(v) || v < lo || v > hi ||
            (lo_open && v == lo))
          return "expected a finite number in " + range + ", got '" + text + "'";
        return std::string();
      },
      "FINITE in " + range);
}

// An integer count in [lo, hi]. A number beyond the 64-bit range is refused too (the parse,
// strtoll, clamps it to the largest one and says so only in errno).
inline CLI::Validator count_range(long long lo, long long hi) {
  const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        long long v = 0;
        errno = 0;
        if (!CLI::detail::lexical_cast(text, v) || errno == ERANGE || v < lo || v > hi)
          return "expected an integer in " + range + ", got '" + text + "'";
        return std::string();
      },
      "INT in " + range);
}

// An output file named by `flag`, checked before a command starts its work (an unwritable path is
// an input error, exit 2, not a result lost after minutes or hours): the file is opened for
// appending (its content is kept) and removed again if this check created it.
inline void require_writable_file(const std::string& flag, const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw InputError(SourceLocation{flag}, "\"" + path + "\" is a directory; expected a file name");
  const bool existed = fs::exists(path, ec);
  std::ofstream probe(path, std::ios::app | std::ios::binary);
  const int why = errno;
  if (!probe)
    throw InputError(SourceLocation{flag}, "cannot write \"" + path + "\" (" + std::strerror(why) +
                                               "), checked before the work starts");
  probe.close();
  if (!existed) fs::remove(path, ec);
}

// An output directory named by `flag`, created if needed and checked for writing before a
// command starts its work (a probe file is created in it and removed).
inline void require_writable_dir(const std::string& flag, const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir))
    throw InputError(SourceLocation{flag}, "cannot create the directory \"" + dir + "\" (" +
                                               (ec ? ec.message() : "not a directory") +
                                               "), checked before the work starts");
  const fs::path probe = fs::path(dir) / (".palplab-write-check-" + std::to_string(::getpid()));
  std::ofstream out(probe, std::ios::app | std::ios::binary);
  const int why = errno;
  if (!out)
    throw InputError(SourceLocation{flag}, "cannot write into the directory \"" + dir + "\" (" +
                                               std::strerror(why) +
                                               "), checked before the work starts");
  out.close();
  fs::remove(probe, ec);
}

// A flag that only means something together with another flag or value (`needed`, e.g.
// "--refinement nested and --grade auto"): given without it, it would be silently ignored, so it
// is an input error naming both.
inline void flag_only_with(const CLI::Option* given, bool applies, const std::string& needed) {
  if (given->count() > 0 && !applies)
    throw InputError(SourceLocation{given->get_name()},
                     "applies only with " + needed + "; here it would be ignored");
}

}  // namespace palplab::app
