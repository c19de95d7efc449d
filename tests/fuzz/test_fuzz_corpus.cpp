// The fuzz corpus as a regression test: every file in tests/fuzz/corpus/<target>/ (the seeds and
// every input that once crashed, hung or leaked) goes through the same entry function as the
// libFuzzer target, with any compiler. An entry may only throw palplab::InputError (and catches
// it); a crash or another exception fails here.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <ostream>

#include "tests/fuzz/fuzz_entries.hpp"

namespace fs = std::filesystem;

namespace palplab::fuzz {
// Test names and messages show the target's name, not its bytes.
inline void PrintTo(const Target& t, std::ostream* os) {
  *os << t.name;
}
}  // namespace palplab::fuzz

class FuzzCorpus : public ::testing::TestWithParam<palplab::fuzz::Target> {};

TEST_P(FuzzCorpus, EveryInputEndsInAnInputErrorAtWorst) {
  const auto& t = GetParam();
  const fs::path dir = fs::path(PALPLAB_SOURCE_DIR) / "tests" / "fuzz" / "corpus" / t.name;
  ASSERT_TRUE(fs::is_directory(dir)) << dir;
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    SCOPED_TRACE(e.path().string());
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_NO_THROW(t.entry(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(s, 5.0) << "slow input (a hang in the making): " << e.path();
    ++n;
  }
  EXPECT_GT(n, 0) << "empty corpus " << dir;
}

INSTANTIATE_TEST_SUITE_P(AllParsers, FuzzCorpus, ::testing::ValuesIn(palplab::fuzz::targets()),
                         [](const auto& info) { return std::string(info.param.name); });
