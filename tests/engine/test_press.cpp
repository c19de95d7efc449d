// The one press script (engine/haptics/press.hpp) against an analytic tissue: a half-space
// spring F = k max(depth, 0) along the normal, stepped at 1 kHz. Every variant the runner, the
// benchmarks and the tests use: force control, a judged force (Weber error), stop at the target
// (the demonstration), position control and a sliding hold.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "engine/haptics/press.hpp"

using namespace palplab::engine;

namespace {

constexpr double kDt = 1e-3;  // s
constexpr double kK = 500.0;  // N/m

struct Step {
  double t;
  Eigen::Vector3d x;
  double f;
  PressPhase phase;  // after the step
};

// One step k of the press against the half-space below spec.point (normal spec.normal), the
// way run_lockstep calls a device (read at the step's start time, write with the end time);
// t kept as step_index * dt, as Scene does.
Step drive_from(PressDevice& d, int k) {
  const PressSpec& s = d.spec();
  const Eigen::Vector3d x = d.read(k * kDt).position;
  const double depth = s.normal.dot(s.point - x);
  Rendered r;
  r.t = (k + 1) * kDt;
  r.force = kK * std::max(depth, 0.0) * s.normal;
  r.contact = depth > 0.0;
  d.write(r);
  return {r.t, x, r.force.norm(), d.phase()};
}

// The press for at most `steps` steps (until it is finished).
std::vector<Step> drive(PressDevice& d, int steps) {
  std::vector<Step> out;
  for (int k = 0; k < steps && !d.finished(); ++k) out.push_back(drive_from(d, k));
  return out;
}

PressSpec base() {
  PressSpec p;
  p.point = Eigen::Vector3d(0.01, -0.02, 0.03);
  p.normal = Eigen::Vector3d(1, 2, 2).normalized();
  p.force = 2.5;
  p.hold = 0.5;
  p.release = 0.2;
  return p;
}

}  // namespace

TEST(Press, ForceControlReachesHoldsAndReleases) {
  PressDevice d(base());
  const auto s = drive(d, 5000);
  ASSERT_TRUE(d.finished());
  // 2 mm outside to 5 mm deep (2.5 N at 500 N/m) at 2 cm/s: 0.35 s, to one step.
  EXPECT_NEAR(d.time_to_force(), 0.35, 1.5 * kDt);
  // The hold keeps the force within 1 % of the target after 0.1 s of settling.
  for (const auto& x : s)
    if (x.phase == PressPhase::hold && x.t > d.time_to_force() + 0.1) {
      EXPECT_NEAR(x.f, 2.5, 0.025);
    }
  // Withdrawn to the start point and released: the last force is 0 at the start position.
  EXPECT_EQ(s.back().f, 0.0);
  EXPECT_NEAR((s.back().x - (base().point + 0.002 * base().normal)).norm(), 0.0, 1e-12);
}

TEST(Press, JudgedForceStopsWhereTheJudgementSaysSo) {
  PressSpec p = base();
  p.force_error = 0.25;  // judges 2 N as 2.5 N
  p.stop_at_target = true;
  PressDevice d(p);
  const auto s = drive(d, 5000);
  ASSERT_TRUE(d.finished());
  ASSERT_TRUE(d.force_reached());
  // Ends on the first step whose judged force reaches the target, and not one step later.
  EXPECT_GE(s.back().f * 1.25, 2.5);
  EXPECT_LT(s[s.size() - 2].f * 1.25, 2.5);
  EXPECT_NEAR(s.back().f, 2.0, kK * 0.02 * kDt);  // within one step's force increment
  EXPECT_EQ(d.time_to_force(), s.back().t);       // no hold, no withdrawal
  EXPECT_NEAR(d.depth(), 0.004, 0.02 * kDt + 1e-12);
}

TEST(Press, StopAtTargetGivesUpAfterTheApproachTime) {
  PressSpec p = base();
  p.force = 1e3;  // unreachable within the time allowed
  p.stop_at_target = true;
  p.max_approach_time = 0.2;
  p.max_depth = 1.0;
  PressDevice d(p);
  const auto s = drive(d, 5000);
  EXPECT_TRUE(d.finished());
  EXPECT_FALSE(d.force_reached());
  EXPECT_NEAR(s.back().t, 0.2, 1.5 * kDt);
}

