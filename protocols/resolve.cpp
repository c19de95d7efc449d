#include "protocols/resolve.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace palplab::protocols {

std::string source_tree_dir() {
  // The source tree the binary was built from (a compile definition: __FILE__ is not reliably
  // absolute, e.g. under ccache's base_dir rewriting), used only if it still holds prototypes.
  const fs::path tree(PALPLAB_SOURCE_TREE);
  std::error_code ec;
  return fs::exists(tree / "prototypes", ec) ? tree.string() : std::string();
}

static std::string exe_dir() {
  char buf[4096];
  ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return {};
  buf[n] = 0;
  return fs::path(buf).parent_path().string();
}

std::vector<std::string> prototype_search_dirs(const std::string& study_file,
                                               const std::vector<std::string>& prototype_dirs) {
  std::vector<std::string> dirs;
  fs::path sdir = fs::path(study_file).parent_path();
  if (sdir.empty()) sdir = ".";
  for (const auto& d : prototype_dirs) {
    fs::path p(d);
    dirs.push_back((p.is_absolute() ? p : sdir / p).lexically_normal().string());
  }
  dirs.push_back(sdir.lexically_normal().string());
  dirs.push_back((sdir / "prototypes").lexically_normal().string());
  if (const char* env = std::getenv("PALPLAB_PROTOTYPE_PATH")) {
    std::string s(env);
    std::size_t i = 0;
    while (i <= s.size()) {
      std::size_t j = s.find(':', i);
      if (j == std::string::npos) j = s.size();
      if (j > i) dirs.push_back(s.substr(i, j - i));
      i = j + 1;
    }
  }
  if (auto t = source_tree_dir(); !t.empty()) dirs.push_back((fs::path(t) / "prototypes").string());
  if (auto e = exe_dir(); !e.empty())
    dirs.push_back((fs::path(e) / ".." / "share" / "palplab" / "prototypes").lexically_normal());
  // Each directory once, in its first place (PALPLAB_PROTOTYPE_PATH often names the source
  // tree's prototypes again): a message lists the search path without repeats.
  std::vector<std::string> once;
  for (auto& d : dirs) {
    const std::string n = fs::path(d).lexically_normal().string();
    if (std::find(once.begin(), once.end(), n) == once.end()) once.push_back(n);
  }
  return once;
}

namespace {
// A study (its "palplab_study" key near the top) is never a prototype: a study saved as A.json
// in the working directory was taken for prototype A by `probe --scene A` (review of the
// fixes, 2026-12-07).
bool is_study_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::string head(4096, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return head.find("\"palplab_study\"") != std::string::npos;
}
}  // namespace

std::string resolve_prototype(const std::string& id, const std::vector<std::string>& search_dirs,
                              const std::string& study_file) {
  if (id.empty() || id.find('/') != std::string::npos || id[0] == '.') return {};
  for (const auto& d : search_dirs) {
    fs::path p = fs::path(d) / (id + ".json");
    std::error_code ec;
    if (!fs::is_regular_file(p, ec)) continue;
    if (!study_file.empty() && fs::equivalent(p, study_file, ec)) continue;
    if (is_study_file(p)) continue;
    return p.string();
  }
  return {};
}

}  // namespace palplab::protocols
