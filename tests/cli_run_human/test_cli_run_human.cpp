// `palplab run --human` end to end (about 6 s of real-time sessions): a scripted hand
// (`device-sim`) over the UDP protocol, the same script replayed step by step as a trace (what
// the lock-step clock would feed the scene: a TraceDevice replays by step index, so its
// measures are those of the lock-step run of the script), the recorded track replayed again,
// the refusal of a session that is not due yet, and a device that goes silent mid-session.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include "tests/cli_human_support.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "engine/haptics/device.hpp"
#include "engine/haptics/devices/trace_device.hpp"

namespace fs = std::filesystem;
namespace e = palplab::engine;
using palplab::testing::db_rows;

namespace {
using Result = palplab::testing::CliResult;
Result run(const std::string& cmdline) {
  return palplab::testing::run_command(cmdline);
}
const std::string kDir = std::string(PALPLAB_SOURCE_DIR) + "/tests/cli_run_human/";

std::map<std::string, double> measures(const fs::path& db, int session) {
  std::map<std::string, double> m;
  for (auto& r :
       db_rows(db, "SELECT name, value FROM measures WHERE session = " + std::to_string(session)))
    m[r["name"]] = r["value"] == "NULL" ? NAN : std::stod(r["value"]);
  return m;
}

struct Tmp {
  fs::path dir = palplab::testing::scratch_dir("human");
  ~Tmp() { fs::remove_all(dir); }
};

std::string human(const fs::path& db, const std::string& device, const std::string& now,
                  const std::string& extra = "") {
  return palplab::testing::human_run(kDir + "human_study.json", db, device, extra, now);
}

// A device held at the origin for `steps` samples of 1 ms, written to `path` (returned).
std::string still_trace(const fs::path& path, int steps) {
  e::Trace tr;
  for (int k = 0; k < steps; ++k) tr.samples.push_back({k * 0.001, e::DeviceInput{}});
  e::write_trace(path.string(), tr);
  return path.string();
}

// One participant on A, two training sessions of 1 s, `gap_s` between them.
fs::path break_study(const fs::path& dir, int gap_s) {
  const fs::path study = dir / "breaks.json";
  std::ofstream(study) << R"({"palplab_study": 1, "id": "breaks", "title": "breaks", "seed": 7,
  "task": {"feature": "ovary_left", "thresholds": {"*": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}}},
  "groups": [{"id": "A", "prototype": "A", "size": 1}],
  "phases": [{"id": "training", "kind": "training", "sessions": 2, "session_duration": 1,
              "gap": {"seconds": )"
                       << gap_s << "}}]}";
  return study;
}

}  // namespace

TEST(CliRunHuman, UdpSessionMatchesScriptAndTraceReplayIsExact) {
  Tmp tmp;
  // The script sampled at the haptic steps t = 0.001 k: the lock-step clock's device track.
  std::vector<std::pair<double, Eigen::Vector3d>> w;
  {
    std::ifstream in(kDir + "press_script.json");
    const auto j = nlohmann::json::parse(in);
    for (const auto& p : j["waypoints"])
      w.emplace_back(p[0].get<double>(),
                     Eigen::Vector3d(p[1].get<double>(), p[2].get<double>(), p[3].get<double>()));
  }
  e::ScriptedDevice script(w);
  e::Trace tr;
  for (int k = 0; k < 2000; ++k) {
    e::TraceSample s;
    s.t = k * 0.001;
    s.in = script.read(s.t);
    tr.samples.push_back(s);
  }
  e::write_trace((tmp.dir / "script.trace").string(), tr);
  const fs::path ref = tmp.dir / "ref.db";
  auto r0 = run(human(ref, "trace:" + (tmp.dir / "script.trace").string(), "2026-11-24T10:00:00Z"));
  ASSERT_EQ(r0.code, 0) << r0.out;
  const auto m_script = measures(ref, 1);
  ASSERT_EQ(m_script.at("feature_identified"), 1.0) << "the script must find the feature";

  // The same script from device-sim over UDP, real time; the track is recorded. device-sim
  // plays 2.3 s of script for the 2 s session: 0.3 s of slack for the real-time clock's drift
  // (below). A session whose clock drifted more has run past the end of the script: the machine
  // starved the haptic loop (at load 18-22 on 2 cores we saw 1.3-2.3 s, and then the feature
  // unidentified), and the comparison says nothing about palplab. Such a session is repeated
  // (a fresh database), up to 3 times; the loop's MEDIAN period, which is palplab's own speed
  // and not the machine's load, must be on time in every one.
  const double dt = 0.001;  // the prototype's haptic step
  const double kScriptSlack = 0.3;
  fs::path db;
  std::string trace_dir, drifts;
  int port = 0;
  Result s1;
  for (int attempt = 1;; ++attempt) {
    port = palplab::testing::free_udp_port();
    db = tmp.dir / ("h" + std::to_string(attempt) + ".db");
    trace_dir = (tmp.dir / ("tr" + std::to_string(attempt))).string();
    auto sim = std::async(std::launch::async, [&] {
      return run(std::string(PALPLAB_BINARY) + " device-sim --port " + std::to_string(port) +
                 " --script " + kDir +
                 "press_script.json --start-on-force --duration 2.3 --wait 60 --json");
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    // --min-device-rate 0: the device self-test (900 Hz over 0.25 s by default) is tested by
    // DeviceSelfTest and CliView; here a 25 ms stall of either process on a loaded machine
    // would turn it into an exit 2 that says nothing about the session.
    auto r1 = run(human(db, "udp:" + std::to_string(port), "2026-11-24T10:00:00Z",
                        "--record-trace " + trace_dir + " --min-device-rate 0"));
    s1 = sim.get();
    // 0, or 3 for a session aborted because the stream ended (a starved loop); never a crash.
    ASSERT_TRUE(r1.code == 0 || r1.code == 1) << r1.code << "\n" << r1.out << s1.out;
    auto row = db_rows(db, "SELECT wall_duration, steps, loop_median FROM sessions");
    ASSERT_EQ(row.size(), 1u) << r1.out;
    EXPECT_NEAR(std::stod(row[0].at("loop_median")), dt, 0.05 * dt) << r1.out;
    const double drift = std::stod(row[0].at("wall_duration")) - 2000 * dt;
    if (r1.code == 0 && drift <= kScriptSlack) break;
    drifts += (drifts.empty() ? "" : ", ") + std::to_string(drift) + " s";
    if (attempt == 3)
      GTEST_SKIP() << "the machine starved the real-time loop in 3 sessions (drift bounds "
                   << drifts << " > " << kScriptSlack
                   << " s of script slack): no comparison possible here";
  }
  auto rows = db_rows(db, "SELECT * FROM sessions");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0]["status"], "complete");
  EXPECT_EQ(rows[0]["trainee"], "human");
  EXPECT_EQ(rows[0]["device"], "udp:" + std::to_string(port));
  EXPECT_EQ(rows[0]["steps"], "2000");
  EXPECT_GT(std::stoi(db_rows(db, "SELECT COUNT(*) AS n FROM samples")[0]["n"]), 1);
  const auto m_udp = measures(db, 1);
  // What the real-time clock allows, from this session's own loop timing (sessions row). The
  // lock-step reference sees the script at simulated time t exactly; the UDP session differs by
  //  - drift: a step that starts more than a period late re-anchors the clock instead of
  //    bursting through the missed ticks (engine/haptics/clock.cpp), so simulated time falls
  //    behind wall time, on which device-sim plays the script: script events show up EARLIER in
  //    simulated time by the lag accumulated so far. The lag only grows, and at the end it is
  //    at most the session's wall time minus its simulated time (wall_duration also counts the
  //    last store write, so this bounds it from above). On an idle machine it is a few ms; at
  //    load 16 on 2 cores we measured 0.07-0.11 s of lag within 0.16-0.31 s of this bound.
  //  - delay: the script starts when device-sim sees the first force datagram (after step 1),
  //    and a position is read at the first step after it arrives: script events show up LATER
  //    by the start delay plus the position's age, each about one loop period and a wake-up of
  //    device-sim's 1 kHz loop. Bounded by J = 3 periods at the loop's p99 + device-sim's own
  //    p99 send interval (its summary; 1 ms on an idle machine, more when the machine delays
  //    its ticks) + 1 ms of delivery; ~5 ms on an idle machine.
  // A fixed window cannot be right for both an idle and a loaded machine; this one is as tight
  // as the run's own timing permits and still fails for any error that is not timing (a wrong
  // identification, a force computed from another track, time measured on the wall clock).
  const auto row = db_rows(db, "SELECT steps, wall_duration, loop_p99 FROM sessions")[0];
  const double drift = std::max(0.0, std::stod(row.at("wall_duration")) - 2000 * dt);
  const double p99 = std::stod(row.at("loop_p99"));
  const auto sim_summary = nlohmann::json::parse(s1.out);
  const double dev_p99 = std::max(dt, sim_summary.at("send_interval_p99_ms").get<double>() / 1e3);
  const double J = 3.0 * std::max(dt, p99) + dev_p99 + 0.001;
  EXPECT_EQ(m_udp.at("feature_identified"), m_script.at("feature_identified"));
  const double d_explore = m_udp.at("exploration_time") - m_script.at("exploration_time");
  EXPECT_GE(d_explore, -(drift + J)) << "drift bound " << drift << " s, J " << J << " s";
  EXPECT_LE(d_explore, J) << "J " << J << " s";
  // The peak force is taken at the turning point of the press. A constant delay only moves the
  // peak in time; what lowers it is the gap g between the two script times the loop samples on
  // either side of the turn (one loop period, plus device-sim's own tick): the nearer sample is
  // then short of the turn by at most min(v_in a, v_out b) with a + b = g, i.e. at most
  // g v_in v_out / (v_in + v_out) in depth (11.7 mm/s in, 35 mm/s out: 8.8 mm/s x g), and the
  // force (prototype A: Hooke's law on the penetration, 500 N/m) by that times the stiffness.
  // g is taken as 2 loop periods at the run's p99 + device-sim's p99 send interval (a longer
  // stall exactly at the turn is rarer than 1 %), plus one step's travel of the reference: 0.01 N.
  // Idle machine: 0.024 N; at load 16 (p99 ~5 ms): ~0.06 N; observed differences there were below
  // 0.02 N.
  double stiffness = 0.0;
  {
    std::ifstream in(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/A.json");
    stiffness = nlohmann::json::parse(in)["contact"]["stiffness"].get<double>();
  }
  const double v_in = (w[2].second - w[1].second).norm() / (w[2].first - w[1].first);
  const double v_out = (w[3].second - w[2].second).norm() / (w[3].first - w[2].first);
  const double gap = 2.0 * std::max(dt, p99) + dev_p99;
  const double force_tol = 0.01 + stiffness * gap * v_in * v_out / (v_in + v_out);
  EXPECT_NEAR(m_udp.at("palpation_force"), m_script.at("palpation_force"), force_tol)
      << "p99 " << p99 << " s";
  EXPECT_EQ(m_udp.at("palpations"), m_script.at("palpations"));
  std::cout << "real time vs lock-step: exploration_time " << d_explore << " s in [" << -(drift + J)
            << ", " << J << "], palpation_force "
            << m_udp.at("palpation_force") - m_script.at("palpation_force") << " N within "
            << force_tol << " (loop p99 " << p99 << " s, device-sim p99 " << dev_p99 << " s)\n";

  // The recorded track replayed: identical measures (replay by step index, deterministic scene).
  const fs::path rep = tmp.dir / "rep.db";
  auto r2 = run(human(rep, "trace:" + (fs::path(trace_dir) / "P01_0_0.trace").string(),
                      "2026-11-24T10:00:00Z"));
  ASSERT_EQ(r2.code, 0) << r2.out;
  const auto m_rep = measures(rep, 1);
  for (const auto& [k, v] : m_udp) {
    if (std::isnan(v))
      EXPECT_TRUE(std::isnan(m_rep.at(k))) << k;
    else
      EXPECT_EQ(m_rep.at(k), v) << k;
  }

  // The next session is on day 2: refused on day 1 with its date, run on day 2.
  auto r3 = run(human(db, "trace:" + (tmp.dir / "script.trace").string(), "2026-11-25T09:00:00Z"));
  EXPECT_EQ(r3.code, 2) << r3.out;
  EXPECT_NE(r3.out.find("due on 2026-11-26"), std::string::npos) << r3.out;
}

TEST(CliRunHuman, SilentDeviceAbortsSessionKeptAndRepeated) {
  Tmp tmp;
  const fs::path db = tmp.dir / "h.db";
  const int port = palplab::testing::free_udp_port();
  auto sim = std::async(std::launch::async, [&] {
    return run(std::string(PALPLAB_BINARY) + " device-sim --port " + std::to_string(port) +
               " --script " + kDir +
               "press_script.json --start-on-force --stop-after 0.5 --wait 60");
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  auto r = run(human(db, "udp:" + std::to_string(port), "2026-11-24T10:00:00Z",
                     "--device-lost 0.3 --min-device-rate 0"));  // (as above)
  sim.get();
  EXPECT_EQ(r.code, 1) << r.out;  // a session aborted: kept, said on stderr
  EXPECT_NE(r.out.find("1 session(s) of participant"), std::string::npos) << r.out;  // 2>&1
  // with its reason (it was in the database only: 2026-12-06, noticed)
  EXPECT_NE(r.out.find("aborted: device udp:" + std::to_string(port) + " lost: no position for"),
            std::string::npos)
      << r.out;
  auto rows = db_rows(db, "SELECT * FROM sessions");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0]["status"], "aborted");
  EXPECT_NE(rows[0]["abort_reason"].find("lost"), std::string::npos) << rows[0]["abort_reason"];
  EXPECT_LT(std::stoi(rows[0]["steps"]), 2000);
  // The data up to the loss is kept: samples and the device_timeout event.
  EXPECT_GE(std::stoi(db_rows(db, "SELECT COUNT(*) AS n FROM samples")[0]["n"]), 1);
  EXPECT_GE(std::stoi(db_rows(db,
                              "SELECT COUNT(*) AS n FROM events WHERE kind = "
                              "'device_timeout'")[0]["n"]),
            1);
  // Not complete: the analysis tables do not see it; the next run repeats it as attempt 1.
  const std::string trace = still_trace(tmp.dir / "t.trace", 2000);
  auto r2 = run(human(db, "trace:" + trace, "2026-11-24T11:00:00Z"));
  EXPECT_EQ(r2.code, 0) << r2.out;
  rows = db_rows(db, "SELECT attempt, status FROM sessions ORDER BY session");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1]["attempt"], "1");
  EXPECT_EQ(rows[1]["status"], "complete");
}