TEST(Press, PositionControlFollowsTheDepthWhateverTheForce) {
  PressSpec p = base();
  p.depth = 0.008;
  p.hold = 0.3;
  p.withdraw_speed = 0.03;
  PressDevice d(p);
  const auto s = drive(d, 5000);
  ASSERT_TRUE(d.force_reached());
  // (2 mm + 8 mm) at 2 cm/s = 0.5 s to the depth.
  EXPECT_NEAR(d.time_to_force(), 0.5, 1.5 * kDt);
  double deepest = -1;
  for (const auto& x : s) {
    const double depth = p.normal.dot(p.point - x.x);
    deepest = std::max(deepest, depth);
    if (x.phase == PressPhase::hold) {
      EXPECT_NEAR(depth, 0.008, 1e-12);
    }
  }
  EXPECT_NEAR(deepest, 0.008, 1e-12);  // never deeper than asked
  // Hold 0.3 s, then 10 mm out at 3 cm/s, then the release.
  EXPECT_NEAR(s.back().t, 0.5 + 0.3 + 0.010 / 0.03 + 0.2, 4 * kDt);
}

TEST(Press, SlidingHoldMovesAlongTheSurfaceAtTheGivenSpeed) {
  PressSpec p = base();
  const Eigen::Vector3d tangent = Eigen::Vector3d(2, -1, 0).normalized();  // ⟂ normal
  ASSERT_NEAR(tangent.dot(p.normal), 0.0, 1e-15);
  p.slide = 0.02 * tangent;
  p.hold = 1.0;
  PressDevice d(p);
  const auto s = drive(d, 5000);
  ASSERT_TRUE(d.finished());
  // Along the tangent: 0 before the hold, then 2 cm/s while the force is held.
  std::vector<std::pair<double, double>> hold;  // (t, along)
  for (const auto& x : s) {
    const double along = tangent.dot(x.x - p.point);
    if (x.phase == PressPhase::approach) {
      EXPECT_NEAR(along, 0.0, 1e-15);
    }
    if (x.phase == PressPhase::hold) {
      hold.push_back({x.t, along});
      EXPECT_NEAR(x.f, 2.5, 0.05);  // the force is still held
    }
  }
  ASSERT_GT(hold.size(), 900u);
  const double speed = (hold.back().second - hold[1].second) / (hold.back().first - hold[1].first);
  EXPECT_NEAR(speed, 0.02, 1e-9);
  // ... and 2 cm along after it (kept while withdrawing).
  EXPECT_NEAR(tangent.dot(s.back().x - p.point), 0.02, 2 * 0.02 * kDt);
}

TEST(Press, BadSpecsAreRefused) {
  auto bad = [](auto edit) {
    PressSpec p = base();
    edit(p);
    EXPECT_THROW(PressDevice{p}, std::invalid_argument);
  };
  bad([](PressSpec& p) { p.depth = -0.001; });
  bad([](PressSpec& p) { p.force = 0.0; });  // force control needs a force
  bad([](PressSpec& p) { p.force_error = -1.0; });
  bad([](PressSpec& p) { p.hold_speed_in = 0.0; });
  bad([](PressSpec& p) { p.hold_speed_out = NAN; });
  bad([](PressSpec& p) { p.slide = Eigen::Vector3d(NAN, 0, 0); });
  PressSpec depth_only = base();
  depth_only.force = 0.0;
  depth_only.depth = 0.005;  // position control does not need one
  EXPECT_NO_THROW(PressDevice{depth_only});
}

