// End-to-end tests of `palplab power` and `palplab merge`: a study without any effect has power
// alpha (its Monte Carlo interval covers .05), resuming adds only the missing replicates and
// gives the uninterrupted result, shards merged equal a single run, and (in a PALPLAB_MPI
// build) `mpirun -np 2` equals a single process. The null test needs many replicates to say
// anything about alpha, so it is the slow one (~10 s on one core): replicates are tiny
// (2 x 3 participants, one 12 s session).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../cli_support.hpp"

namespace fs = std::filesystem;

namespace {
using Result = palplab::testing::CliResult;
using palplab::testing::run_palplab;
using palplab::testing::run_shell;
using palplab::testing::scratch_dir;
using palplab::testing::slurp;

std::string null_study() {
  return (fs::path(PALPLAB_SOURCE_DIR) / "tests" / "data" / "power" / "null_study.json").string();
}

nlohmann::json power_json(const fs::path& dir) {
  return nlohmann::json::parse(slurp(dir / "power.json"));
}

}  // namespace

TEST(Power, NoEffectGivesAlpha) {
  auto d = scratch_dir("null");
  auto r = run_palplab(
      "power " + null_study() + " --replicates 60 --jobs 2 --quiet --out " + (d / "out").string(),
      d);
  ASSERT_EQ(r.code, 0) << r.err;
  auto j = power_json(d / "out");
  ASSERT_EQ(j["tests"].size(), 2u);  // the ANOVA and the one pair
  for (const auto& t : j["tests"]) {
    const auto& c = t["by_n"][0];
    EXPECT_EQ(c["n"], 3);
    EXPECT_EQ(c["replicates"], 60);
    // Every replicate gives a defined test (the feature is found in 12 s).
    EXPECT_LE(c["undefined"].get<int>(), 3) << t["id"];
    EXPECT_LE(c["ci_low"].get<double>(), 0.05) << t["id"];
    EXPECT_GE(c["ci_high"].get<double>(), 0.05) << t["id"];
    EXPECT_LT(c["power"].get<double>(), 0.25) << t["id"];
  }
  EXPECT_TRUE(fs::exists(d / "out" / "power.svg"));
  EXPECT_NE(slurp(d / "out" / "power.md").find("| anova_oneway palpation_force test |"),
            std::string::npos);
  fs::remove_all(d);
}

TEST(Power, ResumeAndShardsGiveTheSingleRunResult) {
  auto d = scratch_dir("shard");
  const std::string base = "power " + null_study() + " --n 2,3 --quiet";
  auto single = run_palplab(base + " --replicates 3 --out " + (d / "single").string(), d);
  ASSERT_EQ(single.code, 0) << single.err;
  // Resume: 2 replicates first, then 3 in the same directory runs only the missing ones.
  ASSERT_EQ(run_palplab(base + " --replicates 2 --out " + (d / "resumed").string(), d).code, 0);
  auto resumed = run_palplab(base + " --replicates 3 --out " + (d / "resumed").string(), d);
  ASSERT_EQ(resumed.code, 0) << resumed.err;
  EXPECT_NE(resumed.out.find("(2 replicates run now)"), std::string::npos) << resumed.out;
  EXPECT_EQ(power_json(d / "resumed"), power_json(d / "single"));
  // Shards 1/2 and 2/2 into separate directories, then merged.
  for (int i = 1; i <= 2; ++i) {
    auto s = run_palplab(base + " --replicates 3 --shard " + std::to_string(i) + "/2 --out " +
                             (d / ("s" + std::to_string(i))).string(),
                         d);
    ASSERT_EQ(s.code, 0) << s.err;
  }
  auto m = run_palplab("merge " + (d / "s1").string() + " " + (d / "s2").string() + " --out " +
                           (d / "merged").string(),
                       d);
  ASSERT_EQ(m.code, 0) << m.err;
  EXPECT_EQ(power_json(d / "merged"), power_json(d / "single"));
  // A shard alone is not the whole result.
  EXPECT_FALSE(fs::exists(d / "s1" / "power.json"));
  fs::remove_all(d);
}

TEST(Power, BadArgumentsAreInputErrors) {
  auto d = scratch_dir("bad");
  EXPECT_EQ(
      run_palplab("power " + null_study() + " --replicates 2 --shard 3/2 --out " + d.string(), d)
          .code,
      2);
  EXPECT_EQ(run_palplab("merge " + (d / "nothing").string() + " --out " + d.string(), d).code, 2);
  // NaN and inf pass CLI11's Range (every comparison with NaN is false): refused, exit 2.
  for (const char* bad : {"--alpha nan", "--alpha inf", "--target-power nan", "--alpha 0.7"}) {
    const auto r = run_palplab(
        "power " + null_study() + " --replicates 2 " + bad + " --out " + (d / "never").string(), d);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.out << r.err;
    EXPECT_FALSE(fs::exists(d / "never" / "replicates.jsonl")) << bad;
  }
  fs::remove_all(d);
}

