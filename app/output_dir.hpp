#pragma once
// The output directory of `report --out`, `export --csv`, `power --out` and `merge --out`,
// checked before the command writes anything, so that no input and no foreign file is lost (the
// directory counterpart of require_replaceable_output in app/command.hpp, and worded like it):
// - the directory path naming an existing non-directory is refused (saying so when it is an
//   input: `report results.db --out results.db`);
// - a file the command writes (or removes) in the directory that is one of the command's inputs
//   (std::filesystem::equivalent: also through a link or another spelling, e.g. the database
//   saved as DIR/report.md) is refused, --overwrite or not: writing it would destroy the input;
// - an existing regular, non-empty file at one of those names that `is_own` does not recognise
//   as the command's own earlier output is refused unless `overwrite` (the command's --overwrite
//   flag; a command without one says "remove it" instead).
// - a directory at one of those names is refused (the command could not write its file).
// An own earlier output, an empty file and a non-regular file (/dev/null) are replaced as before.
#include <algorithm>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "app/command.hpp"
#include "common/input_error.hpp"

namespace palplab::app {

// A file a command writes into its output directory: `name` (relative to it, "report.md"),
// `own_kind` as said in a message ("palplab report (report.md)"), `is_own` recognising the
// command's own earlier output by its content, `verb`: what the command does to an existing
// file ("replace", "append to", "remove"), and `why`, said in a refusal when the command removes
// it (`export` without --samples: "an export without --samples removes the samples.csv of an
// earlier export").
struct DirOutput {
  std::string name, own_kind;
  std::function<bool(const std::string&)> is_own;
  std::string verb = "replace", why;
};

// Whether the file starts with `prefix` and holds `needle` in its first `limit` bytes.
inline bool output_head_has(const std::string& path, const std::string& prefix,
                            const std::string& needle, std::size_t limit = std::size_t{1} << 20) {
  const std::string head = file_head(path, limit);
  return head.compare(0, prefix.size(), prefix) == 0 && head.find(needle) != std::string::npos;
}

// A file in the subdirectory `sub` of `dir` with one of `extensions` (".svg") or one of `names`
// that is one of `inputs`: the command writes such files there under names known only as it
// runs (the report's figures/*.svg), so every one of them is taken for an output (`what`, "its
// SVG figures"). So is each such name with ".partial" appended, where common/write_file writes
// the file first (a database at stills/A_pressed.png.partial cost the report that still, exit 0;
// at figures/x.svg.partial it was refused only after the report's work).
inline void require_no_input_under(const std::string& flag, const std::string& dir,
                                   const std::string& sub,
                                   const std::vector<std::string>& extensions,
                                   const std::vector<std::string>& names,
                                   const std::vector<CommandInput>& inputs,
                                   const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path under = fs::path(dir) / sub;
  if (!fs::is_directory(under, ec)) return;
  for (fs::directory_iterator it(under, ec), end; !ec && it != end; it.increment(ec)) {
    std::string name = it->path().filename().string();
    const bool partial = name.size() > 8 && name.ends_with(".partial");
    if (partial) name.resize(name.size() - 8);
    bool hit = false;
    for (const auto& e : extensions) hit = hit || fs::path(name).extension().string() == e;
    for (const auto& n : names) hit = hit || name == n;
    if (!hit) continue;
    if (const CommandInput* in = same_input(it->path().string(), inputs))
      refuse_input_output(
          flag, it->path().string(), *in,
          "writing " + what + " there" +
              (partial ? " (each written as NAME.partial first, then renamed)" : ""));
  }
}

// Files in the subdirectory `sub` of `dir` that the command writes under names known only as it
// runs (the report's figures/*.svg, stills/*_pressed.png): an existing regular, non-empty file
// that `matches` and that `is_own` does not recognise as the command's own earlier output is
// refused (`own_kind`, "palplab report figure") unless `overwrite`; a symbolic link always.
inline void require_own_files_under(const std::string& flag, const std::string& dir,
                                    const std::string& sub,
                                    const std::function<bool(const std::string&)>& matches,
                                    const std::string& own_kind,
                                    const std::function<bool(const std::string&)>& is_own,
                                    const std::string& overwrite_flag, bool overwrite) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path under = fs::path(dir) / sub;
  if (!fs::is_directory(under, ec)) return;
  for (fs::directory_iterator it(under, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string path = it->path().string();
    std::error_code e2;
    std::string name = it->path().filename().string();
    const bool partial = name.size() > 8 && name.ends_with(".partial");
    if (partial) name.resize(name.size() - 8);
    if (!matches(name)) continue;
    const auto lt = fs::symlink_status(path, e2).type();
    // A directory where a file is written (or first written, as NAME.partial): found only
    // after the other files were written, or a still skipped with exit 0 (review 2026-12-06,
    // fifth).
    if (lt == fs::file_type::directory)
      throw InputError(SourceLocation{flag},
                       "\"" + path + "\" is a directory; the command writes its " + sub +
                           " there as files" +
                           (partial ? " (each first as NAME.partial, then renamed)" : "") +
                           ": remove or rename it, or choose another " + flag);
    if (partial) continue;  // a leftover NAME.partial file is replaced (common/write_file)
    // Never written through, even with the overwrite flag: it could point outside `dir`.
    if (lt == fs::file_type::symlink)
      throw InputError(SourceLocation{flag},
                       "\"" + path + "\" is a symbolic link; the command writes its " + sub +
                           " there and never through a link (it could write outside " + flag +
                           "): remove the link or choose another " + flag);
    // A FIFO would be written directly (common/write_file), blocking until a reader came; a
    // listing there was read first and blocked for ever (review 2026-12-06, third).
    if (lt == fs::file_type::fifo || lt == fs::file_type::socket)
      throw InputError(SourceLocation{flag},
                       "\"" + path + "\" is a " + (lt == fs::file_type::fifo ? "FIFO" : "socket") +
                           "; the command writes its " + sub +
                           " there as regular files: remove it or choose another " + flag);
    if (overwrite || !fs::is_regular_file(path, e2) || fs::file_size(path, e2) == 0 || e2 ||
        is_own(path))
      continue;
    throw InputError(SourceLocation{flag},
                     "\"" + path + "\" exists and is " + describe_existing_file(path) + ", not a " +
                         own_kind + "; the command writes its " + sub +
                         " there and could replace it: choose another " + flag + ", or give " +
                         overwrite_flag + " to replace such files");
  }
}

// The checks above for the directory `dir` named by `flag` (`contents`, e.g. "report.md,
// report.html, figures/ and stills/", says what the directory is for). `overwrite_flag` is the
// command's flag that allows replacing a foreign file ("--overwrite"), empty if it has none.
// Nothing is created: require_writable_dir comes after.
inline void require_replaceable_dir_outputs(const std::string& flag, const std::string& dir,
                                            const std::string& contents,
                                            const std::vector<DirOutput>& outputs,
                                            const std::vector<CommandInput>& inputs,
                                            const std::string& overwrite_flag, bool overwrite) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto st = fs::status(dir, ec);
  if (!fs::exists(st)) return;  // created later: nothing in it to lose
  if (!fs::is_directory(st)) {
    const CommandInput* in = same_input(dir, inputs);
    throw InputError(SourceLocation{flag},
                     "\"" + dir + "\" exists and is not a directory" +
                         (in ? " (it is " + in->what + " this command reads)" : "") +
                         "; expected the directory for " + contents + ": choose another " + flag);
  }
  for (const auto& o : outputs) {
    const std::string path = (fs::path(dir) / o.name).string();
    if (const CommandInput* in = same_input(path, inputs))
      refuse_input_output(flag, path, *in,
                          (o.verb == "remove" ? "removing " : "writing ") + o.name + " there");
    // Written as NAME.partial first, then renamed (common/write_file), unless the command lists
    // NAME.partial as an output of its own (export).
    if (o.verb == "replace" &&
        std::none_of(outputs.begin(), outputs.end(),
                     [&](const DirOutput& q) { return q.name == o.name + ".partial"; }))
      if (const CommandInput* in = same_input(path + ".partial", inputs))
        refuse_input_output(flag, path + ".partial", *in,
                            "writing " + o.name + " (written there first, then renamed)");
    if (o.verb == "replace") require_no_directory_at_partial(flag, path);
    std::error_code e2;
    // A directory where the command writes (or removes) a file: it could do neither, after
    // its work (`power` and `merge` read an existing power.json first).
    if (fs::is_directory(path, e2))
      throw InputError(SourceLocation{flag}, "\"" + path + "\" is a directory; the command " +
                                                 (o.verb == "remove" ? "removes" : "writes") +
                                                 " the file " + o.name + " there: choose another " +
                                                 flag + ", or remove or rename that directory");
    // A FIFO or socket there: the command reads its earlier file first (it blocked for ever on
    // a FIFO; review 2026-12-06, third) and writes a regular file.
    if (const auto t = fs::status(path, e2).type();
        t == fs::file_type::fifo || t == fs::file_type::socket)
      throw InputError(SourceLocation{flag},
                       "\"" + path + "\" is a " + (t == fs::file_type::fifo ? "FIFO" : "socket") +
                           "; the command " + (o.verb == "remove" ? "removes" : "writes") +
                           " the file " + o.name + " there: choose another " + flag +
                           ", or remove it");
    if (overwrite) continue;
    if (!fs::is_regular_file(path, e2) || fs::file_size(path, e2) == 0 || e2 || o.is_own(path))
      continue;
    throw InputError(
        SourceLocation{flag},
        "\"" + path + "\" exists and is " + describe_existing_file(path) + ", not a " + o.own_kind +
            "; refusing to " + o.verb + " it" + (o.why.empty() ? "" : " (" + o.why + ")") +
            ": choose another " + flag +
            (overwrite_flag.empty() ? ", or remove it"
                                    : ", or give " + overwrite_flag + " to " + o.verb + " it"));
  }
}

// The summary files of `palplab power` and `palplab merge` (protocols::write_power_report): the
// same openings since their first version. power.json is recognised (and another study's refused)
// by protocols::check_out_dir_study; here it is only checked not to be an input.
inline std::vector<DirOutput> power_summary_outputs() {
  return {
      {"power.json", "palplab power summary (power.json)", [](const std::string&) { return true; }},
      {"power.md", "palplab power table (power.md)",
       [](const std::string& p) { return output_head_has(p, "# Power analysis: ", ""); }},
      {"power.svg", "palplab power plot (power.svg)", [](const std::string& p) {
         return output_head_has(p, "<svg xmlns=\"http://www.w3.org/2000/svg\"",
                                "Power by group size");
       }}};
}

// Each summary file of `palplab power` and `palplab merge` in `dir` checked for writing before
// any replicate is run or read (require_writable_file: a read-only power.json, or a link to a
// missing file, was found only after the simulation).
inline void require_writable_power_summary(const std::string& flag, const std::string& dir) {
  for (const auto& o : power_summary_outputs())
    require_writable_file(flag, (std::filesystem::path(dir) / o.name).string());
}

}  // namespace palplab::app
