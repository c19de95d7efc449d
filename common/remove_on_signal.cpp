#include "common/remove_on_signal.hpp"

#include <limits.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>
#include <mutex>

namespace palplab {

namespace {

constexpr int kSlots = 64;
constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};

// A slot's path is written while it is free and published by `used` (release); the handler reads
// only slots it sees used (acquire). Only async-signal-safe calls in the handler: unlink, signal,
// raise.
struct Slot {
  std::atomic<bool> used{false};
  char path[PATH_MAX] = {};
};
Slot g_slots[kSlots];
std::mutex g_claim;  // registrations from several threads claim distinct slots

extern "C" void remove_registered_and_reraise(int sig) {
  remove_registered_files();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

// On every registration (a command may have restored the default since the last one).
void install() {
  for (int sig : kSignals) {
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) != 0) continue;
    if (!(old.sa_flags & SA_SIGINFO) && old.sa_handler == SIG_DFL)
      std::signal(sig, remove_registered_and_reraise);
  }
}

}  // namespace

void remove_registered_files() noexcept {
  for (auto& s : g_slots)
    if (s.used.load(std::memory_order_acquire)) ::unlink(s.path);
  // Then the directories (unlink fails on them, rmdir on files and on directories that are not
  // empty), in a few passes so that a parent goes once its registered children have gone
  // (slots are reused, so their order is not the registration order).
  for (int pass = 0; pass < 4; ++pass)
    for (int i = kSlots - 1; i >= 0; --i)
      if (g_slots[i].used.load(std::memory_order_acquire)) ::rmdir(g_slots[i].path);
}

RemoveOnSignal::RemoveOnSignal(const std::string& path) {
  if (path.empty() || path.size() >= PATH_MAX) return;
  std::lock_guard<std::mutex> lock(g_claim);
  install();
  for (int i = 0; i < kSlots; ++i) {
    Slot& s = g_slots[i];
    if (s.used.load(std::memory_order_relaxed)) continue;
    std::memcpy(s.path, path.c_str(), path.size() + 1);
    s.used.store(true, std::memory_order_release);
    slot_ = i;
    return;
  }
}

RemoveOnSignal::~RemoveOnSignal() {
  if (slot_ >= 0) g_slots[slot_].used.store(false, std::memory_order_release);
}

}  // namespace palplab