// --n "6,,8" was 6,8 (CLI11 drops empty entries) and "3,3" simulated n = 3 twice; a study
// without a test has no power to compute; an unwritable --out is refused before any replicate.
TEST(Power, SizesStudyAndOutputAreCheckedFirst) {
  auto d = scratch_dir("first");
  for (const char* bad : {"6,,8", "3,3", "3,", ",3", "3,x", "1", "3.5"}) {
    const auto r = run_palplab("power " + null_study() + " --replicates 1 --quiet --n " + bad +
                                   " --out " + (d / "never").string(),
                               d);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.out << r.err;
    EXPECT_NE(r.err.find("--n:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(std::string("\"") + bad + "\""), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(d / "never")) << bad;
  }
  // Only descriptives: nothing to compute the power of.
  std::string text = slurp(null_study());
  const auto a = text.find("\"analyses\"");
  ASSERT_NE(a, std::string::npos);
  text = text.substr(0, a) +
         "\"analyses\": [{\"kind\": \"descriptives\", \"measure\": \"palpation_force\", "
         "\"phase\": \"test\"}]\n}\n";
  const std::string dirs = "\"prototype_dirs\": [\"../../../prototypes\"]";
  const auto p = text.find(dirs);
  ASSERT_NE(p, std::string::npos);
  text.replace(p, dirs.size(),
               "\"prototype_dirs\": [\"" + std::string(PALPLAB_SOURCE_DIR) + "/prototypes\"]");
  std::ofstream(d / "no_tests.json") << text;
  const auto nt = run_palplab("power " + (d / "no_tests.json").string() +
                                  " --replicates 1 --quiet --out " + (d / "never").string(),
                              d);
  EXPECT_EQ(nt.code, 2) << nt.out << nt.err;
  EXPECT_NE(nt.err.find("no_tests.json: $.analyses:"), std::string::npos) << nt.err;
  EXPECT_FALSE(fs::exists(d / "never"));
  // --out under a regular file cannot be created.
  std::ofstream(d / "file") << "x";
  const auto w = run_palplab(
      "power " + null_study() + " --replicates 1 --quiet --out " + (d / "file" / "out").string(),
      d);
  EXPECT_EQ(w.code, 2) << w.out << w.err;
  EXPECT_NE(w.err.find("--out"), std::string::npos) << w.err;
  const auto m = run_palplab("merge " + d.string() + " --out " + (d / "file" / "m").string(), d);
  EXPECT_EQ(m.code, 2) << m.out << m.err;
  EXPECT_NE(m.err.find("--out"), std::string::npos) << m.err;
  fs::remove_all(d);
}

TEST(Power, MpiEqualsSingleProcess) {
#ifndef PALPLAB_MPIEXEC
  GTEST_SKIP() << "built without PALPLAB_MPI";
#else
  auto d = scratch_dir("mpi");
  const std::string base = "power " + null_study() + " --n 2,3 --replicates 3 --quiet --out ";
  ASSERT_EQ(run_palplab(base + (d / "single").string(), d).code, 0);
  // Root in containers: OpenMPI refuses unless told; --oversubscribe for 2 ranks on 1 core.
  const std::string mpirun =
      std::string("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 timeout -k 10 300 ") +
      PALPLAB_MPIEXEC + " -np 2 --oversubscribe ";
  auto r = run_shell(mpirun + PALPLAB_BINARY + " " + base + (d / "mpi").string(), d);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_EQ(power_json(d / "mpi"), power_json(d / "single"));
  // Shards under MPI (each shard's replicates shared by the ranks), merged.
  for (int i = 1; i <= 2; ++i) {
    auto s =
        run_shell(mpirun + PALPLAB_BINARY + " " + base + (d / ("m" + std::to_string(i))).string() +
                      " --shard " + std::to_string(i) + "/2",
                  d);
    ASSERT_EQ(s.code, 0) << s.out << s.err;
  }
  ASSERT_EQ(run_palplab("merge " + (d / "m1").string() + " " + (d / "m2").string() + " --out " +
                            (d / "mmerged").string(),
                        d)
                .code,
            0);
  EXPECT_EQ(power_json(d / "mmerged"), power_json(d / "single"));
  fs::remove_all(d);
#endif
}
