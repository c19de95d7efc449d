#include "tests/fuzz/fuzz_entries.hpp"

namespace palplab::fuzz {

const std::vector<Target>& targets() {
  static const std::vector<Target> t = {
      {"study", study}, {"prototype", prototype}, {"obj", obj}, {"stl", stl}, {"off", off},
      {"ply", ply},     {"tetgen", tetgen},       {"vtu", vtu}, {"csv", csv}};
  return t;
}

}  // namespace palplab::fuzz