// Sessions planned on one day with a break between them (exp2: 10 min between training
// sessions) ran back to back with a person, and stored the plan's study_offset (review
// 2026-12-07). The command now waits out the break after the previous session's end, saying
// until when, and stores when each session started; --no-wait starts at once and says so.
TEST(CliRunHuman, SessionsOfOneDayKeepTheStudysBreakBetweenThem) {
  Tmp tmp;
  const fs::path study = break_study(tmp.dir, 3);
  const std::string trace = still_trace(tmp.dir / "t.trace", 1000);
  for (const bool wait : {true, false}) {
    SCOPED_TRACE(wait ? "waiting" : "--no-wait");
    const fs::path db = tmp.dir / (wait ? "w.db" : "n.db");
    const auto t0 = std::chrono::steady_clock::now();
    auto r = run(palplab::testing::human_run(study.string(), db, "trace:" + trace,
                                             wait ? "" : "--no-wait", "2026-11-24T10:00:00Z"));
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ(r.code, 0) << r.out;
    const auto rows = db_rows(db,
                              "SELECT started_at, completed_at, study_offset FROM sessions "
                              "ORDER BY ordinal");
    ASSERT_EQ(rows.size(), 2u);
    EXPECT_EQ(std::stod(rows[0].at("study_offset")), 0.0);
    const auto secs = [](const std::string& iso) {  // "2026-11-24T10:00:SSZ"
      return std::stoi(iso.substr(14, 2)) * 60 + std::stoi(iso.substr(17, 2));
    };
    const int second_start = secs(rows[1].at("started_at"));
    EXPECT_EQ(std::stod(rows[1].at("study_offset")), second_start - secs(rows[0].at("started_at")));
    if (wait) {
      EXPECT_NE(r.out.find("break: training #2 is planned 3 s after the previous session ended; "
                           "it starts at 2026-11-24T10:00:"),
                std::string::npos)
          << r.out;
      EXPECT_GE(second_start - secs(rows[0].at("completed_at")), 3);
      EXPECT_GE(wall, 5.0);  // two sessions of 1 s and the break
    } else {
      EXPECT_EQ(r.out.find("break:"), std::string::npos) << r.out;
      EXPECT_NE(r.out.find("training #2 starts without the study's break of 3 s after the "
                           "previous session (--no-wait)"),
                std::string::npos)
          << r.out;
      EXPECT_LT(second_start - secs(rows[0].at("completed_at")), 3);
    }
  }
}

