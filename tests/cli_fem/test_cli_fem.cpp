// End-to-end tests of `palplab fem verify`: exit codes and the JSON contract (issue 12).
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

Result run(const std::string& args) {
  const fs::path d = palplab::testing::scratch_dir("cli_fem");
  Result r = palplab::testing::run_palplab(args, d);
  fs::remove_all(d);
  return r;
}

}  // namespace

// The whole verification (~5 s: the cantilever needs a 20k-dof level, see fem_verify.hpp).
TEST(CliFem, VerifyJsonPassesWithEveryCase) {
  const Result r = run("fem verify --json");
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const json j = json::parse(r.out);
  EXPECT_TRUE(j.at("pass").get<bool>());
  const std::vector<std::string> names = {"patch_test",
                                          "uniaxial_compression",
                                          "uniaxial_poisson",
                                          "cantilever",
                                          "stiffness_symmetry",
                                          "rigid_modes",
                                          "corotational_invariance",
                                          "corotational_small_strain",
                                          "corotational_tangent",
                                          "condensed_equals_full",
                                          "inverse_stiffness_contact"};
  ASSERT_EQ(j.at("cases").size(), names.size());
  for (size_t i = 0; i < names.size(); ++i) {
    const json& c = j["cases"][i];
    EXPECT_EQ(c.at("name"), names[i]);
    for (const char* k : {"quantity", "computed", "analytic", "rel_error", "tolerance",
                          "observed_order", "pass", "detail"})
      EXPECT_TRUE(c.contains(k)) << names[i] << " lacks " << k;
    EXPECT_LE(c["rel_error"].get<double>(), c["tolerance"].get<double>()) << names[i];
  }
  EXPECT_GT(j["cases"][3]["observed_order"].get<double>(), 1.5);  // cantilever
  EXPECT_TRUE(j["cases"][0]["observed_order"].is_null());
}

TEST(CliFem, BadLevelsIsAnInputError) {
  const Result r = run("fem verify --levels 2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--levels"), std::string::npos) << r.err;
  EXPECT_EQ(run("fem").code, 2);  // a sub-command is required: a usage error
  // CLI11's bare "Could not convert: --levels = x" before (review 2026-12-06, fourth).
  const Result x = run("fem verify --levels x");
  EXPECT_EQ(x.code, 2);
  EXPECT_NE(x.err.find("--levels: expected an integer in [4, 5], got 'x'"), std::string::npos)
      << x.err;
}
