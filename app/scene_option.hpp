#pragma once
// The `--scene` option of probe, run and view (issue 16), resolved in one place:
//   --scene FILE.psim  a simulation file written by `palplab scene build`: it is verified
//                      (version, checksums, sources unchanged) and its precomputation is
//                      installed in the process caches, so every scene of that prototype starts
//                      from it; the prototype is the one the file was built from.
//   --scene KEY        a prototype key ("A", "C", "D", ...): the shipped prototype KEY.json
//                      (searched as a study's prototype ids are, protocols/resolve.hpp).
// Every problem is an InputError (exit 2).
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace palplab::app {

// Registers --scene on cmd (repeatable when `many`: run may use several prototypes). Each
// --scene takes exactly one value, so a positional after it stays positional
// (`probe --scene A.psim B.json` compares the two; it said "At Most 1 required but received 2").
CLI::Option* add_scene_option(CLI::App* cmd, std::vector<std::string>& scenes, bool many);

// The prototype file of a command that builds one scene: the positional file, or what --scene
// names (both given: they must name the same prototype). Installs a .psim's precomputation.
std::string scene_prototype(const std::string& positional, const std::vector<std::string>& scenes);

// Installs the precomputation of every --scene file (run: the study's prototypes then start from
// them); a prototype key is refused here (a study names its prototypes itself). Returns the
// prototype file each was built from, in the order given.
std::vector<std::string> preload_scenes(const std::vector<std::string>& scenes);

// The notices for --scene files that do nothing (review 2026-12-06: they passed without a
// word): one given twice, one built from the same prototype as an earlier one, or one built from
// a prototype file none of `used` (the study's prototype files) is. One line each, "warning:
// --scene ...".
std::vector<std::string> unused_scene_warnings(const std::vector<std::string>& scenes,
                                               const std::vector<std::string>& sources,
                                               const std::vector<std::string>& used);

// True when `value` names a .psim file (by extension or by its magic bytes).
bool is_scene_file(const std::string& value);

// True when the file `path` starts with the .psim magic ("PALPSIM\0").
bool has_scene_magic(const std::string& path);

// A directory given where a .psim file is expected (`scene info DIR`): an InputError
// "LABEL: is a directory, expected a .psim scene file" (the reader said "no such scene file").
void refuse_directory_as_scene(const std::string& label, const std::string& path);

}  // namespace palplab::app