// A multi-segment script (PressSpec::segments) at a held depth: hold 0.1 s, slide 1 cm at 2 cm/s,
// hold 0.05 s, withdraw. Every position along the path is where the timing rule of press.hpp
// puts it (k-th step after the target: tau = k dt), and each segment ends on its own step.
TEST(Press, SegmentsHoldSlideHoldFollowThePathExactly) {
  PressSpec p = base();
  const Eigen::Vector3d tangent = Eigen::Vector3d(2, -1, 0).normalized();
  const Eigen::Vector3d by = 0.01 * tangent;
  p.hold_depth = true;
  p.segments = {PressSegment::hold_for(0.1), PressSegment::slide_by(by, 0.02),
                PressSegment::hold_for(0.05)};
  PressDevice d(p);
  std::vector<int> seg;  // d.segment() after each step
  std::vector<Step> s;
  for (int k = 0; k < 5000 && !d.finished(); ++k) {
    const auto one = drive_from(d, k);
    s.push_back(one);
    seg.push_back(d.segment());
  }
  ASSERT_TRUE(d.finished());
  ASSERT_TRUE(d.force_reached());
  // R: the step that reached 2.5 N; x_r its position, the depth held from then on.
  size_t R = 0;
  while (s[R].phase == PressPhase::approach) ++R;
  EXPECT_EQ(s[R].t, d.time_to_force());
  EXPECT_GE(s[R].f, 2.5);
  EXPECT_LT(s[R - 1].f, 2.5);
  const Eigen::Vector3d xr = s[R].x;
  for (int k = 1; k <= 100; ++k) {  // hold: 0.1 s = 100 steps, not moving
    EXPECT_NEAR((s[R + k].x - xr).norm(), 0.0, 1e-15) << k;
    EXPECT_EQ(s[R + k].phase, PressPhase::hold);
  }
  for (int k = 101; k <= 600; ++k) {  // slide: 1 cm at 2 cm/s = 500 steps of 20 um
    const Eigen::Vector3d want = xr + by * ((k - 100) / 500.0);
    EXPECT_NEAR((s[R + k].x - want).norm(), 0.0, 1e-14) << k;
  }
  EXPECT_NEAR((s[R + 101].x - xr).norm(), 0.02 * kDt, 1e-14);  // the first step moves speed dt
  EXPECT_NEAR((s[R + 600].x - (xr + by)).norm(), 0.0, 1e-14);  // the last lands on `by`
  for (int k = 601; k <= 650; ++k)                             // hold 0.05 s at the end
    EXPECT_NEAR((s[R + k].x - (xr + by)).norm(), 0.0, 1e-14) << k;
  // The segment index changes after the last step of each segment (segment() is the segment of
  // the next step), and -1 once the withdrawal begins.
  EXPECT_EQ(seg[R], 0);
  EXPECT_EQ(seg[R + 99], 0);
  EXPECT_EQ(seg[R + 100], 1);
  EXPECT_EQ(seg[R + 599], 1);
  EXPECT_EQ(seg[R + 600], 2);
  EXPECT_EQ(seg[R + 649], 2);
  EXPECT_EQ(seg[R + 650], -1);
  // Step R + 651 is the first of the withdrawal: 5 cm/s out along the normal, the offset kept.
  const Eigen::Vector3d w = s[R + 651].x - (xr + by);
  EXPECT_NEAR(w.dot(p.normal), 0.05 * kDt, 1e-14);
  EXPECT_NEAR((w - w.dot(p.normal) * p.normal).norm(), 0.0, 1e-14);
  EXPECT_EQ(s[R + 650].phase, PressPhase::withdraw);
  // The depth was held: the half-space force is the same on every step of the segments.
  for (int k = 1; k <= 650; ++k) EXPECT_NEAR(s[R + k].f, s[R].f, 1e-9) << k;
  // Ends withdrawn to the start offset, `by` along the surface.
  EXPECT_NEAR((s.back().x - (p.point + 0.002 * p.normal + by)).norm(), 0.0, 1e-12);
}

// Under force control the segments hold the force while sliding (the sliding press of the
// benchmarks as a script), and a script of zero-length holds withdraws on the next step.
TEST(Press, SegmentsUnderForceControlHoldTheForce) {
  PressSpec p = base();
  const Eigen::Vector3d tangent = Eigen::Vector3d(2, -1, 0).normalized();
  p.segments = {PressSegment::slide_by(0.015 * tangent, 0.03)};  // 0.5 s
  PressDevice d(p);
  const auto s = drive(d, 5000);
  ASSERT_TRUE(d.finished());
  int held = 0;
  for (const auto& x : s)
    if (x.phase == PressPhase::hold && x.t > d.time_to_force() + 0.1 + 0.5 * kDt) {
      EXPECT_NEAR(x.f, 2.5, 0.025);
      ++held;
    }
  EXPECT_EQ(held, 400 - 1);  // 500 steps of slide, the first 0.1 s settling, the last withdraws
  EXPECT_NEAR(tangent.dot(s.back().x - p.point), 0.015, 1e-12);

  PressSpec z = base();
  z.segments = {PressSegment::hold_for(0.0)};
  PressDevice dz(z);
  const auto sz = drive(dz, 5000);
  size_t R = 0;
  while (sz[R].phase == PressPhase::approach) ++R;
  EXPECT_EQ(sz[R].phase, PressPhase::withdraw);  // no step at the target after the one reaching it
  EXPECT_NEAR(p.normal.dot(sz[R].x - sz[R + 1].x), -0.05 * kDt, 1e-14);
}

TEST(Press, BadSegmentsAreRefused) {
  auto bad = [](PressSegment g) {
    PressSpec p = base();
    p.segments = {PressSegment::hold_for(0.1), g};
    EXPECT_THROW(PressDevice{p}, std::invalid_argument);
  };
  bad(PressSegment::hold_for(-0.1));
  bad(PressSegment::hold_for(NAN));
  bad(PressSegment::slide_by(Eigen::Vector3d(0.01, 0, 0), 0.0));
  bad(PressSegment::slide_by(Eigen::Vector3d(0.01, 0, 0), -0.02));
  bad(PressSegment::slide_by(Eigen::Vector3d(NAN, 0, 0), 0.02));
}

