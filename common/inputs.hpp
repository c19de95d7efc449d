#pragma once
// The files this process reads (studies, prototypes, CSVs, meshes, results databases), by file
// identity, so that `write_file` never writes through one: an output is written as FILE.partial
// and renamed over FILE, and an input that happened to be named FILE.partial (a database saved
// as report.md.partial) was overwritten and then renamed away, exit 0 (review 2026-12-06).
#include <string>

namespace palplab {

// Records `path`'s file (device and inode) as an input of this process; a path that does not
// exist is not recorded. Thread-safe.
void note_input(const std::string& path);
// Whether `path` is (through any link or spelling) a file recorded by note_input.
bool is_noted_input(const std::string& path);

}  // namespace palplab
