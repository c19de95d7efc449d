#pragma once
// What the end-to-end tests (tests/cli_*) share: run the palplab binary with arguments and
// capture its exit code, stdout and stderr; read a file; a fresh per-process scratch directory.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace palplab::testing {

struct CliResult {
  int code = -1;  // exit code, -1 if killed by a signal
  std::string out, err;
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A fresh directory <tmp>/palplab_<name>_<pid> (emptied if it exists).
inline std::filesystem::path scratch_dir(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() /
                 ("palplab_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

// Runs a shell command line with stdout/stderr captured in files of `dir`.
inline CliResult run_shell(const std::string& cmdline, const std::filesystem::path& dir) {
  const auto o = dir / "stdout.txt", e = dir / "stderr.txt";
  const std::string cmd = cmdline + " > " + o.string() + " 2> " + e.string();
  const int st = std::system(cmd.c_str());
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, slurp(o), slurp(e)};
}

// Root ignores permissions: as root, a permission test runs palplab as "nobody". The prefix
// for a command line ("" when not root), or nothing when that is impossible (root without
// runuser).
inline std::optional<std::string> unprivileged() {
  if (::geteuid() != 0) return std::string();
  if (std::system("runuser -u nobody -- true 2>/dev/null") != 0) return std::nullopt;
  return std::string("runuser -u nobody -- ");
}

// Runs `PALPLAB_BINARY args` (stdout/stderr captured in files of `dir`).
inline CliResult run_palplab(const std::string& args, const std::filesystem::path& dir) {
  return run_shell(std::string(PALPLAB_BINARY) + " " + args, dir);
}

// The test process's own scratch directory, made once.
inline const std::filesystem::path& process_scratch() {
  static const std::filesystem::path d = scratch_dir("cli");
  return d;
}

// The prefix that runs a command under Xvfb (screen e.g. "640x480x24"), bounded at 300 s, with
// the X authority file `auth` (a path in the test's scratch directory). With -f xvfb-run makes
// no temporary directory of its own: under load its `rm -r` of that directory failed now and
// then after the command had ended correctly (exit 5, "problem while cleaning up temporary
// directory"; CliRunMouse.ClosingTheWindowMidSessionAbortsItKeptAndFlagged, 2026-12-05).
inline std::string xvfb_run(const std::string& screen, const std::filesystem::path& auth) {
  return "timeout -k 10 300 xvfb-run -a -f " + auth.string() + " -s '-screen 0 " + screen + "' ";
}

// Runs `PALPLAB_BINARY args` in the process's scratch directory.
inline CliResult run_palplab(const std::string& args) {
  return run_palplab(args, process_scratch());
}

// The path of a file `name` in the process's scratch directory.
inline std::string scratch_file(const std::string& name) {
  return (process_scratch() / name).string();
}

// Writes `text` to a file `name` in the process's scratch directory and returns its path.
inline std::string write_temp(const std::string& name, const std::string& text) {
  const auto p = process_scratch() / name;
  std::ofstream(p, std::ios::binary) << text;
  return p.string();
}

// Runs any shell command line; `out` holds its stdout and stderr interleaved, `err` is empty.
inline CliResult run_command(const std::string& cmdline) {
  FILE* p = popen((cmdline + " 2>&1").c_str(), "r");
  CliResult r;
  if (!p) return r;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) r.out.append(buf.data(), n);
  const int st = pclose(p);
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// A UDP port on 127.0.0.1 that the kernel has just handed out as free (bound as port 0, then
// released), for a `palplab` process and a `device-sim` to meet on. Ports derived from the pid
// collided: the test processes ctest starts side by side have nearby pids.
inline int free_udp_port() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t n = sizeof a;
  int port = -1;
  if (fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n) == 0)
    port = ntohs(a.sin_port);
  if (fd >= 0) ::close(fd);
  return port;
}

inline bool has(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// Exit 2 (bad input), not an internal error, and stderr holds every one of `parts`.
inline void expect_exit2(const CliResult& r, const std::vector<std::string>& parts) {
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_FALSE(has(r.err, "internal error")) << r.err;
  for (const auto& p : parts) EXPECT_TRUE(has(r.err, p)) << r.err << "\nmissing: " << p;
}

// A tiny study: one participant in each of two groups (prototypes A and B), a 2 s pre-training
// and a 2 s post-training session: a results database in well under a second.
inline std::string tiny_study_json(const std::string& id, int seed) {
  return R"({"palplab_study": 1, "id": ")" + id + R"(", "title": "tiny", "seed": )" +
         std::to_string(seed) + R"(,
  "task": {"feature": "ovary_left", "thresholds": {"*": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}}},
  "groups": [{"id": "G1", "prototype": "A", "size": 1}, {"id": "G2", "prototype": "B", "size": 1}],
  "phases": [
    {"id": "pre", "kind": "pre_training", "session_duration": 2, "start": {"day": 0}},
    {"id": "test", "kind": "post_training", "session_duration": 2,
     "start": {"after_previous": {"minutes": 10}}}]})";
}

}  // namespace palplab::testing
