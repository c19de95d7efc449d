// End-to-end: `palplab mesh generate shoulder` -> `mesh tetrahedralize` -> `mesh check` (issue 16).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include "tests/cli_support.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

using Result = palplab::testing::CliResult;
using palplab::testing::slurp;

using palplab::testing::run_palplab;
using palplab::testing::scratch_file;

TEST(CliShoulder, GenerateTetrahedralizeCheck) {
  ASSERT_EQ(run_palplab("mesh generate shoulder --vertices 642 --out " + scratch_file("sh")).code,
            0);
  ASSERT_TRUE(fs::exists(scratch_file("sh.obj")));
  ASSERT_TRUE(fs::exists(scratch_file("sh.regions")));
  EXPECT_EQ(run_palplab("mesh check " + scratch_file("sh.obj")).code, 0);
  // Same arguments, same bytes.
  ASSERT_EQ(
      run_palplab("mesh generate shoulder --vertices 642 --out " + scratch_file("sh2.obj")).code,
      0);
  EXPECT_EQ(slurp(scratch_file("sh.obj")), slurp(scratch_file("sh2.obj")));
  EXPECT_EQ(slurp(scratch_file("sh.regions")), slurp(scratch_file("sh2.regions")));
  // The .regions side file is found next to the surface.
  const Result t = run_palplab("mesh tetrahedralize " + scratch_file("sh.obj") + " --out " +
                               scratch_file("tet"));
  ASSERT_EQ(t.code, 0) << t.err;
  EXPECT_NE(t.out.find("with regions from"), std::string::npos) << t.out;
  EXPECT_EQ(run_palplab("mesh check " + scratch_file("tet.node")).code, 0);
  const Result i = run_palplab("mesh info " + scratch_file("tet.node") + " --json");
  ASSERT_EQ(i.code, 0);
  const json j = json::parse(i.out);
  for (const char* tissue : {"100", "101", "107", "200", "201", "300"})
    EXPECT_TRUE(j["tissues"].contains(tissue)) << tissue;
  EXPECT_EQ(j["tissues"].size(), 6u);
}

TEST(CliShoulder, BadVertexCountIsExit2) {
  const Result r = run_palplab("mesh generate shoulder --vertices 50 --out " + scratch_file("bad"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("between 162 and 40962"), std::string::npos) << r.err;
}

}  // namespace