// The hold's force control when the stiffness under the probe changes mid-hold (a slide from one
// tissue onto another): the half-space spring's stiffness jumps from 500 N/m to `ratio` x that
// 0.2 s into the hold. The jump itself moves the force at once (ratio x the target: no
// controller can prevent it); what the controller owns is the way back. Bounds: back within
// 10 % of the target in (the depth to travel at the hold's rate limit) + 10 steps and within
// 1 % 30 steps later, from one side (below), and the stiffness estimate within 10 % of the new
// stiffness.
// The former controller (a fixed integral gain 0.2 / secant) lost contact for 3 steps and rang
// after an 8x jump (loop gain 1.6) and had no stiffness estimate.
namespace {
struct JumpRun {
  std::vector<double> f;  // N per hold step from the jump on
  double k_hat = 0.0;     // N/m at the end
  long steps_in10 = -1, steps_in1 = -1;
};

JumpRun stiffness_jump(double ratio) {
  PressSpec p = base();
  p.hold = 0.6;
  PressDevice d(p);
  JumpRun out;
  double t_jump = -1.0;
  for (int k = 0; k < 5000 && !d.finished(); ++k) {
    const Eigen::Vector3d x = d.read(k * kDt).position;
    const double depth = p.normal.dot(p.point - x);
    if (t_jump < 0.0 && d.force_reached() && (k + 1) * kDt > d.time_to_force() + 0.2)
      t_jump = (k + 1) * kDt;
    const double stiff = t_jump > 0.0 ? ratio * kK : kK;
    Rendered r;
    r.t = (k + 1) * kDt;
    r.force = stiff * std::max(depth, 0.0) * p.normal;
    r.contact = depth > 0.0;
    d.write(r);
    if (t_jump > 0.0 && d.phase() == PressPhase::hold) out.f.push_back(r.force.norm());
  }
  out.k_hat = d.stiffness_estimate();
  auto settled_from = [&](double band) {
    long from = -1;
    for (long i = static_cast<long>(out.f.size()) - 1; i >= 0; --i) {
      if (std::abs(out.f[i] / p.force - 1.0) > band) break;
      from = i;
    }
    return from;
  };
  out.steps_in10 = settled_from(0.10);
  out.steps_in1 = settled_from(0.01);
  return out;
}
}  // namespace

TEST(Press, ForceControlRecoversFromAStiffnessJumpMidHold) {
  const PressSpec p = base();
  for (double ratio : {2.0, 0.5, 8.0}) {
    SCOPED_TRACE(ratio);
    const JumpRun r = stiffness_jump(ratio);
    ASSERT_GT(r.f.size(), 300u);
    const double travel = std::abs(p.force / (ratio * kK) - p.force / kK);  // m of depth
    const double rate = ratio > 1.0 ? p.hold_speed_out : p.hold_speed_in;
    const long bound = static_cast<long>(std::ceil(travel / (rate * kDt))) + 10;
    std::printf(
        "stiffness x%.1f: within 10 %% after %ld steps (bound %ld), 1 %% after %ld; "
        "estimate %.0f N/m for %.0f\n",
        ratio, r.steps_in10, bound, r.steps_in1, r.k_hat, ratio * kK);
    ASSERT_GE(r.steps_in10, 0);
    EXPECT_LE(r.steps_in10, bound);
    ASSERT_GE(r.steps_in1, 0);
    EXPECT_LE(r.steps_in1, r.steps_in10 + 30);
    // The way back: from one side (through the target by at most 1 %) after 2x and 0.5x;
    // after 8x the last rate-limited step crosses it (measured 2.0 N, -20 %), never losing the
    // contact (the former controller's first step back left the surface for 3 steps).
    const double through = ratio < 4.0 ? 0.01 : 0.25;
    for (double f : r.f) {
      if (ratio > 1.0) {
        EXPECT_GE(f, (1.0 - through) * p.force);
      } else {
        EXPECT_LE(f, (1.0 + through) * p.force);
        EXPECT_GE(f, 0.99 * ratio * p.force);  // never below where the jump put it
      }
    }
    // The estimate learns from changes of the depth step (second differences): after 2x and
    // 0.5x it has the new stiffness; after 8x the way back is 9 equal steps at the rate limit
    // (no second difference), so it has moved only part of the way (still, toward it).
    if (ratio < 4.0) {
      EXPECT_NEAR(r.k_hat, ratio * kK, 0.1 * ratio * kK);
    } else {
      EXPECT_GT(r.k_hat, 2.0 * kK);
    }
  }
}

// A settled hold on an unchanging spring leaves the estimate and the force alone: the estimate
// does not drift without excitation (the dead zone) and the force stays at the target.
TEST(Press, StiffnessEstimateHoldsStillOnAConstantSpring) {
  PressSpec p = base();
  p.hold = 1.0;
  PressDevice d(p);
  const auto s = drive(d, 5000);
  ASSERT_TRUE(d.force_reached());
  EXPECT_NEAR(d.stiffness_estimate(), kK, 0.1 * kK);
  for (const auto& x : s)
    if (x.phase == PressPhase::hold) {
      EXPECT_NEAR(x.f, 2.5, 2.5 * 1e-3);  // the target is reached on a step boundary
    }
}
