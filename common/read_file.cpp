#include "common/read_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "common/input_error.hpp"
#include "common/inputs.hpp"

namespace palplab {

namespace {

std::string size_text(std::size_t bytes) {
  if (bytes % (1024 * 1024) == 0) return std::to_string(bytes / (1024 * 1024)) + " MiB";
  return std::to_string(bytes) + " bytes";
}

}  // namespace

std::string read_file_bounded(const std::string& path, std::size_t max_bytes,
                              const std::string& what) {
  // POSIX reads: an ifstream's locale and buffer set-up cost more than reading a prototype.
  if (path.empty()) throw InputError("an empty file name, expected the path of a " + what);
  // Opened without blocking (a FIFO with no writer blocked here for ever; now it reads as
  // nothing and is refused below), then read blocking as usual.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd >= 0) ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  if (fd < 0)
    throw InputError(std::string("cannot open file: ") + std::strerror(errno) +
                         " (expected a readable " + what + ")",
                     path);
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) {
    ::close(fd);
    throw InputError("is a directory, expected a " + what, path);
  }
  if (S_ISREG(st.st_mode)) note_input(path);
  std::string text;
  if (S_ISREG(st.st_mode) && st.st_size > 0) {
    if (static_cast<unsigned long long>(st.st_size) > max_bytes) {
      ::close(fd);
      throw InputError("is " + std::to_string(st.st_size) + " bytes, more than the " +
                           size_text(max_bytes) + " accepted for " + what,
                       path);
    }
    text.reserve(static_cast<std::size_t>(st.st_size));
  }
  char chunk[65536];
  for (;;) {
    const ssize_t k = ::read(fd, chunk, sizeof chunk);
    if (k < 0) {
      ::close(fd);
      throw InputError("cannot read file (expected a readable " + what + ")", path);
    }
    if (k == 0) break;
    if (text.size() + static_cast<std::size_t>(k) > max_bytes) {
      ::close(fd);
      throw InputError("more than the " + size_text(max_bytes) + " accepted for " + what +
                           " (an endless input such as a device or a pipe that does not end?)",
                       path);
    }
    text.append(chunk, static_cast<std::size_t>(k));
  }
  ::close(fd);
  // A named FIFO that no writer held open when it was opened reads as nothing: said as such, not
  // as an empty file of the kind expected.
  if (S_ISFIFO(st.st_mode) && text.empty())
    throw InputError(
        "is a FIFO and nothing was written to it (its writer wrote nothing, or no writer had "
        "it open when it was read: start the writer first); expected a " +
            what,
        path);
  return text;
}

}  // namespace palplab
