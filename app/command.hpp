#pragma once
// Sub-command registry of the `palplab` command line. Each app/cmd_*.cpp registers its
// commands with a static CommandRegistration; main() builds the CLI11 parser from them.
// A command's run function returns the process exit code; it throws palplab::InputError for
// bad input (exit 2, message on stderr).
#include <fcntl.h>
#include <sys/stat.h>
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

#include "common/file_kind.hpp"
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

// A finite number in [lo, hi] (open at lo / hi when lo_open / hi_open), written in decimal:
// CLI11 also reads hexadecimal ("0x0.1p0" as 0.0625), which CSV values and --bounds refuse.
inline CLI::Validator finite_range(double lo, double hi, bool lo_open = false,
                                   bool hi_open = false) {
  const std::string range =
      (lo_open ? "(" : "[") + shown_number(lo) + ", " + shown_number(hi) + (hi_open ? ")" : "]");
  return CLI::Validator(
      [lo, hi, lo_open, hi_open, range](std::string& text) -> std::string {
        double v = 0;
        if (text.empty() || text.find_first_not_of("0123456789.eE+-") != std::string::npos ||
            !CLI::detail::lexical_cast(text, v) || !std::isfinite(v) || v < lo || v > hi ||
            (lo_open && v == lo) || (hi_open && v == hi))
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
        // Decimal digits only: CLI11 converts "010" as octal (8) and "0x10" as hexadecimal (16),
        // which a user who typed them did not mean; a leading zero is refused rather than read,
        // and so is a '+' (--n and --shard refused "+2" where --replicates took it: review
        // 2026-12-07); a '-' only starts a negative value.
        const std::size_t digits = !text.empty() && text[0] == '-' ? 1 : 0;
        const bool decimal = text.size() > digits &&
                             text.find_first_not_of("0123456789", digits) == std::string::npos &&
                             (text[digits] != '0' || text.size() == digits + 1);
        long long v = 0;
        errno = 0;
        if (!decimal || !CLI::detail::lexical_cast(text, v) || errno == ERANGE || v < lo || v > hi)
          return "expected an integer in " + range + ", got '" + text + "'" +
                 (decimal ? "" : " (decimal digits without leading zeros)");
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
  // A link to a missing file: the probe would create its target and then remove the link.
  if (!existed && fs::is_symlink(fs::symlink_status(path, ec)))
    throw InputError(SourceLocation{flag}, "cannot write \"" + path +
                                               "\" (a symbolic link to a missing file), checked "
                                               "before the work starts");
  // Non-blocking: a FIFO that no process reads blocked this probe for ever (review 2026-12-06,
  // third: `calibrate --journal FIFO`); one with a reader is written as a device is.
  const int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_NONBLOCK | O_CLOEXEC, 0644);
  const int why = errno;
  if (fd < 0 && why == ENXIO)
    throw InputError(SourceLocation{flag}, "\"" + path +
                                               "\" is a FIFO that no process reads (the command "
                                               "would wait for ever); expected a file name");
  // A missing directory is said as `run --db` says it (file outputs are not given directories
  // of their own; --out DIR outputs are created).
  const fs::path parent = fs::path(path).parent_path();
  if (fd < 0 && why == ENOENT && !parent.empty() && !fs::exists(parent, ec))
    throw InputError(SourceLocation{flag}, "cannot write \"" + path + "\": its directory " +
                                               parent.string() +
                                               " does not exist (create it first), checked "
                                               "before the work starts");
  if (fd < 0)
    throw InputError(SourceLocation{flag}, "cannot write \"" + path + "\" (" + std::strerror(why) +
                                               "), checked before the work starts");
  // A FIFO's reader sees the end of its input when the last writer closes: the probe's end stays
  // open until the process ends (closing it made `cat FIFO` stop before the output came, and the
  // command's own open then waited for ever).
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISFIFO(st.st_mode)) return;
  ::close(fd);
  if (!existed) fs::remove(path, ec);
}

// An input file of a command, for require_replaceable_output: what it is ("the prototype file")
// and its path.
struct CommandInput {
  std::string what, path;
};

// What an existing file looks like, for a message ("an SQLite database", "a JSON file"; "a file
// this user cannot read (Permission denied)": its kind is unknown, and so whether it is the
// command's own).
inline std::string describe_existing_file(const std::string& path) {
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return std::string("a file this user cannot read (") +
           (errno ? std::strerror(errno) : "open failed") + ")";
  char head[16] = {};
  in.read(head, sizeof head);
  const std::string h(head, static_cast<size_t>(in.gcount()));
  if (const char* kind = binary_file_kind(h)) return kind;
  const auto first = h.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && (h[first] == '{' || h[first] == '[')) return "a JSON file";
  return "a file";
}

// Up to `limit` bytes from the start of the file at `path` ("" if it cannot be read).
inline std::string file_head(const std::string& path, std::size_t limit) {
  std::ifstream in(path, std::ios::binary);
  std::string head(limit, '\0');
  in.read(head.data(), static_cast<std::streamsize>(limit));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return head;
}