// A signal during the break exited 0 in silence, and every signal was stored as "interrupted
// (Ctrl-C)" (review 2026-12-07): the command now exits 128 + the signal, says what is stored,
// and an aborted session keeps the signal that stopped it.
TEST(CliRunHuman, ASignalDuringTheBreakOrASessionIsSaidAndStored) {
  Tmp tmp;
  const fs::path study = break_study(tmp.dir, 30);
  const std::string trace = still_trace(tmp.dir / "t.trace", 1000);
  const std::string slow =
      still_trace(tmp.dir / "slow.trace", 20000);  // 20 s: the signal comes within
  // Runs the command in the background, sends `sig` once `wait_for` is in its output.
  auto signalled = [&](const fs::path& db, const std::string& device, const char* sig,
                       const std::string& wait_for) {
    const fs::path out = tmp.dir / "out.txt", rc = tmp.dir / "rc.txt";
    const std::string cmd =
        palplab::testing::human_run(study.string(), db, device, "", "2026-11-24T10:00:00Z");
    const std::string script = "(" + cmd + " >" + out.string() + " 2>&1) & pid=$!; i=0; " +
                               "while ! grep -q \"" + wait_for + "\" " + out.string() +
                               " 2>/dev/null && [ $i -lt 6000 ]; do sleep 0.01; i=$((i+1)); " +
                               "done; kill -" + sig + " $pid; wait $pid; echo $? > " + rc.string();
    EXPECT_EQ(std::system(("bash -c '" + script + "'").c_str()), 0);
    return std::pair{palplab::testing::slurp(rc), palplab::testing::slurp(out)};
  };
  const fs::path db = tmp.dir / "h.db";
  const auto [code, out] = signalled(db, "trace:" + trace, "TERM", "break: training #2");
  EXPECT_EQ(code, "143\n") << out;
  EXPECT_NE(out.find("palplab run: stopped by SIGTERM before the next session (nothing of it is "
                     "stored): the completed sessions are stored in " +
                     db.string() + ", 1 remaining; the same command continues"),
            std::string::npos)
      << out;
  auto rows = db_rows(db, "SELECT status FROM sessions");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].at("status"), "complete");
  // Within a session: aborted, with the signal as its reason.
  const fs::path db2 = tmp.dir / "h2.db";
  const auto [code2, out2] = signalled(db2, "trace:" + slow, "HUP", "started");
  EXPECT_EQ(code2, "129\n") << out2;
  rows = db_rows(db2, "SELECT status, abort_reason FROM sessions");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].at("status"), "aborted");
  EXPECT_EQ(rows[0].at("abort_reason"), "stopped by SIGHUP (the terminal closed)");
  EXPECT_NE(out2.find("palplab run: stopped by SIGHUP (the terminal closed): the completed "
                      "sessions are stored in"),
            std::string::npos)
      << out2;
}

