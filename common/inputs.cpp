#include "common/inputs.hpp"

#include <sys/stat.h>

#include <mutex>
#include <set>
#include <utility>

namespace palplab {

namespace {

struct Inputs {
  std::mutex mu;
  std::set<std::pair<dev_t, ino_t>> files;
};

Inputs& inputs() {
  static Inputs in;
  return in;
}

}  // namespace

void note_input(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return;
  Inputs& in = inputs();
  std::lock_guard<std::mutex> lock(in.mu);
  in.files.insert({st.st_dev, st.st_ino});
}

bool is_noted_input(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return false;
  Inputs& in = inputs();
  std::lock_guard<std::mutex> lock(in.mu);
  return in.files.count({st.st_dev, st.st_ino}) > 0;
}

}  // namespace palplab
