// End to end (issue 16 items 3-4): a reduced needle_insertion study through `palplab run` and
// `palplab report` (all five needle measures stored, finite where an insertion happened), and
// bad prototype N files -> exit 2 with the JSON path.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "results/store.hpp"
#include "tests/cli_support.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

using Result = palplab::testing::CliResult;
using palplab::testing::slurp;

using palplab::testing::run_palplab;
using palplab::testing::scratch_file;

const std::string kSrc = PALPLAB_SOURCE_DIR;

void write(const std::string& path, const json& j) {
  std::ofstream(path) << j.dump(2);
}

// The shipped study, cut to one trainee per group, one training and one test session.
json reduced_study() {
  json s = json::parse(slurp(kSrc + "/protocols/studies/needle_insertion.json"));
  s["id"] = "needle_insertion_reduced";
  for (auto& g : s["groups"]) g["size"] = 1;
  s["phases"][0]["sessions"] = 1;
  s["phases"][0].erase("gap");
  s["prototype_dirs"] = json::array({kSrc + "/prototypes"});
  s["analyses"] = json::array();
  for (const char* m : {"insertion_attempts", "layers_passed", "tip_to_target_mm", "bone_contacts",
                        "procedure_time"})
    s["analyses"].push_back({{"kind", "descriptives"}, {"measure", m}, {"phase", "test"}});
  return s;
}

TEST(CliNeedleStudy, ReducedRunStoresEveryNeedleMeasureAndReports) {
  write(scratch_file("study.json"), reduced_study());
  const Result v = run_palplab("validate " + scratch_file("study.json"));
  ASSERT_EQ(v.code, 0) << v.err << v.out;
  // The summary describes the needle task, not a palpation one.
  EXPECT_EQ(v.out.find("task: find"), std::string::npos) << v.out;
  for (const char* want :
       {"task: needle insertion into \"membrane\"", "tool finger: palpate the skin",
        "tool needle: insert along the stylus axis", "briefed depth 50 mm", "tip_to_target_mm [mm]",
        "insertion_attempts [1]",
        "transparent / training: N_transparent, model needle, tools finger+needle, soft tissue "
        "transparent",
        "transparent / test: N, model needle, tools finger+needle, opaque (tip not visible) [phase "
        "switch]",
        "opaque / training: N, model needle, tools finger+needle, opaque (tip not visible) "
        "[prototype]"})
    EXPECT_NE(v.out.find(want), std::string::npos) << want << "\n" << v.out;
  const Result r = run_palplab("run " + scratch_file("study.json") + " --db " +
                               scratch_file("n.db") + " --quiet");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const auto store = palplab::results::Store::open(scratch_file("n.db"));
  // Each session stores the transparency it ran with, each phase its declared switch.
  {
    const auto parts = store.read_participants();
    std::map<std::string, std::string> group;
    for (const auto& pr : parts) group[pr.participant] = pr.group;
    int seen = 0;
    for (const auto& ss : store.read_sessions()) {
      ASSERT_TRUE(ss.transparency.has_value()) << ss.session;
      const bool expect = group[ss.participant] == "transparent" && ss.phase == "training";
      EXPECT_EQ(*ss.transparency, expect) << ss.participant << " " << ss.phase;
      ++seen;
    }
    EXPECT_EQ(seen, 4);
    const auto st = store.read_structure();
    ASSERT_EQ(st.phases.size(), 2u);
    EXPECT_FALSE(st.phases[0].transparency.has_value());  // training: as the prototype says
    ASSERT_TRUE(st.phases[1].transparency.has_value());   // test: switched off
    EXPECT_FALSE(*st.phases[1].transparency);
  }
  // (Human needle sessions: tests/cli_needle/test_cli_needle_human.cpp.)
  const auto rows = store.read_measures();
  const std::set<std::string> wanted = {"insertion_attempts", "layers_passed", "tip_to_target_mm",
                                        "bone_contacts", "procedure_time"};
  std::map<long long, std::set<std::string>> per_session;
  for (const auto& m : rows) {
    ASSERT_TRUE(wanted.count(m.name)) << m.name;
    per_session[m.session].insert(m.name);
    ASSERT_TRUE(m.value.has_value()) << m.name << " undefined in session " << m.session;
    EXPECT_TRUE(std::isfinite(*m.value)) << m.name;
    if (m.name == "insertion_attempts") {
      EXPECT_GE(*m.value, 1.0);
      EXPECT_LE(*m.value, 3.0);  // max_insertions
    }
    if (m.name == "layers_passed") {
      EXPECT_GE(*m.value, 2.0);  // skin and fat at least
    }
    if (m.name == "tip_to_target_mm") {
      EXPECT_GE(*m.value, 0.0);
      EXPECT_LT(*m.value, 60.0);
    }
    if (m.name == "procedure_time") {
      EXPECT_GT(*m.value, 1.0);
      EXPECT_LE(*m.value, 60.0);
    }
  }
  EXPECT_EQ(per_session.size(), 4u);  // 2 trainees x 2 sessions
  for (const auto& [s, names] : per_session) EXPECT_EQ(names, wanted);
  // The log shows the phases: the tool switch and the needle events.
  const auto sessions = store.read_sessions();
  ASSERT_FALSE(sessions.empty());
  const auto ev = store.read_events(sessions.front().session);
  bool tool = false, entered = false;
  for (const auto& e : ev) {
    tool = tool || e.kind == "tool_changed";
    entered = entered || (e.kind == "tissue_entered" && e.region == "skin");
  }
  EXPECT_TRUE(tool);
  EXPECT_TRUE(entered);
  const Result rep =
      run_palplab("report " + scratch_file("n.db") + " --out " + scratch_file("report"));
  ASSERT_EQ(rep.code, 0) << rep.err;
  const std::string md = slurp(scratch_file("report") + "/report.md");
  for (const auto& m : wanted) EXPECT_NE(md.find(m), std::string::npos) << m;
}