// A missed day's session ran first without a word (review 2026-12-07): it is said, with the
// day it was planned on and the day it runs on, and stored with its planned day.
TEST(CliRunHuman, AMissedDaysSessionIsSaid) {
  Tmp tmp;
  const fs::path db = tmp.dir / "h.db";
  const std::string trace = still_trace(tmp.dir / "t.trace", 2000);
  ASSERT_EQ(run(human(db, "trace:" + trace, "2026-11-24T10:00:00Z")).code, 0);
  const Result r = run(human(db, "trace:" + trace, "2026-11-27T10:00:00Z"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("note: test #1 was planned on day 2 of the study (2026-11-26); it was "
                       "missed and runs now, on day 3"),
            std::string::npos)
      << r.out;
  const auto rows = db_rows(db, "SELECT day FROM sessions ORDER BY ordinal");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].at("day"), "2");
}

// A human session ended by kill -9 kept its samples, but its row said 0 steps and 0 s (set only
// at the session's end: review 2026-12-07). The row follows the data written each second.
TEST(CliRunHuman, ASessionKilledMidwayKeepsStepsThatMatchItsSamples) {
  Tmp tmp;
  const fs::path db = tmp.dir / "h.db";
  const std::string trace = still_trace(tmp.dir / "t.trace", 2000);
  auto r = run(palplab::testing::human_run(kDir + "human_study.json", db, "trace:" + trace, "",
                                           "2026-11-24T10:00:00Z", "timeout -s KILL 1.7 "));
  if (r.code == 0) GTEST_SKIP() << "the 2 s session ended before the kill";
  if (!fs::exists(db)) GTEST_SKIP() << "killed before the database was made";
  const auto rows =
      db_rows(db,
              "SELECT s.status, s.steps, s.duration, (SELECT COALESCE(SUM(n), 0) FROM "
              "samples WHERE session = s.session) AS logged FROM sessions s");
  if (rows.empty() || rows[0].at("logged") == "0") GTEST_SKIP() << "killed before a second";
  EXPECT_EQ(rows[0].at("status"), "running");
  EXPECT_EQ(rows[0].at("steps"), rows[0].at("logged"));
  EXPECT_DOUBLE_EQ(std::stod(rows[0].at("duration")), std::stod(rows[0].at("logged")) * 0.001);
  // The next run marks it aborted and keeps the counts.
  auto r2 = run(human(db, "trace:" + trace, "2026-11-24T11:00:00Z"));
  EXPECT_EQ(r2.code, 0) << r2.out;
  const auto after = db_rows(db, "SELECT status, steps FROM sessions ORDER BY session");
  ASSERT_EQ(after.size(), 2u);
  EXPECT_EQ(after[0].at("status"), "aborted");
  EXPECT_EQ(after[0].at("steps"), rows[0].at("logged"));
  EXPECT_EQ(after[1].at("steps"), "2000");
}

