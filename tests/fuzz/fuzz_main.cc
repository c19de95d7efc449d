// libFuzzer target for one parser (PALPLAB_FUZZ_TARGET, set per executable by CMake with
// -DPALPLAB_FUZZ=ON). Deliberately .cc: the tests/ glob (*.cpp) builds the regression test
// test_fuzz from this folder without it. See docs/FUZZING.md.
#include <cstdlib>

#include "tests/fuzz/fuzz_entries.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const palplab::fuzz::Entry entry = palplab::fuzz::find_target(PALPLAB_FUZZ_TARGET);
  if (!entry) std::abort();
  entry(data, size);
  return 0;
}
