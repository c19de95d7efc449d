// `palplab bench` end to end: `bench --quick --json` writes every section with finite numbers
// and the framework's invariants (>= 5 repetitions, min <= median <= max); the frontier's
// errors come from the FEM reference, not from the model itself: the planted control (20 % too
// much displacement) is found at 0.2, and no prototype shows the zero error a comparison with
// itself would give; the FEM prototype D against the reference of its own problem shows a
// discretisation error, not ~100 %. No timing is asserted. The --quick run needs about 60 s of
// CPU time (the budget is 3 minutes on 2 cores): it runs once, in one test (ctest runs
// every TEST as its own process, so a shared fixture would run it once per test).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace {

struct Result {
  int code = -1;
  std::string out;
};

Result run(const std::string& args) {
  const std::string cmd = std::string(PALPLAB_BINARY) + " " + args + " 2>&1";
  Result r;
  FILE* p = popen(cmd.c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = pclose(p);
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::string data_dir() {
  return std::string(PALPLAB_SOURCE_DIR) + "/tests/data";
}

const nlohmann::json& quick_json() {
  static nlohmann::json j = [] {
    const auto dir = std::filesystem::temp_directory_path() /
                     ("palplab_cli_bench_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string json = (dir / "bench.json").string();
    const Result r = run("bench --quick --json " + json + " --md " + (dir / "bench.md").string() +
                         " --svg " + (dir / "svg").string() + " --data " + data_dir());
    EXPECT_EQ(r.code, 0) << r.out;
    std::ifstream in(json);
    nlohmann::json out = in ? nlohmann::json::parse(in) : nlohmann::json::object();
    EXPECT_TRUE(std::filesystem::exists(dir / "bench.md"));
    EXPECT_TRUE(std::filesystem::exists(dir / "svg" / "frontier.svg"));
    EXPECT_TRUE(std::filesystem::exists(dir / "svg" / "search.svg"));
    std::filesystem::remove_all(dir);
    return out;
  }();
  return j;
}

void expect_finite(const nlohmann::json& j, const std::string& path) {
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it) expect_finite(it.value(), path + "." + it.key());
  else if (j.is_array())
    for (size_t i = 0; i < j.size(); ++i) expect_finite(j[i], path + "[" + std::to_string(i) + "]");
  else if (j.is_number())
    EXPECT_TRUE(std::isfinite(j.get<double>())) << path;
  else
    EXPECT_FALSE(j.is_null()) << path;  // a NaN is written as null
}

const nlohmann::json* find(const nlohmann::json& section, const std::string& name) {
  for (const auto& r : section["results"])
    if (r["name"] == name) return &r;
  return nullptr;
}

TEST(CliBench, QuickRunHasEverySectionFiniteAndFindsPlantedError) {
  const nlohmann::json& j = quick_json();
  for (const char* s : {"search", "haptic_scope", "refinement", "integrators", "frontier",
                        "sleeping", "throughput", "stats"}) {
    ASSERT_TRUE(j.contains(s)) << s;
    EXPECT_TRUE(j[s]["quick"].get<bool>());
    ASSERT_FALSE(j[s]["results"].empty()) << s;
    for (const auto& r : j[s]["results"]) {
      if (r["reps"].get<int>() >= 5) {  // a timed case (controls and summaries have no reps)
        EXPECT_LE(r["min_s"].get<double>(), r["median_s"].get<double>()) << r["name"];
        EXPECT_LE(r["median_s"].get<double>(), r["max_s"].get<double>()) << r["name"];
        EXPECT_GT(r["median_s"].get<double>(), 0.0) << r["name"];
      } else {
        EXPECT_TRUE(r["reps"].get<int>() <= 1) << r["name"];
      }
    }
  }
  expect_finite(j, "$");

  // The octree finds exactly the linear scan's node.
  for (const auto& r : j["search"]["results"])
    EXPECT_EQ(r["metrics"]["mismatches"].get<double>(), 0.0) << r["name"];

  // The frontier finds the planted error, and no model is compared with itself.
  const auto& f = j["frontier"];
  const auto* planted = find(f, "ovary_left_planted_20pct");
  ASSERT_NE(planted, nullptr);
  EXPECT_NEAR((*planted)["metrics"]["force_curve_rel_err"].get<double>(), 0.2, 1e-9);
  EXPECT_NEAR((*planted)["metrics"]["field_rel_err"].get<double>(), 0.2, 1e-9);
  for (const char* m : {"A", "B", "C", "C_full"}) {
    const auto* r = find(f, std::string("ovary_left_") + m);
    ASSERT_NE(r, nullptr) << m;
    EXPECT_GT((*r)["metrics"]["force_curve_rel_err"].get<double>(), 1e-6) << m;
    EXPECT_GT((*r)["metrics"]["k_ref_N_per_m"].get<double>(), 0.0) << m;
  }
  // A rigid model does not deform: its field error is exactly 1.
  EXPECT_DOUBLE_EQ((*find(f, "ovary_left_A"))["metrics"]["field_rel_err"].get<double>(), 1.0);
  // The reference describes the prototypes' problem (D's support, material and pinning): the
  // FEM prototype D against it shows a discretisation error, not the ~100 % of a different
  // body, and so do the fully integrated mass-spring C and its condensed FEM variant; the
  // condensed FEM equals the linear one at equilibrium (the holds are quasi-static).
  const auto err = [&](const std::string& m, const char* key) {
    const auto* r = find(f, "ovary_left_" + m);
    EXPECT_NE(r, nullptr) << m;
    return r ? (*r)["metrics"][key].get<double>() : std::nan("");
  };
  EXPECT_LT(err("D", "force_curve_rel_err"), 0.15);
  EXPECT_LT(err("D", "field_rel_err"), 0.3);
  EXPECT_LT(err("C_full", "force_curve_rel_err"), 0.5);
  EXPECT_NEAR(err("D_condensed", "force_curve_rel_err"), err("D", "force_curve_rel_err"), 2e-3);
  EXPECT_LT(err("D", "settle_rel"), 0.01);
  // Hooke's-law models (A, B) are compared through their penalty stiffness: the same number.
  EXPECT_NEAR(err("A", "force_curve_rel_err"), err("B", "force_curve_rel_err"), 1e-9);
  const auto* ref = find(f, "ovary_left_reference");
  ASSERT_NE(ref, nullptr);
  EXPECT_GT((*ref)["metrics"]["c_ws_m_per_N"].get<double>(), 0.0);
  // The reference says whether it can be trusted, and why not: a trusted one was extrapolated
  // with a plausible order (fem_reference.hpp kPlausibleOrder) on levels that resolve the press;
  // an untrusted one names its reason in the case's description and stands in unextrapolated.
  const auto& rm = (*ref)["metrics"];
  const std::string what = (*ref)["what"].get<std::string>();
  EXPECT_GT(rm["press_h_level0_m"].get<double>(), 0.0);
  if (rm["ref_trusted"].get<double>() == 1.0) {
    EXPECT_NE(what.find("trusted"), std::string::npos) << what;
    EXPECT_EQ(what.find("NOT TRUSTED"), std::string::npos) << what;
    EXPECT_EQ(rm["ref_extrapolated"].get<double>(), 1.0);
    EXPECT_GE(rm["ref_order"].get<double>(), 0.8);
    EXPECT_LE(rm["ref_order"].get<double>(), 2.5);
    EXPECT_LE(rm["press_h_level0_m"].get<double>(), 0.01);  // D's pad radius
  } else {
    EXPECT_EQ(rm["ref_trusted"].get<double>(), 0.0);
    EXPECT_NE(what.find("NOT TRUSTED: "), std::string::npos) << what;
    EXPECT_GT(what.size(), what.find("NOT TRUSTED: ") + 20) << "a reason is given: " << what;
    EXPECT_EQ(rm["ref_extrapolated"].get<double>(), 0.0);
    EXPECT_EQ(rm["finest_vs_ref_rel"].get<double>(), 0.0);  // the finest level stands in
  }
  EXPECT_EQ(rm["ref_trusted"].get<double>(),
            (*find(f, "ovary_left_D"))["metrics"]["ref_trusted"].get<double>());

  // The integrators' reference agrees with itself at twice its step.
  for (const auto& r : j["integrators"]["results"]) {
    if (r["metrics"].contains("ref_self_err")) {
      EXPECT_LT(r["metrics"]["ref_self_err"].get<double>(), 1e-6) << r["name"];
    }
  }
}

TEST(CliBench, UnknownSectionIsAnInputError) {
  const Result r = run("bench no_such_section --data " + data_dir());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("frontier"), std::string::npos) << r.out;  // lists the known sections
}

// An unwritable --json or --md is an input error before the first section runs (the section
// named would take seconds; the output says nothing of it), not after the whole run.
TEST(CliBench, UnwritableOutputIsAnInputErrorBeforeAnySection) {
  for (const char* flag : {"--json", "--md"}) {
    const Result r = run(std::string("bench stats --quick --data ") + data_dir() + " " + flag +
                         " /nonexistent_dir_palplab/out.x");
    EXPECT_EQ(r.code, 2) << flag << ": " << r.out;
    EXPECT_NE(r.out.find("/nonexistent_dir_palplab/out.x"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("rows1e5"), std::string::npos) << "a section ran first: " << r.out;
  }
}

}  // namespace
