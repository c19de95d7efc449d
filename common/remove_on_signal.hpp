#pragma once
// Output files that are not yet whole (an export's NAME.partial, a trace's FILE.partial, a
// report file being written) are removed when the process is ended by SIGINT, SIGTERM or SIGHUP
// while they are registered, so that an interrupted command leaves no cut-off file behind; the
// process then ends by the same signal, as it would have without the handler (exit status
// 128 + signal in a shell). A registered directory is removed after the files if it is then
// empty (a directory the command made for its output: an interrupted `export --csv a/b` left
// a/ and a/b, a report its stills' stage).
//
// The handler is installed at each registration, for each of those signals whose
// disposition is still the default: a signal the caller ignores (nohup) stays ignored, and a
// command with its own handler (`run`) keeps it. At most 64 files are registered at once (a
// further one is simply not removed on a signal); paths longer than PATH_MAX are not registered.
#include <string>

namespace palplab {

// Unlinks every registered file now: for a command's own signal handler that ends the process
// (`run`'s), which replaces the one installed here. Async-signal-safe.
void remove_registered_files() noexcept;

class RemoveOnSignal {
 public:
  explicit RemoveOnSignal(const std::string& path);
  ~RemoveOnSignal();  // deregisters (the file is whole, renamed or removed by its writer)
  RemoveOnSignal(const RemoveOnSignal&) = delete;
  RemoveOnSignal& operator=(const RemoveOnSignal&) = delete;

 private:
  int slot_ = -1;
};

}  // namespace palplab
