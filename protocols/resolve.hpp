#pragma once
// Where a prototype id ("C1") is looked up: the first existing file ID.json in
//   1. each directory of the study's "prototype_dirs" (relative to the study file's directory),
//   2. the study file's directory, and its prototypes/ sub-directory,
//   3. each directory of the environment variable PALPLAB_PROTOTYPE_PATH (':'-separated),
//   4. the palplab source tree's prototypes/ (the tree this binary was built from),
//   5. the install dir: <dir of the palplab executable>/../share/palplab/prototypes.
// A study can therefore ship its own prototype copies next to itself and they win.
#include <string>
#include <vector>

namespace palplab::protocols {

std::vector<std::string> prototype_search_dirs(const std::string& study_file,
                                               const std::vector<std::string>& prototype_dirs);

// Empty string when no directory has ID.json. Ids may not contain '/' or start with '.'.
// `study_file`, when given, is never the answer: a study saved as A.json beside the prototypes
// it names was taken for prototype "A" (its own errors then reported as the prototype's); nor is
// any file that is a study ("palplab_study" in its first 4 KiB).
std::string resolve_prototype(const std::string& id, const std::vector<std::string>& search_dirs,
                              const std::string& study_file = {});

// Source tree this library was compiled from (derived from __FILE__), "" if unknown.
std::string source_tree_dir();

}  // namespace palplab::protocols
