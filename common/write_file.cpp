#include "common/write_file.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <optional>

#include "common/input_error.hpp"
#include "common/remove_on_signal.hpp"

namespace palplab {

void write_file(const std::string& path, std::string_view content, const std::string& what) {
  write_file(path, {content}, what);
}

void write_file(const std::string& path, std::initializer_list<std::string_view> parts,
                const std::string& what) {
  // Only a regular file is removed: never a device or a FIFO named as the output (/dev/full).
  bool regular = false;
  auto fail = [&](int why) {
    if (regular) std::remove(path.c_str());
    throw InputError("cannot write " + what + " (" +
                         (why != 0 ? std::string(std::strerror(why)) : "a write failed") + ")",
                     path);
  };
  if (path.empty()) throw InputError("an empty file name, expected where to write " + what);
  errno = 0;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) fail(errno);
  struct stat st {};
  regular = ::fstat(::fileno(f), &st) == 0 && S_ISREG(st.st_mode);
  // An interruption while the bytes are written removes the cut-off file, as a failure does.
  std::optional<RemoveOnSignal> cut_off;
  if (regular) cut_off.emplace(path);
  errno = 0;
  bool written = true;
  for (const auto& part : parts)
    written = written && std::fwrite(part.data(), 1, part.size(), f) == part.size();
  written = written && std::fflush(f) == 0;
  const int write_errno = errno;
  errno = 0;
  const bool closed = std::fclose(f) == 0;
  if (!written) fail(write_errno);
  if (!closed) fail(errno);
}

}  // namespace palplab