// Whether the file at `path` starts with `prefix` (a format's magic bytes).
inline bool file_starts_with(const std::string& path, const std::string& prefix) {
  return file_head(path, prefix.size()) == prefix;
}

// `flag: "DIR/report.md" is the results database this command reads ("r.db"); writing report.md
// there would destroy it: choose another flag` (`what`: "writing report.md there").
[[noreturn]] inline void refuse_input_output(const std::string& flag, const std::string& shown,
                                             const CommandInput& in, const std::string& what) {
  throw InputError(SourceLocation{flag}, "\"" + shown + "\" is " + in.what + " this command reads" +
                                             (in.path == shown ? "" : " (\"" + in.path + "\")") +
                                             "; " + what + " would destroy it: choose another " +
                                             flag);
}

// The input among `inputs` that is the same file as `path`, or nullptr.
inline const CommandInput* same_input(const std::string& path,
                                      const std::vector<CommandInput>& inputs) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) return nullptr;
  for (const auto& in : inputs) {
    std::error_code e2;
    if (!in.path.empty() && fs::exists(in.path, e2) && fs::equivalent(path, in.path, e2))
      return &in;
  }
  return nullptr;
}

// A directory at PATH.partial, where common/write_file writes PATH first: refused before the
// command's work (it was found when the output was written, after a power analysis's hours).
inline void require_no_directory_at_partial(const std::string& flag, const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(std::filesystem::symlink_status(path + ".partial", ec)))
    throw InputError(SourceLocation{flag},
                     "\"" + path + ".partial\" is a directory; the command writes " + path +
                         " there first, then renames it: remove "
                         "or rename that directory, or choose another " +
                         flag);
}

// The output file of `flag` (scene build --out, fem reference --out), checked before the command
// reads or computes anything costly, so that no result and no input is lost:
// - the same file as one of `inputs` (std::filesystem::equivalent: also through a link or
//   another spelling) is an input error, --overwrite or not: writing it would destroy the input
//   the command reads;
// - an existing regular, non-empty file that `is_own_output` does not recognise as this
//   command's own output (`own_kind`, e.g. "palplab scene file (.psim)") is refused unless
//   `overwrite` (the --overwrite flag) is given: `--out results.db` must not replace a database;
// - a directory at PATH.partial is refused (require_no_directory_at_partial);
// - then require_writable_file.
// A file the command wrote before (own output), an empty file and a non-regular file (/dev/null)
// are replaced without --overwrite.
inline void require_replaceable_output(const std::string& flag, const std::string& path,
                                       const std::vector<CommandInput>& inputs,
                                       const std::function<bool(const std::string&)>& is_own_output,
                                       const std::string& own_kind, bool overwrite) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // The output is written as PATH.partial and renamed (common/write_file): an input there is
  // destroyed as surely (review 2026-12-06: `calibrate st.json.partial --out st.json`).
  if (const CommandInput* in = same_input(path + ".partial", inputs))
    refuse_input_output(flag, path + ".partial", *in,
                        "writing " + path + " (written there first, then renamed)");
  require_no_directory_at_partial(flag, path);
  if (fs::exists(path, ec)) {
    if (const CommandInput* in = same_input(path, inputs))
      refuse_input_output(flag, path, *in, "writing the output there");
    if (!overwrite && fs::is_regular_file(path, ec) && fs::file_size(path, ec) > 0 && !ec &&
        !is_own_output(path))
      throw InputError(SourceLocation{flag},
                       "\"" + path + "\" exists and is " + describe_existing_file(path) +
                           ", not a " + own_kind + "; refusing to replace it: choose another " +
                           flag + ", or give --overwrite to replace it");
  }
  require_writable_file(flag, path);
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

// An output directory that is made only when something is written into it (a run that writes
// nothing, or fails, leaves no empty directory behind): checked before the work starts by making
// the missing part of the path and removing it again (asking the file system is the only sure
// test: /proc/x or a dangling symlink pass every look from outside and failed after the run,
// exit 3). An existing one is checked as require_writable_dir does.
inline void require_creatable_dir(const std::string& flag, const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(dir, ec)) {
    require_writable_dir(flag, dir);
    return;
  }
  std::vector<fs::path> missing;  // deepest last
  for (fs::path p = fs::path(dir).lexically_normal();
       !p.empty() && !fs::exists(fs::symlink_status(p, ec)); p = p.parent_path()) {
    missing.insert(missing.begin(), p);
    if (p == p.parent_path()) break;
  }
  std::size_t made = 0;
  std::string why;
  for (; made < missing.size(); ++made)
    if (::mkdir(missing[made].c_str(), 0777) != 0) {
      why = missing[made].string() + ": " + std::strerror(errno);
      break;
    }
  for (std::size_t k = made; k-- > 0;) ::rmdir(missing[k].c_str());
  if (missing.empty()) why = "\"" + dir + "\" exists and is not a directory";
  if (!why.empty())
    throw InputError(SourceLocation{flag}, "cannot create the directory \"" + dir + "\" (" + why +
                                               "), checked before the work starts");
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
