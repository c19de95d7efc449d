// The runner's virtual sessions run on the one lock-step loop (engine::run_lockstep) with the
// participant as the device. Checked here: a session's log is exactly what that loop renders
// for the logged positions (replayed on a fresh scene of the same prototype: every force and
// contact node bit for bit, so the briefing's demonstration on the session's scene left no
// trace either), and an instructed session (exp1) logs one sample per planned step.
#include <gtest/gtest.h>

#include <unistd.h>
#include <cstring>
#include <filesystem>
#include <map>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "protocols/plan.hpp"
#include "protocols/runner.hpp"
#include "protocols/study.hpp"
#include "prototypes/factory.hpp"
#include "results/store.hpp"

using namespace palplab;
using namespace palplab::protocols;

namespace {

Study reference(const std::string& file) {
  return load_study(
      (std::filesystem::path(PALPLAB_SOURCE_DIR) / "protocols" / "studies" / file).string(),
      engine_prototype_inspector());
}

// The first participant of `group` with only its first `sessions` sessions, each `seconds` long.
ParticipantPlan first_of(const Study& study, const std::string& group, int sessions,
                         double seconds) {
  for (ParticipantPlan p : make_plan(study).participants)
    if (p.group == group) {
      p.sessions.resize(sessions);
      for (auto& s : p.sessions) s.duration = seconds;
      return p;
    }
  ADD_FAILURE() << "no participant in group " << group;
  return {};
}

// Plays logged positions back, one per step.
class Replay : public engine::Device {
 public:
  explicit Replay(const results::SampleSeries& s) : s_(s) {}
  engine::DeviceInput read(double) override {
    engine::DeviceInput in;
    in.position = Eigen::Vector3d(s_.x[3 * k_], s_.x[3 * k_ + 1], s_.x[3 * k_ + 2]);
    ++k_;
    return in;
  }
  void write(const engine::Rendered&) override {}
  bool finished() const override { return k_ >= s_.size(); }

 private:
  const results::SampleSeries& s_;
  std::size_t k_ = 0;
};

}  // namespace

TEST(RunnerLoop, VirtualSessionLogIsTheLockstepLoopsOwnRendering) {
  const Study study = reference("exp2_short_term.json");
  // Group B: the briefing demonstrates on B's scene before the first session.
  const ParticipantPlan pp = first_of(study, "B", 2, 15.0);
  const std::vector<results::SessionData> out = simulate_participant(study, pp, true);
  ASSERT_EQ(out.size(), 2u);
  for (std::size_t k = 0; k < out.size(); ++k) {
    const results::SampleSeries& s = out[k].samples;
    engine::Scene scene = prototypes::build_scene(pp.sessions[k].prototype_file);
    ASSERT_EQ(static_cast<long>(s.size()), std::lround(15.0 / scene.dt())) << k;
    EXPECT_EQ(out[k].session.steps, static_cast<long>(s.size()));
    Replay replay(s);
    std::size_t i = 0, contacts = 0, mismatches = 0;
    engine::run_lockstep(scene, replay, {.duration = 15.0, .frame_period = 0.0},
                         [&](const engine::Rendered& r, const engine::Sample&) {
                           mismatches +=
                               std::memcmp(r.force.data(), &s.F[3 * i], 3 * sizeof(double)) != 0 ||
                               r.contact_node != s.node[i];
                           contacts += r.contact;
                           ++i;
                         });
    EXPECT_EQ(i, s.size());
    EXPECT_EQ(mismatches, 0u) << "session " << k;
    EXPECT_GT(contacts, 1000u) << "session " << k << ": the trainee palpated";
  }
}

TEST(RunnerLoop, InstructedSessionLogsEveryPlannedStep) {
  const Study study = reference("exp1_instructor.json");
  const ParticipantPlan pp = first_of(study, "A", 1, 10.0);
  ASSERT_FALSE(pp.sessions[0].instructor.empty());
  const std::vector<results::SessionData> out = simulate_participant(study, pp, true);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].samples.size(), 10000u);  // 10 s at 1 kHz
  EXPECT_EQ(out[0].session.steps, 10000);
  EXPECT_DOUBLE_EQ(out[0].session.duration, 10.0);
  EXPECT_GT(out[0].session.loop_median, 0.0);  // s per step, from the sampled step times
  EXPECT_GE(out[0].session.loop_p99, out[0].session.loop_median);
  EXPECT_LT(out[0].session.loop_median, 0.1);
}

