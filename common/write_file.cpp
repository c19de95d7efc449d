#include "common/write_file.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>

#include "common/input_error.hpp"
#include "common/inputs.hpp"
#include "common/remove_on_signal.hpp"

namespace palplab {

namespace fs = std::filesystem;

void write_file(const std::string& path, std::string_view content, const std::string& what) {
  write_file(path, {content}, what);
}

void write_file(const std::string& path, std::initializer_list<std::string_view> parts,
                const std::string& what) {
  auto fail = [&](int why) {
    throw InputError("cannot write " + what + " (" +
                         (why != 0 ? std::string(std::strerror(why)) : "a write failed") + ")",
                     path);
  };
  if (path.empty()) throw InputError("an empty file name, expected where to write " + what);
  // A device, a FIFO or a directory (the error is the system's) is written directly and never
  // removed (/dev/full, /dev/stdout). A regular file — or the file a link points to — is written
  // beside itself as FILE.partial and renamed over it when whole: a failure or an interruption
  // leaves the earlier file as it was (an in-place write truncated it first).
  struct stat st {};
  const bool exists = ::stat(path.c_str(), &st) == 0;
  const bool direct = exists && !S_ISREG(st.st_mode);
  std::string target = path;
  if (exists && !direct) {
    std::error_code ec;
    const fs::path resolved = fs::canonical(path, ec);  // through links: the link stays a link
    if (!ec) target = resolved.string();
  }
  const std::string tmp = direct ? path : target + ".partial";
  // Never through a file this command reads (common/inputs.hpp): FILE itself is each command's
  // own check (some replace a file they read on purpose); FILE.partial, where FILE is written
  // first, was not checked (a database named report.md.partial was overwritten and renamed away).
  if (!direct && is_noted_input(tmp))
    throw InputError("is a file this command reads; " + what + " is written to " + path +
                         " through " + tmp +
                         " first, which would destroy it: rename that input "
                         "or choose another output",
                     tmp);
  // A leftover FILE.partial (an earlier write killed) is replaced itself, never written
  // through: a link there pointed the write at another file, a FIFO there blocked it for ever
  // (review 2026-12-06, third); a directory there is said as such.
  if (struct stat lt{}; !direct && ::lstat(tmp.c_str(), &lt) == 0) {
    if (S_ISDIR(lt.st_mode))
      throw InputError("is a directory where " + what + " is written first (then renamed to " +
                           path + "): remove or rename it",
                       tmp);
    if (std::remove(tmp.c_str()) != 0) fail(errno);
  }
  std::optional<RemoveOnSignal> partial;
  if (!direct) partial.emplace(tmp);
  errno = 0;
  std::FILE* f = std::fopen(tmp.c_str(), direct ? "wb" : "wbx");  // x: made here, no link followed
  if (!f) fail(errno);
  errno = 0;
  bool written = true;
  for (const auto& part : parts)
    written = written && std::fwrite(part.data(), 1, part.size(), f) == part.size();
  written = written && std::fflush(f) == 0;
  const int write_errno = errno;
  errno = 0;
  const bool closed = std::fclose(f) == 0;
  const int close_errno = errno;
  if (!written || !closed) {
    if (!direct) std::remove(tmp.c_str());
    fail(!written ? write_errno : close_errno);
  }
  if (!direct && std::rename(tmp.c_str(), target.c_str()) != 0) {
    const int why = errno;
    std::remove(tmp.c_str());
    fail(why);
  }
}

}  // namespace palplab
