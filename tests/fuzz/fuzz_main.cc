// libFuzzer target for one parser (the entry PALPLAB_FUZZ_TARGET, set per executable by CMake with
// -DPALPLAB_FUZZ=ON). Deliberately .cc: the tests/ glob (*.cpp) builds the regression test
// test_fuzz from this folder without it. See docs/FUZZING.md.
#include "tests/fuzz/fuzz_entries.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  palplab::fuzz::PALPLAB_FUZZ_TARGET(data, size);
  return 0;
}