// The run's ETA is the simulated time left per prototype at that prototype's measured cost
// (wall time per simulated second of its stored sessions) over the threads; while a prototype
// has none timed it is unknown and that prototype is named; with --max-sessions it is the time
// to that stop. One A participant (2 sessions of 2 s) then one B participant (4 sessions of
// 2 s), one thread. The first run stops after 3 sessions (A's two, B's first): B is untimed
// until its first session; after it nothing is left before the stop. The resumed run (stopped
// after 2 more) times B from the stored session too: after B's second session, B's cost is both
// sessions' wall time over their 4 simulated s, and one session is left before the stop (two to
// the end). The last resume finishes: nothing is left. A session of this run counts whole
// (Progress::last_session_wall, longer than its stored stepping loop), one stored by an earlier
// run its stepping loop (wall_duration).
TEST(RunnerLoop, ProgressEtaIsEachPrototypesMeasuredCost) {
  const Study study = reference("exp2_short_term.json");
  Plan plan;
  plan.participants = {first_of(study, "A", 2, 2.0), first_of(study, "B", 4, 2.0)};
  ASSERT_EQ(plan.participants[0].sessions[1].prototype, "A");
  ASSERT_EQ(plan.participants[1].sessions[3].prototype, "B");
  const auto dir =
      std::filesystem::temp_directory_path() / ("palplab_test_eta_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  RunOptions opt;
  opt.db = (dir / "eta.db").string();
  opt.samples = false;
  opt.max_sessions = 3;
  std::vector<Progress> seen;
  opt.progress = [&](const Progress& p) { seen.push_back(p); };
  run_study(study, plan, opt);
  opt.max_sessions = 2;
  opt.resume = true;
  run_study(study, plan, opt);
  opt.max_sessions = 0;
  run_study(study, plan, opt);
  ASSERT_EQ(seen.size(), 6u);
  std::map<std::string, double> wall;  // "P.. ordinal" -> the session's wall time
  for (const auto& r : results::Store::open(opt.db).read_sessions())
    wall[r.participant + " " + std::to_string(r.ordinal)] = r.wall_duration;
  const std::string b = plan.participants[1].id;
  EXPECT_EQ(seen[0].eta_untimed, "B");  // A1 and B0 before the stop
  EXPECT_EQ(seen[0].eta, -1.0);
  EXPECT_EQ(seen[1].eta_untimed, "B");  // B0
  EXPECT_EQ(seen[1].eta, -1.0);
  EXPECT_EQ(seen[2].eta_untimed, "");  // the stop
  EXPECT_EQ(seen[2].eta, 0.0);
  // Resumed: B's first session (stored by the first run: its stepping loop) counts, and B's
  // second whole (set-up and database write included).
  EXPECT_EQ(seen[3].eta_untimed, "");
  EXPECT_GT(seen[3].last_session_wall, wall.at(b + " 1"));
  const double b_cost2 = (wall.at(b + " 0") + seen[3].last_session_wall) / 4.0;  // s per sim. s
  EXPECT_NEAR(seen[3].eta, 2.0 * b_cost2, 1e-12 * (1.0 + seen[3].eta));          // B2, not B3 too
  EXPECT_EQ(seen[4].eta, 0.0);
  EXPECT_EQ(seen[5].eta_untimed, "");
  EXPECT_EQ(seen[5].eta, 0.0);
  std::filesystem::remove_all(dir);
}

// A person's device that fails its start-up check before a later session (`run --human`; a UDP
// bridge below the required rate): the command ended with the device error alone, no word of
// the session it had completed and stored (review 2026-12-07). The error now says it.
TEST(RunnerLoop, ADeviceFailingBeforeALaterSessionSaysWhatWasStored) {
  const Study study = reference("exp2_short_term.json");
  Plan plan;
  plan.participants = {first_of(study, "A", 3, 0.2)};
  for (auto& s : plan.participants[0].sessions) s.day = 0;  // all due today
  const auto dir =
      std::filesystem::temp_directory_path() / ("palplab_test_dev2_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  HumanOptions opt;
  opt.db = (dir / "h.db").string();
  opt.participant = plan.participants[0].id;
  opt.device_text = "udp:5000";
  opt.no_wait = true;  // exp2's 10 min breaks
  int made = 0;
  opt.make_device = [&]() -> std::unique_ptr<engine::Device> {
    if (made++ == 1)
      throw InputError(SourceLocation{"--device"}, "udp:5000: 0 Hz, below the required 900 Hz");
    engine::Trace tr;
    for (int k = 0; k < 200; ++k) tr.samples.push_back({k * 0.001, engine::DeviceInput{}});
    return std::make_unique<engine::TraceDevice>(tr);
  };
  try {
    run_human(study, plan, opt);
    FAIL() << "the device error was not raised";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "--device: udp:5000: 0 Hz, below the required 900 Hz; before it this command "
              "completed and stored 1 session(s) of " +
                  opt.participant + ", 2 remain (run the command again when the device works)");
  }
  const auto stored = results::Store::open(opt.db).read_sessions();
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored[0].status, "complete");
  // A device that fails before the first session: the error alone, as before.
  made = 1;
  std::filesystem::remove(opt.db);
  try {
    run_human(study, plan, opt);
    FAIL() << "the device error was not raised";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--device: udp:5000: 0 Hz, below the required 900 Hz");
  }
  std::filesystem::remove_all(dir);
}