json n_proto() {
  return json::parse(slurp(kSrc + "/prototypes/N.json"));
}

TEST(CliNeedleStudy, BadPrototypeKeysExitTwoWithThePath) {
  struct Case {
    std::string name;
    std::function<void(json&)> edit;
    std::string expect;
  };
  const std::vector<Case> cases = {
      {"unknown_key", [](json& j) { j["model"]["tol"] = "finger"; }, "$.model.tol"},
      {"bad_tool", [](json& j) { j["model"]["tool"] = "scalpel"; }, "$.model.tool"},
      {"zero_axis",
       [](json& j) {
         j["model"]["axis"] = {0, 0, 0};
       },
       "$.model.axis"},
      {"radius", [](json& j) { j["model"]["finger_radius"] = -1; }, "$.model.finger_radius"},
      {"cue", [](json& j) { j["cues"]["transparent"] = true; }, "$.cues.transparent"},
      {"surface_mesh",
       [](json& j) {
         j["mesh"] = {{"generator", "sphere"}};
       },
       "tetrahedral"},
  };
  for (const auto& c : cases) {
    json j = n_proto();
    c.edit(j);
    const std::string f = scratch_file("N_" + c.name + ".json");
    write(f, j);
    const Result r = run_palplab("probe " + f + " --press 0 --force 1 --duration 0.01");
    EXPECT_EQ(r.code, 2) << c.name << ": " << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.name << ": " << r.err;
  }
}

TEST(CliNeedleStudy, BadNeedleTaskKeysExitTwoWithThePath) {
  json s = reduced_study();
  s["task"].erase("entry_hint");
  s["task"]["target_depth_hint"] = -0.01;
  write(scratch_file("bad_study.json"), s);
  const Result r = run_palplab("validate " + scratch_file("bad_study.json"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("$.task"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("entry_hint"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("$.task.target_depth_hint"), std::string::npos) << r.err;
}

}  // namespace
