#pragma once
// Reading a whole input file (study, prototype, CSV, ...) into memory, bounded: a FIFO, a device
// such as /dev/zero or a runaway file would otherwise be read until memory runs out.
#include <cstddef>
#include <string>

namespace palplab {

// The file's bytes. InputError naming `path` when it cannot be opened or read, is a directory
// ("is a directory, expected a <what>"; `what` is e.g. "JSON file"), or holds more than `max_bytes`
// (the limit and what it is for are named; it is checked while reading, so an endless input stops
// there).
std::string read_file_bounded(const std::string& path, std::size_t max_bytes,
                              const std::string& what);

}  // namespace palplab
