#pragma once
// Writing a whole output file (a report, a figure, a parameter file) so that a failure is never
// silent: an ofstream checked before its close misses the error of the last buffered bytes (a
// report.md smaller than the buffer, on a full disk, was an empty file and exit 0). Here every
// byte is written, flushed and closed before success is returned, and the file appears whole or
// not at all.
#include <initializer_list>
#include <string>
#include <string_view>

namespace palplab {

// Writes `content` to `path`. InputError naming `path` on any failure: "cannot write <what>
// (<the system's reason>)"; `what` e.g. "the report", "the figure". A regular file (also one a
// link points to; the link stays) is written as PATH.partial and renamed over PATH when whole,
// so a failure or an interruption (SIGINT, SIGTERM, SIGHUP: common/remove_on_signal) leaves the
// earlier file as it was and no cut-off file; a device or a FIFO is written directly and never
// removed.
void write_file(const std::string& path, std::string_view content, const std::string& what);
// The same with the content in parts, written one after the other.
void write_file(const std::string& path, std::initializer_list<std::string_view> parts,
                const std::string& what);

}  // namespace palplab