// `run --human` created (or opened) the results database before it read the trace of
// `--device trace:FILE` (and before it bound a UDP device or checked --record-trace), so a bad
// device left a fresh database behind its exit 2. Every argument is checked first now: no
// database file (nor its -wal/-shm) after any of these.
TEST(CliRunHuman, BadDeviceOrArgumentsExit2BeforeTheDatabaseExists) {
  namespace t = palplab::testing;
  Tmp tmp;
  const fs::path db = tmp.dir / "h.db";
  const std::string good = still_trace(tmp.dir / "good.trace", 2000);
  // At 2 kHz: played at half speed before (review 2026-12-06, fourth).
  const std::string half = (tmp.dir / "half.trace").string();
  {
    e::Trace tr;
    for (int k = 0; k < 4000; ++k) tr.samples.push_back({k * 0.0005, e::DeviceInput{}});
    e::write_trace(half, tr);
  }
  const std::string no_samples = (tmp.dir / "empty.trace").string();
  e::write_trace(no_samples, e::Trace{});
  const std::string a_file = (tmp.dir / "file").string();
  std::ofstream(a_file) << "x";
  const int silent_port = t::free_udp_port();  // nobody sends there
  struct Case {
    std::string device, extra, flag, shown;
  };
  const std::vector<Case> cases = {
      {"BAD", "", "--device", "\"BAD\""},
      {"udp:0", "", "--device", "udp:PORT (1..65535)"},
      {"trace:" + (tmp.dir / "missing.trace").string(), "", "missing.trace",
       "cannot open the trace"},
      {"trace:" + kDir + "human_study.json", "", "human_study.json", "not a palplab trace"},
      {"trace:" + no_samples, "", "--device", "the trace has no samples"},
      {"trace:" + half, "", "--device", "the trace has a sample every 0.5 ms, prototype"},
      {"udp:" + std::to_string(silent_port), "", "udp:" + std::to_string(silent_port),
       "below the required 900 Hz"},
      {"trace:" + good, "--record-trace " + a_file + "/sub", "--record-trace", "/sub"},
      // An empty directory (an unset shell variable) wrote no trace, exit 0.
      {"trace:" + good, "--record-trace ''", "--record-trace", "no directory given"},
      {"trace:" + good, "--min-device-rate nan", "--min-device-rate", "'nan'"},
      {"trace:" + good, "--device-lost nan", "--device-lost", "'nan'"},
      {"trace:" + good, "--device-lost 0", "--device-lost", "(0, 3600]"},
      // Options of virtual runs were silently ignored with --human.
      {"trace:" + good, "--jobs 2", "--jobs", "without --human"},
      {"trace:" + good, "--max-sessions 1", "--max-sessions", "without --human"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.device + " " + c.extra);
    const t::CliResult r = t::run_shell(human(db, c.device, t::kHumanNow, c.extra), tmp.dir);
    t::expect_exit2(r, {c.flag, c.shown});
    for (const char* suffix : {"", "-wal", "-shm", "-journal"})
      EXPECT_FALSE(fs::exists(db.string() + suffix)) << db.string() + suffix;
  }
  // An unknown participant with a silent bridge: the id is the error (it was reported only
  // after the device's rate was measured, and failed as "below 900 Hz": review 2026-12-07).
  {
    const std::string cmd =
        "PALPLAB_NOW=" + std::string(t::kHumanNow) + " " + PALPLAB_BINARY + " run " + kDir +
        "human_study.json --db " + db.string() +
        " --human --participant NOPE --device udp:" + std::to_string(silent_port);
    const t::CliResult r = t::run_shell(cmd, tmp.dir);
    t::expect_exit2(r, {"--participant", "no participant \"NOPE\"", "P01"});
    EXPECT_EQ(r.err.find("900 Hz"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(db));
  }
  // The same good trace and arguments without the bad one: the session runs and is stored (the
  // trace read once before the database replays in the session).
  const t::CliResult ok = t::run_shell(
      human(db, "trace:" + good, t::kHumanNow, "--record-trace " + (tmp.dir / "tr").string()),
      tmp.dir);
  ASSERT_EQ(ok.code, 0) << ok.out << ok.err;
  const auto rows = db_rows(db, "SELECT status, steps FROM sessions");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].at("status"), "complete");
  EXPECT_EQ(fs::exists(tmp.dir / "tr" / "P01_0_0.trace"), true);
}

