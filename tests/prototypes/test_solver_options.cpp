// Prototype C's solver options (engine/solvers/integrators.hpp) on a real press: the rank_one
// spring blocks (the default) and the extrapolated CG warm start against the original path
// (3x3 matrix blocks, the last dv as warm start). Both are the same linear system solved to the
// same CG tolerance (1e-4 in C.json), so the force they render must agree far below the 7 %
// force Weber fraction: within 1e-3 of the peak force, with refinement on (as shipped) and off.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "prototypes/factory.hpp"
#include "tests/prototypes/press_run.hpp"

using namespace palplab;

namespace {

std::vector<double> press_forces(engine::SolverConfig solver, bool refine) {
  engine::SceneConfig cfg =
      prototypes::load_prototype(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/C.json");
  cfg.solver = solver;
  cfg.refinement.enabled = refine;
  engine::Scene s = engine::make_scene(cfg);
  std::vector<double> f;
  // 2 mm out, in at 2 cm/s to 5 mm, held: 0.55 s in all.
  for (const auto& r : engine::testing::run_press(
           s, engine::testing::depth_press(s, "ovary_left", 0.005, 1e3), 550))
    f.push_back(r.force.norm());
  return f;
}

}  // namespace

TEST(SolverOptions, RankOneAndExtrapolatedWarmStartRenderTheOriginalForce) {
  for (bool refine : {true, false}) {
    engine::SceneConfig base =
        prototypes::load_prototype(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/C.json");
    engine::SolverConfig orig = base.solver, r1 = base.solver, ex = base.solver;
    orig.blocks = engine::SpringBlocks::matrix;
    orig.warm_start = engine::WarmStart::previous;
    r1.blocks = engine::SpringBlocks::rank_one;
    r1.warm_start = engine::WarmStart::previous;
    ex.blocks = engine::SpringBlocks::rank_one;
    ex.warm_start = engine::WarmStart::extrapolated;
    const std::vector<double> a = press_forces(orig, refine), b = press_forces(r1, refine),
                              c = press_forces(ex, refine);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_EQ(a.size(), c.size());
    const double peak = *std::max_element(a.begin(), a.end());
    EXPECT_GT(peak, 1.0);  // the press reached the tissue
    double db = 0.0, dc = 0.0;
    for (size_t k = 0; k < a.size(); ++k) {
      db = std::max(db, std::abs(b[k] - a[k]));
      dc = std::max(dc, std::abs(c[k] - a[k]));
    }
    EXPECT_LT(db, 1e-3 * peak) << "rank_one, refinement " << refine;
    EXPECT_LT(dc, 1e-3 * peak) << "extrapolated, refinement " << refine;
  }
}
