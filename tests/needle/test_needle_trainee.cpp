// The needle trainee's learning from a visible miss (protocols/participants/needle.hpp,
// docs/PARTICIPANTS.md "Needle insertion" 3.): with the tip drawn, every insertion that passes
// the target at closest distance r at depth d is an observation of the target depth with variance
// visual_spatial_sd^2 + r^2; merged by Kalman updates, the belief's variance after k such misses
// is exactly 1 / (1/var0 + k / (sd^2 + r^2)) whatever the noise draws. Without the tip drawn
// nothing is learnt.
#include <gtest/gtest.h>

#include <cmath>

#include "protocols/participants/needle.hpp"
#include "protocols/participants/params.hpp"

namespace {

namespace pm = palplab::protocols::participants;
using Mat = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// A flat skin patch in the plane y = 0 (outward normal -y), 5 x 5 nodes 5 mm apart. The target
// lies at depth 40 mm, 3 mm beside every straight track: the drawn distance is
// sqrt((depth - 0.040)^2 + 0.003^2) once the tip is in (never 0: always a miss).
struct Outcome {
  pm::TraineeState before, after;
  double closest = 1.0;  // m, smallest drawn distance fed
};

Outcome session(bool visible) {
  Mat V(25, 3), N(25, 3);
  std::vector<int> region(25, 0);
  for (int i = 0; i < 25; ++i) {
    V.row(i) << 0.005 * (i % 5 - 2), 0.0, 0.005 * (i / 5 - 2);
    N.row(i) << 0.0, -1.0, 0.0;
  }
  pm::SurfaceView view;
  view.V = &V;
  view.N = &N;
  view.vertex_region = &region;
  view.start_position = Eigen::Vector3d(0.0, -0.05, 0.0);
  pm::NeedleBriefing brief;
  brief.entry = Eigen::Vector3d::Zero();
  brief.target_depth = 0.06;  // briefed 20 mm too deep
  pm::TraineeParams p;
  p.aim_angle_sd = 0.0;
  p.aim_position_sd = 0.0;
  pm::NeedleTrainee t(p, pm::TraineeState{});
  t.begin_session(view, brief, 11, 22);
  Outcome r;
  r.before = t.state();
  double time = 0.0;
  for (int i = 0; i < 200000 && !t.done(); ++i) {
    time += 0.001;
    const pm::ToolCommand c = t.command(time);
    pm::Percept pc;
    pc.t = time;
    const double depth = c.x.y();  // the skin is y = 0, the needle goes along +y
    if (visible && c.tool == "needle" && depth > 0.0) {
      pc.visible_tip_to_target = std::hypot(depth - 0.040, 0.003);
      r.closest = std::min(r.closest, pc.visible_tip_to_target);
    }
    t.perceive(pc);
  }
  EXPECT_TRUE(t.done());
  // Seen: every insertion missed, so it re-aims up to max_insertions; blind: it stops once at
  // the believed depth.
  EXPECT_EQ(t.insertions(), visible ? 3 : 1);
  t.end_session(time);
  r.after = t.state();
  return r;
}

TEST(NeedleTrainee, AVisibleMissTeachesTheDepthByItsClosestApproach) {
  const Outcome seen = session(true);
  const pm::TraineeParams p;
  ASSERT_NEAR(seen.closest, 0.003, 1e-5);
  const double obs_var = p.visual_spatial_sd * p.visual_spatial_sd + 0.003 * 0.003;
  const double expect_var = 1.0 / (1.0 / seen.before.depth_var + 3.0 / obs_var);
  EXPECT_NEAR(seen.after.depth_var, expect_var, 0.01 * expect_var);
  // The belief moves from the briefed ~60 mm towards the 40 mm seen.
  EXPECT_LT(std::abs(seen.after.depth_mean - 0.040), std::abs(seen.before.depth_mean - 0.040));

  const Outcome blind = session(false);
  EXPECT_EQ(blind.after.depth_mean, blind.before.depth_mean);
  EXPECT_EQ(blind.after.depth_var, blind.before.depth_var);
}

}  // namespace
