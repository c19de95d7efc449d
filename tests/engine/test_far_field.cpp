// The linear exterior of prototype C's scope (engine/solvers/far_field.hpp): g must be the
// static response of the model that compute_forces evaluates (the force sum the integrator
// uses), to first order in the load.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "engine/solvers/far_field.hpp"

using namespace palplab::engine;

namespace {

// An n x n x n lattice (1 cm spacing) with springs to every neighbour within a cube diagonal (a
// rigid framework), the bottom layer fixed, a support spring on the top layer.
MassSpringSystem lattice(const int n = 4) {
  const double a = 0.01;
  MassSpringSystem s;
  s.X_rest.resize(n * n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) s.X_rest.row((i * n + j) * n + k) << i * a, j * a, k * a;
  // Slightly irregular, so that no spring direction is special.
  for (long v = 0; v < s.X_rest.rows(); ++v)
    s.X_rest.row(v) +=
        0.1 * a * Eigen::RowVector3d(std::sin(3.1 * v), std::cos(1.7 * v), std::sin(0.7 * v + 1.0));
  std::vector<std::pair<int, int>> e;
  for (int p = 0; p < n * n * n; ++p)
    for (int di = 0; di <= 1; ++di)
      for (int dj = -1; dj <= 1; ++dj)
        for (int dk = -1; dk <= 1; ++dk) {
          const int i = p / (n * n) + di, j = (p / n) % n + dj, k = p % n + dk;
          const int q = (i * n + j) * n + k;
          if (i < n && j >= 0 && j < n && k >= 0 && k < n && q > p) e.emplace_back(p, q);
        }
  std::sort(e.begin(), e.end());  // (p, q) order, as the all-pairs loop gave them
  RowMatX2i E(e.size(), 2);
  for (size_t k = 0; k < e.size(); ++k) E.row(k) << e[k].first, e[k].second;
  s.springs = springs_from_edges(s.X_rest, E, 300.0, 0.0);
  for (long k = 0; k < s.springs.size(); ++k) s.springs.ks[k] *= 1.0 + 0.5 * std::sin(2.3 * k);
  s.X = s.X_rest;
  s.V.setZero(s.X.rows(), 3);
  s.F_ext.setZero(s.X.rows(), 3);
  s.mass = Eigen::VectorXd::Constant(s.X.rows(), 1e-3);
  s.home_ks = Eigen::VectorXd::Zero(s.X.rows());
  s.home_kd = Eigen::VectorXd::Zero(s.X.rows());
  s.fixed.assign(s.X.rows(), 0);
  for (long v = 0; v < s.X.rows(); ++v) {
    if (v % n == 0) s.fixed[v] = 1;
    if (v % n == n - 1) s.home_ks[v] = 50.0;
  }
  build_adjacency(s);
  return s;
}

}  // namespace