// `trace-export --session N`: a session id not in the database is exit 2 naming the ids it holds,
// and one beyond the 64-bit range (clamped by the integer parse to 9223372036854775807, so the
// message named another number than the one given) or below 1 is exit 2 naming the valid range.
// Nothing is written then.
TEST(CliTraceExport, SessionOutOfRangeIsExit2NamingTheRange) {
  namespace t = palplab::testing;
  Tmp tmp;
  const std::string study = (tmp.dir / "tiny.json").string();
  std::ofstream(study) << t::tiny_study_json("tiny", 3);
  const fs::path db = tmp.dir / "t.db";
  const t::CliResult made =
      t::run_palplab("run " + study + " --db " + db.string() + " --quiet", tmp.dir);
  ASSERT_EQ(made.code, 0) << made.err;
  const fs::path out = tmp.dir / "o.trace";
  auto export_session = [&](const std::string& session) {
    return t::run_palplab(
        "trace-export " + db.string() + " --session " + session + " --out " + out.string(),
        tmp.dir);
  };
  t::expect_exit2(export_session("5"), {"--session", "no session 5", "its sessions are 1..4"});
  for (const std::string bad : {"0", "-1", "99999999999999999999", "-99999999999999999999"})
    t::expect_exit2(export_session(bad),
                    {"--session:", "[1, 9223372036854775807]", "'" + bad + "'"});
  EXPECT_FALSE(fs::exists(out));
  const t::CliResult ok = export_session("4");
  ASSERT_EQ(ok.code, 0) << ok.err;
  EXPECT_TRUE(t::has(ok.out, "2000 samples of session 4")) << ok.out;
  EXPECT_EQ(e::read_trace(out.string()).samples.size(), 2000u);
  // Review finding: --out naming the database replaced it with the trace text.
  const auto db_bytes = fs::file_size(db);
  t::expect_exit2(t::run_palplab("trace-export " + db.string() + " --session 4 --out " +
                                     db.string() + " --overwrite",
                                 tmp.dir),
                  {"--out", "is the results database this command reads"});
  EXPECT_EQ(fs::file_size(db), db_bytes);
  // Another kind of file is replaced only with --overwrite; a trace file is replaced.
  const fs::path other = tmp.dir / "notes.txt";
  std::ofstream(other) << "my notes\n";
  const std::string to_other =
      "trace-export " + db.string() + " --session 4 --out " + other.string();
  t::expect_exit2(t::run_palplab(to_other, tmp.dir),
                  {"--out", "exists and is a file, not a palplab trace file", "--overwrite"});
  EXPECT_EQ(fs::file_size(other), 9u);
  EXPECT_EQ(t::run_palplab(to_other + " --overwrite", tmp.dir).code, 0);
  EXPECT_EQ(export_session("4").code, 0);  // its own earlier output
  // Review finding (2026-12-06): a write that failed half-way (a full disk) left a truncated
  // trace in place of the earlier one. A file-size limit of 64 KiB (`ulimit -f 128`: 512-byte
  // blocks in POSIX sh; above the database's 32 KiB -shm) makes the write fail (EFBIG, SIGXFSZ
  // ignored): exit 2, and the earlier trace is unchanged, with no .partial left.
  const std::string before = t::slurp(out);
  ASSERT_GT(before.size(), 65536u);
  t::expect_exit2(
      t::run_shell("trap '' XFSZ; ulimit -f 128; " + std::string(PALPLAB_BINARY) +
                       " trace-export " + db.string() + " --session 4 --out " + out.string(),
                   tmp.dir),
      {out.string() + ": cannot write the trace (File too large)"});
  EXPECT_EQ(t::slurp(out), before);
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
}

