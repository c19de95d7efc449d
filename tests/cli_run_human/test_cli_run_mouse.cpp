// `palplab run --human --device mouse` end to end under Xvfb: the palpation window with a
// scripted mouse (--mouse-script) runs participant P01's due session (instructions shown, then
// the session with the 1 kHz haptic loop on its own thread) and the database holds it exactly as
// a virtual participant's session is held (the same tables, the same measure names and units,
// one sample per haptic step); closing the window mid-session aborts the session, kept and
// flagged. Skipped only without xvfb-run.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

#include "tests/cli_human_support.hpp"

namespace fs = std::filesystem;

namespace {
using Result = palplab::testing::CliResult;
using palplab::testing::db_rows;
using palplab::testing::have_xvfb;
using palplab::testing::kNoXvfb;
const std::string kMouseDir = std::string(PALPLAB_SOURCE_DIR) + "/tests/cli_run_human/";
constexpr int kW = 400, kH = 300;

// A pixel where the window's default camera sees prototype A's surface head-on, so a press
// along the view direction goes straight into the tissue.
std::pair<int, int> organ_pixel() {
  const auto p = palplab::testing::head_on_pixel_of("A", kW, kH);
  EXPECT_TRUE(p && p->cosine > 0.95);
  return p ? std::pair<int, int>{p->x, p->y} : std::pair<int, int>{kW / 2, kH / 2};
}

// Presses on the organ from 0.1 s (10 wheel notches: 8 mm past the surface along the view ray),
// backs out at 1.2 s; `close_at` in (0, 1.2) closes the window then instead.
fs::path write_script(const fs::path& dir, double close_at) {
  const auto [x, y] = organ_pixel();
  const fs::path p = dir / (close_at > 0 ? "close.json" : "press.json");
  std::ofstream o(p);
  o << "{\"palplab_mouse_script\": 1, \"instructions_seconds\": 0.2, \"events\": ["
    << "{\"t\": 0.0, \"x\": " << x << ", \"y\": " << y << ", \"left\": true},"
    << "{\"t\": 0.1, \"wheel\": 10}, "
    << (close_at > 0 ? "{\"t\": " + std::to_string(close_at) + ", \"close\": true}"
                     : "{\"t\": 1.2, \"wheel\": -10}")
    << "]}";
  return p;
}

Result human(const fs::path& db, const fs::path& script) {
  return palplab::testing::run_command(
      palplab::testing::mouse_run(kMouseDir + "mouse_study.json", db, script, kW, kH));
}
}  // namespace

TEST(CliRunMouse, ScriptedMouseSessionIsStoredLikeAVirtualOne) {
  if (!have_xvfb()) GTEST_SKIP() << kNoXvfb;
  const fs::path dir = palplab::testing::scratch_dir("run_mouse");
  const fs::path db = dir / "human.db", vdb = dir / "virtual.db";
  const Result r = human(db, write_script(dir, 0));
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  // The phase's instructions are said (and shown) before the session; the next one is due later.
  EXPECT_NE(r.out.find("instructions: Drag over the model to find the left ovary"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("1 session(s) completed, 0 aborted, 1 remaining; next due 2026-11-26"),
            std::string::npos)
      << r.out;
  auto s = db_rows(db, "SELECT * FROM sessions");
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0]["status"], "complete");
  EXPECT_EQ(s[0]["trainee"], "human");
  EXPECT_EQ(s[0]["device"], "mouse");
  EXPECT_EQ(s[0]["steps"], "2000");
  EXPECT_GT(std::stod(s[0]["loop_median"]), 0.0);
  // One sample per haptic step, every second stored.
  EXPECT_EQ(db_rows(db, "SELECT SUM(n) AS n FROM samples")[0]["n"], "2000");
  // The scripted press reached the organ: contact, and the ST cue (prototype A, stiffness
  // 500 N/m, 8 mm along the view ray) -- the same events a virtual participant's press makes.
  std::set<std::string> kinds;
  for (auto& e : db_rows(db, "SELECT DISTINCT kind FROM events")) kinds.insert(e["kind"]);
  EXPECT_TRUE(kinds.count("contact_start")) << r.out;
  EXPECT_TRUE(kinds.count("st_reached")) << r.out;

  // The same study with virtual participants: the same measures (names, units) per session.
  const Result v =
      palplab::testing::run_command(std::string(PALPLAB_BINARY) + " run " + kMouseDir +
                                    "mouse_study.json --db " + vdb.string() + " --quiet");
  ASSERT_EQ(v.code, 0) << v.out << v.err;
  auto names = [](const fs::path& d) {
    std::set<std::string> out;
    for (auto& m : db_rows(d,
                           "SELECT name || ' ' || unit AS n FROM measures WHERE session = "
                           "(SELECT MIN(session) FROM sessions)"))
      out.insert(m["n"]);
    return out;
  };
  EXPECT_FALSE(names(db).empty());
  EXPECT_EQ(names(db), names(vdb));
  fs::remove_all(dir);
}

TEST(CliRunMouse, ClosingTheWindowMidSessionAbortsItKeptAndFlagged) {
  if (!have_xvfb()) GTEST_SKIP() << kNoXvfb;
  const fs::path dir = palplab::testing::scratch_dir("run_mouse_close");
  const fs::path db = dir / "human.db";
  const Result r = human(db, write_script(dir, 0.6));
  ASSERT_EQ(r.code, 1) << r.out << r.err;
  auto s = db_rows(db, "SELECT * FROM sessions");
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0]["status"], "aborted");
  EXPECT_EQ(s[0]["abort_reason"], "window closed");
  // The partial log is kept: up to 0.6 s of samples (fewer when a loaded machine makes the
  // real-time loop fall behind), not the planned 2 s.
  const long n = std::stol(db_rows(db, "SELECT SUM(n) AS n FROM samples")[0]["n"]);
  EXPECT_EQ(s[0]["steps"], std::to_string(n));
  EXPECT_GT(n, 20);
  EXPECT_LT(n, 1900);
  // (That the next run repeats it as attempt 1 is run_human's, tested with a silent UDP device.)
  fs::remove_all(dir);
}

TEST(CliRunMouse, NoDisplayOrBadScriptExits2) {
  const fs::path dir = palplab::testing::scratch_dir("run_mouse_bad");
  const fs::path db = dir / "human.db";
  const std::string base = "env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(PALPLAB_BINARY) +
                           " run " + kMouseDir + "mouse_study.json --db " + db.string() +
                           " --human --participant P01 ";
  Result r = palplab::testing::run_command(base + "--device mouse");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--device mouse needs a window"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(db));  // refused before anything was stored
  r = palplab::testing::run_command(base + "--device udp:5999 --mouse-script x.json");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--mouse-script needs --device mouse"), std::string::npos) << r.out;
  const fs::path bad = dir / "bad.json";
  std::ofstream(bad) << R"({"palplab_mouse_script": 1, "events": [{"t": 1}, {"t": 0}]})";
  r = palplab::testing::run_command(base + "--device mouse --mouse-script " + bad.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("$.events[1].t"), std::string::npos) << r.out;
  fs::remove_all(dir);
}
