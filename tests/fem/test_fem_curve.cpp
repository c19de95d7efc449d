// The quasi-static curve of fem_reference when a load step does not converge (issue 12): the
// curve is a result up to the last converged load, with the reason, not an exception; a load
// step that the Newton iterations cannot take at once is taken in bisected increments and
// reaches the same equilibrium.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_reference.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {
constexpr int kSteps = 4;
constexpr int kNewton = 3;
// The loads tried (N; the block's linear stiffness is ~300 N/m, so 0.3 N is ~1 mm on its 2 cm
// height, 9.6 N far beyond it): each test takes the smallest at which the restricted solver
// fails, so that the case is a real non-convergence whatever the block's exact response.
constexpr double kForces[] = {0.3, 0.6, 1.2, 2.4, 4.8, 9.6};

// The verification block of test_fem_reference.cpp (2 x 2 x 1 hexes, 6 tets each: 12, 96, 768
// tets on the nested levels), base pinned, the smooth press at the top centre along -z.
FemReferenceOptions block(int steps, double force) {
  const mesh::TetMesh b = fem_block_mesh(2, 2, 1, Eigen::Vector3d(0.04, 0.04, 0.02), 101);
  const int top = 1 + 3 * (1 + 3 * 1);  // the centre of the top face
  FemReferenceOptions o = reference_options_from_mesh(b, top, force, 0.012);
  o.is_fixed = [](const Eigen::Vector3d& p) { return p.z() < 1e-9; };
  o.refinement = FemRefinement::nested;
  o.curve_steps = steps;
  return o;
}

void print(const char* what, const FemReferenceResult& r) {
  std::printf("%s: complete %d, %zu points\n", what, r.curve_complete ? 1 : 0, r.curve.size());
  for (size_t l = 0; l < r.levels.size(); ++l) {
    const auto& lv = r.levels[l];
    std::printf("  level %zu (%ld tets): %zu points, bisections %ld, line searches %ld", l, lv.tets,
                lv.curve_displacement.size(), lv.curve_bisections, lv.curve_line_searches);
    for (size_t k = 0; k < lv.curve_displacement.size(); ++k)
      std::printf(" [%.6g m, %d it, %d sub]", lv.curve_displacement[k], lv.curve_iterations[k],
                  lv.curve_substeps[k]);
    std::printf("\n");
  }
  if (!r.curve_complete) {
    const auto& f = r.curve_failure;
    std::printf(
        "  failure on level %d: step %d, load %.4g N (last equilibrium %.4g N, increment %.4g "
        "N), residual %.4g N after %d iterations, indefinite %d, negative pivots %ld / %ld, "
        "min det F %.3g (%ld inverted) / %.3g\n",
        r.curve_failure_level, f.step, f.force, f.last_converged_force, f.substep_force, f.residual,
        f.iterations, f.tangent_indefinite ? 1 : 0, f.negative_pivots, f.converged_negative_pivots,
        f.min_det_f, f.inverted_tets, f.converged_min_det_f);
  }
}
}  // namespace

// Without full Newton iterations (curve_max_newton 0) and without bisection, the modified
// Newton iterations on the linear K cannot take a large load step: the curve stops there and
// says so, and its converged points are the equilibria the default solver finds.
TEST(FemCurve, ANonConvergedStepEndsTheCurveWithTheReason) {
  bool found = false;
  for (double force : kForces) {
    FemReferenceOptions o = block(kSteps, force);
    const FemReferenceResult full = fem_reference(o);
    print("default", full);
    if (!full.curve_complete) break;  // beyond the default solver's range
    ASSERT_EQ(full.curve.size(), static_cast<size_t>(kSteps));
    EXPECT_FALSE(full.curve_failure.failed);
    EXPECT_EQ(full.curve_failure_level, -1);
    o.curve_max_newton = 0;
    o.curve_bisections = 0;
    const FemReferenceResult part = fem_reference(o);
    print("no Newton, no bisection", part);
    if (part.curve_complete) continue;
    found = true;
    std::printf("first failure at %.3g N\n", force);
    const FemCurveFailure& f = part.curve_failure;
    ASSERT_TRUE(f.failed);
    const size_t n = part.curve.size();
    ASSERT_LT(n, static_cast<size_t>(kSteps));
    EXPECT_EQ(f.step, static_cast<int>(n) + 1);
    EXPECT_DOUBLE_EQ(f.force, force * f.step / kSteps);
    EXPECT_DOUBLE_EQ(f.substep_force, force / kSteps);
    EXPECT_FALSE(f.residual <= o.curve_tolerance * f.force);
    ASSERT_GE(part.curve_failure_level, 0);
    // The failing level and the finer ones stop at the same load; the static part is unchanged.
    for (size_t l = 0; l < part.levels.size(); ++l) {
      const auto& lv = part.levels[l];
      EXPECT_EQ(lv.curve_failure.failed, static_cast<int>(l) == part.curve_failure_level) << l;
      if (static_cast<int>(l) >= part.curve_failure_level) {
        EXPECT_EQ(lv.curve_displacement.size(), n) << l;
      }
      EXPECT_EQ(lv.stiffness, full.levels[l].stiffness) << l;
      for (size_t k = 0; k < std::min(n, lv.curve_displacement.size()); ++k)
        EXPECT_NEAR(lv.curve_displacement[k] / full.levels[l].curve_displacement[k], 1.0, 1e-8)
            << l << " " << k;
    }
    EXPECT_DOUBLE_EQ(f.last_converged_force, n > 0 ? part.curve[n - 1].force : 0.0);
    for (size_t k = 0; k < n; ++k)
      EXPECT_NEAR(part.curve[k].displacement / full.curve[k].displacement, 1.0, 1e-7) << k;
    break;
  }
  EXPECT_TRUE(found) << "no load at which modified Newton alone fails";
}

// A load step that fails at once (one step to the whole force, few Newton iterations) is taken
// in bisected increments and reaches the equilibrium that the 4-step ramp reaches.
TEST(FemCurve, BisectionReachesTheRampsEquilibrium) {
  bool found = false;
  for (double force : kForces) {
    const FemReferenceResult ramp = fem_reference(block(kSteps, force));
    if (!ramp.curve_complete) break;
    FemReferenceOptions o = block(1, force);
    o.curve_max_newton = kNewton;
    o.curve_bisections = 0;
    const FemReferenceResult once = fem_reference(o);
    print("one step, no bisection", once);
    if (once.curve_complete) continue;
    found = true;
    std::printf("one step fails at %.3g N\n", force);
    EXPECT_TRUE(once.curve.empty());
    EXPECT_EQ(once.curve_failure.step, 1);
    EXPECT_DOUBLE_EQ(once.curve_failure.last_converged_force, 0.0);
    o.curve_bisections = 6;
    const FemReferenceResult bis = fem_reference(o);
    print("one step, bisection", bis);
    ASSERT_TRUE(bis.curve_complete);
    ASSERT_EQ(bis.curve.size(), 1u);
    long bisections = 0;
    for (size_t l = 0; l < bis.levels.size(); ++l) {
      bisections += bis.levels[l].curve_bisections;
      EXPECT_EQ(bis.levels[l].curve_substeps[0] > 1, bis.levels[l].curve_bisections > 0) << l;
      EXPECT_NEAR(bis.levels[l].curve_displacement[0] / ramp.levels[l].curve_displacement.back(),
                  1.0, 1e-8)
          << l;
    }
    EXPECT_GT(bisections, 0);
    break;
  }
  EXPECT_TRUE(found) << "no load at which one step with " << kNewton << " Newton iterations fails";
}