// `run --human` ignored the run's --samples setting (P01's sessions without samples, the next
// ones with them) and could not continue an empty leftover (a start interrupted while the
// database was created): it is started in, and the setting is kept or an explicit other one
// refused, as `run --resume` does.
TEST(CliRunHuman, HumanSessionsKeepTheRunsSamplesSettingAndStartInALeftover) {
  Tmp tmp;
  e::Trace tr;
  for (int k = 0; k < 2500; ++k) {  // held 5 mm above the model
    e::TraceSample s;
    s.t = k * 0.001;
    s.in.position = Eigen::Vector3d(0.0, 0.0, 0.5);
    tr.samples.push_back(s);
  }
  const std::string device = "trace:" + (tmp.dir / "hold.trace").string();
  e::write_trace((tmp.dir / "hold.trace").string(), tr);
  const fs::path db = tmp.dir / "h.db";
  std::ofstream(db).close();  // 0 bytes
  Result r = run(human(db, device, "2026-11-24T10:00:00Z", "--samples none"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("holds no run yet (its start was interrupted)"), std::string::npos) << r.out;
  auto one = [&](const std::string& sql) { return db_rows(db, sql).at(0).at("v"); };
  EXPECT_EQ(one("SELECT value AS v FROM meta WHERE key = 'samples'"), "none");
  EXPECT_EQ(one("SELECT COUNT(*) AS v FROM sessions WHERE status = 'complete'"), "1");
  // The test session (day 2) with another explicit setting: refused, nothing run.
  r = run(human(db, device, "2026-11-26T10:00:00Z", "--samples full"));
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.out.find("the run started with --samples none, this one asks for --samples full"),
            std::string::npos)
      << r.out;  // (run_command: stderr into out)
  // Without --samples: the run's setting.
  r = run(human(db, device, "2026-11-26T10:00:00Z"));
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_EQ(one("SELECT COUNT(*) AS v FROM sessions WHERE status = 'complete'"), "2");
  EXPECT_EQ(one("SELECT COUNT(*) AS v FROM samples"), "0");
  // On its planned day (2) the test is no missed day's session.
  EXPECT_EQ(r.out.find("was missed"), std::string::npos) << r.out;
  // Every time stored follows PALPLAB_NOW's clock: the study's start and each session's start
  // and end (completed_at was the system clock's: review 2026-12-07). Sessions of 2.5 s.
  EXPECT_EQ(one("SELECT started_at AS v FROM study").substr(0, 16), "2026-11-24T10:00");
  const auto rows = db_rows(db, "SELECT started_at, completed_at FROM sessions ORDER BY ordinal");
  ASSERT_EQ(rows.size(), 2u);
  for (const auto& [row, day] :
       {std::pair{rows[0], "2026-11-24T10:0"}, {rows[1], "2026-11-26T10:0"}}) {
    EXPECT_EQ(row.at("started_at").substr(0, 15), day);
    EXPECT_EQ(row.at("completed_at").substr(0, 15), day);
    EXPECT_LE(row.at("started_at"), row.at("completed_at"));
  }
}