TEST(FarField, DisplacementIsTheStaticResponseOfTheForcesTheIntegratorSums) {
  MassSpringSystem s = lattice();
  FarField ff;
  far_field_build(s, ff);
  ASSERT_TRUE(ff.ready());
  // A unit load spread over three top nodes, pushing along a slanted direction.
  const std::vector<int> patch = {3, 7, 19};
  const std::vector<double> w = {0.5, 0.3, 0.2};
  const Eigen::Vector3d dir = Eigen::Vector3d(0.3, -0.2, -1.0).normalized();
  far_field_solve(ff, patch, w, dir);
  // The equilibrium residual at X_rest + load g: zero to first order, so it must shrink with the
  // square of the load (a wrong stiffness leaves a residual linear in the load).
  double residual[2];
  const double loads[2] = {1e-2, 1e-3};  // N
  for (int q = 0; q < 2; ++q) {
    const double load = loads[q];
    s.X = s.X_rest;
    for (long v = 0; v < s.X.rows(); ++v)
      if (ff.dof[v] >= 0) s.X.row(v) += load * ff.g.segment<3>(ff.dof[v]).transpose();
    RowMatX3d F;
    compute_forces(s, s.X, s.V, F);
    for (size_t k = 0; k < patch.size(); ++k) F.row(patch[k]) += load * w[k] * dir.transpose();
    residual[q] = 0.0;
    for (long v = 0; v < s.X.rows(); ++v)
      if (!s.fixed[v]) residual[q] = std::max(residual[q], F.row(v).norm());
    std::printf("load %.0e N: largest displacement %.2e m, residual %.2e N\n", load,
                load * ff.g.cwiseAbs().maxCoeff(), residual[q]);
  }
  EXPECT_GT(ff.g.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT(residual[1], 1e-3 * loads[1]);
  EXPECT_GT(residual[0] / residual[1], 50.0);  // quadratic: 100
  // Fixed nodes have no dof; a load on a fixed node alone gives no displacement.
  EXPECT_EQ(ff.dof[0], -1);
  far_field_solve(ff, {0}, {1.0}, dir);
  EXPECT_EQ(ff.g.cwiseAbs().maxCoeff(), 0.0);
}

TEST(FarField, UnsupportedPartIsAnError) {
  MassSpringSystem s = lattice();
  s.fixed.assign(s.X.rows(), 0);
  s.home_ks.setZero();
  FarField ff;
  EXPECT_THROW(far_field_build(s, ff), std::runtime_error);
}

// The exterior beside the haptic loop (FarFieldUpdater): every mode adopts the very solution the
// in-step solve gives (the same solve code on the same factor), deterministic exactly `latency`
// steps after the request, async never waiting for it.
namespace {

struct Load {
  std::vector<int> nodes;
  std::vector<double> w;
  Eigen::Vector3d dir;
};

// The in-step (sync) solution of a load.
Eigen::VectorXd sync_g(FarField& ff, const Load& l) {
  far_field_solve(ff, l.nodes, l.w, l.dir);
  return ff.g;
}

double max_diff(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

const Load kLoads[3] = {
    {{3, 7, 19}, {0.5, 0.3, 0.2}, Eigen::Vector3d(0.3, -0.2, -1.0).normalized()},
    {{23, 27}, {0.6, 0.4}, Eigen::Vector3d(0, 0, -1)},
    {{63}, {1.0}, Eigen::Vector3d(-1.0, 0.5, -0.5).normalized()}};

}  // namespace

TEST(FarFieldUpdater, DeterministicAdoptsTheSyncSolutionExactlyAfterTheLatency) {
  MassSpringSystem s = lattice();
  FarField ff;
  far_field_build(s, ff);
  Eigen::VectorXd ref[3];
  for (int k = 0; k < 3; ++k) ref[k] = sync_g(ff, kLoads[k]);
  ASSERT_GT(ref[0].cwiseAbs().maxCoeff(), 0.0);
  const int latency = 5;
  FarFieldUpdater u(ff, FarFieldMode::deterministic, latency);
  EXPECT_EQ(u.g().cwiseAbs().maxCoeff(), 0.0);  // held at rest before the first solve
  u.advance();
  u.request(kLoads[0].nodes, kLoads[0].w, kLoads[0].dir);
  for (int k = 1; k < latency; ++k) {
    EXPECT_FALSE(u.advance()) << k;
    EXPECT_EQ(u.g().cwiseAbs().maxCoeff(), 0.0) << "the previous exterior until the adoption";
  }
  EXPECT_TRUE(u.advance());
  EXPECT_EQ(max_diff(u.g(), ref[0]), 0.0);  // bit-identical to the in-step solve
  // A request replaced before its adoption: only the newest is adopted, `latency` steps after it.
  u.request(kLoads[1].nodes, kLoads[1].w, kLoads[1].dir);
  EXPECT_FALSE(u.advance());
  EXPECT_FALSE(u.advance());
  u.request(kLoads[2].nodes, kLoads[2].w, kLoads[2].dir);
  for (int k = 1; k < latency; ++k) EXPECT_FALSE(u.advance()) << k;
  EXPECT_EQ(max_diff(u.g(), ref[0]), 0.0);
  EXPECT_TRUE(u.advance());
  EXPECT_EQ(max_diff(u.g(), ref[2]), 0.0);
  EXPECT_FALSE(u.advance());
  const FarFieldUpdateStats& st = u.stats();
  EXPECT_EQ(st.requests, 3);
  EXPECT_EQ(st.adopted, 2);
  EXPECT_EQ(st.superseded, 1);
  EXPECT_EQ(st.max_latency, latency);
  EXPECT_EQ(st.late, 0);
}

TEST(FarFieldUpdater, SyncSolvesInTheRequest) {
  MassSpringSystem s = lattice();
  FarField ff;
  far_field_build(s, ff);
  const Eigen::VectorXd ref = sync_g(ff, kLoads[1]);
  FarFieldUpdater u(ff, FarFieldMode::sync, 20);
  u.request(kLoads[1].nodes, kLoads[1].w, kLoads[1].dir);
  EXPECT_EQ(max_diff(u.g(), ref), 0.0);
  EXPECT_FALSE(u.pending());
  u.set_realtime(true);  // no effect on sync
  EXPECT_EQ(u.mode(), FarFieldMode::sync);
}

// A larger model (3000 dofs: a solve of a few ms, far longer than a step's bookkeeping), so that
// the worker is still busy when the haptic thread asks.
TEST(FarFieldUpdater, AsyncNeverWaitsAndAdoptsTheSyncSolution) {
  MassSpringSystem s = lattice(10);
  FarField ff;
  far_field_build(s, ff);
  Eigen::VectorXd ref[3];
  for (int k = 0; k < 3; ++k) ref[k] = sync_g(ff, kLoads[k]);
  FarFieldUpdater u(ff, FarFieldMode::deterministic, 1);
  u.set_realtime(true);
  ASSERT_EQ(u.mode(), FarFieldMode::async);
  long first_advance_adopted = 0, steps_total = 0;
  for (int rep = 0; rep < 6; ++rep) {
    const Load& l = kLoads[rep % 3];
    u.request(l.nodes, l.w, l.dir);
    long steps = 0;
    bool adopted = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!adopted && std::chrono::steady_clock::now() < deadline) {
      adopted = u.advance();
      if (++steps == 1 && adopted) ++first_advance_adopted;
      if (!adopted) std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
    ASSERT_TRUE(adopted) << rep;
    steps_total += steps;
    EXPECT_EQ(max_diff(u.g(), ref[rep % 3]), 0.0) << rep;
  }
  std::printf("async: %ld steps for 6 solves of %.2f ms (%ld adopted at the first step)\n",
              steps_total, u.stats().solve_ms, first_advance_adopted);
  // No step waited: the steps went on while the worker solved (a step that had waited would have
  // adopted the solution in the step right after the request).
  EXPECT_EQ(u.stats().waits, 0);
  EXPECT_LT(first_advance_adopted, 6);
  EXPECT_GT(steps_total, 6);
  EXPECT_EQ(u.stats().adopted, 6);
  EXPECT_GT(u.stats().late, 0);  // adopted after the 1-step latency: the solve took longer
  // Back to lock-step: the deterministic step waits for the worker (counted) and adopts on time.
  u.set_realtime(false);
  u.request(kLoads[0].nodes, kLoads[0].w, kLoads[0].dir);
  EXPECT_TRUE(u.advance());
  EXPECT_EQ(max_diff(u.g(), ref[0]), 0.0);
  EXPECT_LE(u.stats().waits, 1);
}

TEST(FarFieldUpdater, ClearAndDestructionWhileASolveIsInFlight) {
  MassSpringSystem s = lattice(10);
  FarField ff;
  far_field_build(s, ff);
  const Eigen::VectorXd ref = sync_g(ff, kLoads[1]);
  {
    FarFieldUpdater u(ff, FarFieldMode::async, 1);
    u.request(kLoads[0].nodes, kLoads[0].w, kLoads[0].dir);
    u.clear();  // the solve in flight (or queued) must never be adopted
    EXPECT_FALSE(u.pending());
    for (int k = 0; k < 200; ++k) {
      EXPECT_FALSE(u.advance());
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    EXPECT_EQ(u.g().cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ(u.stats().adopted, 0);
    // The next request after the clear is adopted normally.
    u.request(kLoads[1].nodes, kLoads[1].w, kLoads[1].dir);
    u.set_realtime(false);
    EXPECT_TRUE(u.advance());
    EXPECT_EQ(max_diff(u.g(), ref), 0.0);
    // Destroyed with a solve in flight: joins the worker after it (no use of freed buffers).
    u.request(kLoads[2].nodes, kLoads[2].w, kLoads[2].dir);
  }
  for (int k = 0; k < 20; ++k) {  // created and destroyed at once, again and again
    FarFieldUpdater u(ff, FarFieldMode::deterministic, 3);
    u.request(kLoads[k % 3].nodes, kLoads[k % 3].w, kLoads[k % 3].dir);
  }
  SUCCEED();
}

TEST(FarFieldUpdater, BlendStepsLinearlyAndEndsOnTheSolutionBitForBit) {
  // blend = 4: from the adoption step on, g = g_old + (k / 4)(g_new - g_old), k = 1, 2, 3, then
  // g_new itself (the converged exterior of an unblended update, bit for bit); a newer adoption
  // during a blend blends on from the g in use; clear() stops a blend.
  MassSpringSystem s = lattice();
  FarField ff;
  far_field_build(s, ff);
  Eigen::VectorXd ref[3];
  for (int k = 0; k < 3; ++k) ref[k] = sync_g(ff, kLoads[k]);
  const double scale = ref[0].cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0.0);
  const int latency = 5, blend = 4;
  FarFieldUpdater u(ff, FarFieldMode::deterministic, latency, blend);
  EXPECT_EQ(u.blend(), blend);
  u.request(kLoads[0].nodes, kLoads[0].w, kLoads[0].dir);
  for (int k = 1; k < latency; ++k) EXPECT_FALSE(u.advance()) << k;
  for (int k = 1; k < blend; ++k) {
    EXPECT_TRUE(u.advance()) << k;  // the adoption step is the first of the blend
    EXPECT_TRUE(u.pending()) << k;  // g changes at the next advance
    EXPECT_LE(max_diff(u.g(), (k / 4.0) * ref[0]), 1e-15 * scale) << k;
  }
  EXPECT_TRUE(u.advance());
  EXPECT_EQ(max_diff(u.g(), ref[0]), 0.0);
  EXPECT_FALSE(u.pending());
  EXPECT_FALSE(u.advance());
  EXPECT_EQ(u.stats().adopted, 1);
  // Sync mode: the request's step is the first of the blend; a request in the middle of a blend
  // blends on from the g in use.
  FarFieldUpdater v(ff, FarFieldMode::sync, 1, blend);
  v.request(kLoads[1].nodes, kLoads[1].w, kLoads[1].dir);
  EXPECT_LE(max_diff(v.g(), 0.25 * ref[1]), 1e-15 * scale);
  EXPECT_TRUE(v.advance());
  const Eigen::VectorXd mid = v.g();
  EXPECT_LE(max_diff(mid, 0.5 * ref[1]), 1e-15 * scale);
  v.request(kLoads[2].nodes, kLoads[2].w, kLoads[2].dir);
  EXPECT_LE(max_diff(v.g(), mid + 0.25 * (ref[2] - mid)), 1e-15 * scale);
  for (int k = 2; k < blend; ++k) EXPECT_TRUE(v.advance()) << k;
  EXPECT_TRUE(v.advance());
  EXPECT_EQ(max_diff(v.g(), ref[2]), 0.0);
  EXPECT_FALSE(v.advance());
  // clear() in the middle of a blend: at rest, nothing more changes.
  v.request(kLoads[0].nodes, kLoads[0].w, kLoads[0].dir);
  EXPECT_TRUE(v.pending());
  v.clear();
  EXPECT_FALSE(v.pending());
  EXPECT_FALSE(v.advance());
  EXPECT_EQ(v.g().cwiseAbs().maxCoeff(), 0.0);
}