// A study whose every participant is run by a person was never marked finished (finished_at
// stayed NULL when the last session was done: its report "provisional" for ever, and the advice
// "continue with --resume" looped), nor one whose people and virtual participants (--resume) had
// all finished (review 2026-12-06, eighth). The study is finished when every planned session is
// complete, whoever ran it; until then a virtual run whose part is done names the people left.
TEST(CliRunHuman, AStudyIsFinishedWhenItsLastSessionIsAPersons) {
  Tmp tmp;
  e::Trace tr;  // 2 s at rest above the organ: a session that touches nothing
  for (int k = 0; k < 2000; ++k) {
    e::TraceSample s;
    s.t = k * 0.001;
    s.in.position = Eigen::Vector3d(0, 0, 0.2);
    tr.samples.push_back(s);
  }
  const std::string trace = (tmp.dir / "rest.trace").string();
  e::write_trace(trace, tr);
  const auto person = [&](const fs::path& db, const std::string& who, const std::string& now) {
    return run("PALPLAB_NOW=" + now + " " + std::string(PALPLAB_BINARY) + " run " + kDir +
               "human_study.json --db " + db.string() + " --human --participant " + who +
               " --device trace:" + trace);
  };
  const auto finished = [](const fs::path& db) {
    return db_rows(db, "SELECT finished_at FROM study").at(0).at("finished_at");
  };
  // Everyone a person: P01 and P02, day 0 and day 2.
  const fs::path db = tmp.dir / "people.db";
  for (const char* who : {"P01", "P02"})
    for (const char* now : {"2026-11-24T10:00:00Z", "2026-11-26T10:00:00Z"}) {
      const Result r = person(db, who, now);
      ASSERT_EQ(r.code, 0) << r.out;
      if (std::string(who) == "P01") {
        EXPECT_EQ(finished(db), "NULL");
      }
    }
  EXPECT_NE(finished(db), "NULL");
  Result r = run(std::string(PALPLAB_BINARY) + " report " + db.string() + " --out " +
                 (tmp.dir / "rep").string() + " --no-stills");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(palplab::testing::has(r.out, "INCOMPLETE")) << r.out;
  // P01 a person, P02 virtual (--resume): finished by the virtual run.
  const fs::path mixed = tmp.dir / "mixed.db";
  for (const char* now : {"2026-11-24T10:00:00Z", "2026-11-26T10:00:00Z"})
    ASSERT_EQ(person(mixed, "P01", now).code, 0);
  r = run(std::string(PALPLAB_BINARY) + " run " + kDir + "human_study.json --db " + mixed.string() +
          " --resume");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(palplab::testing::has(r.out, ", complete")) << r.out;
  EXPECT_NE(finished(mixed), "NULL");
  // The virtual part done, a person's sessions left: said, with the command that runs them.
  const fs::path waiting = tmp.dir / "waiting.db";
  ASSERT_EQ(person(waiting, "P02", "2026-11-24T10:00:00Z").code, 0);
  r = run(std::string(PALPLAB_BINARY) + " run " + kDir + "human_study.json --db " +
          waiting.string() + " --resume");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(palplab::testing::has(
      r.out,
      "INCOMPLETE (the virtual participants are done; people's sessions remain (P02): "
      "`palplab run STUDY --db " +
          waiting.string() + " --human --participant ID`)"))
      << r.out;
  EXPECT_EQ(finished(waiting), "NULL");
}
