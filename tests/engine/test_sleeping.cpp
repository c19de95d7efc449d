// Sleeping: nodes at rest far from a load are not integrated; the result stays within the
// sleeping tolerance of integrating everything, and everything falls asleep again at rest.
#include <gtest/gtest.h>

#include "engine/mesh/generate.hpp"
#include "engine/solvers/sleeping.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {
MassSpringSystem sphere() {
  const mesh::SurfaceMesh m = mesh::generate_sphere(642);
  MassSpringSystem s;
  const long n = m.V.rows();
  s.X_rest = m.V;
  s.X = m.V;
  s.V.setZero(n, 3);
  s.F_ext.setZero(n, 3);
  s.mass = Eigen::VectorXd::Constant(n, 1e-3);
  s.home_ks = Eigen::VectorXd::Constant(n, 1000.0);
  s.home_kd = Eigen::VectorXd::Constant(n, 0.1);
  s.springs = springs_from_edges(m.V, m.E, 200.0, 0.2);
  build_adjacency(s);
  return s;
}
}  // namespace

TEST(Sleeping, CloseToIntegratingEverythingAndCheaper) {
  MassSpringSystem all = sphere(), lazy = sphere();
  ActiveSet a_all, a_lazy;
  activate_all(all, a_all);
  sleep_all(lazy, a_lazy);
  IntegratorWorkspace w1, w2;
  SleepParams sp;
  sp.x_tol = 1e-6;
  sp.v_tol = 1e-5;
  std::vector<std::uint8_t> scratch;
  const int node = 100;
  long max_awake = 0;
  double max_err = 0.0, peak = 0.0;  // peak: largest displacement of the loaded node (m)
  for (int k = 0; k < 1500; ++k) {
    const Eigen::RowVector3d f =
        k < 500 ? Eigen::RowVector3d(0, 0, -1.0) : Eigen::RowVector3d::Zero();
    all.F_ext.row(node) = f;
    lazy.F_ext.row(node) = f;
    if (k < 500 && !a_lazy.is_active[node]) wake_around(lazy, a_lazy, node);
    integrate(all, a_all, 1e-3, Integrator::backward_euler, w1);
    integrate(lazy, a_lazy, 1e-3, Integrator::backward_euler, w2);
    update_sleeping(lazy, a_lazy, sp, k < 500 ? node : -1, &w2.DV, scratch);
    max_awake = std::max<long>(max_awake, static_cast<long>(a_lazy.nodes.size()));
    max_err = std::max(max_err, (all.X - lazy.X).rowwise().norm().maxCoeff());
    peak = std::max(peak, (all.X.row(node) - all.X_rest.row(node)).norm());
  }
  EXPECT_GT(peak, 5e-4);
  EXPECT_LT(max_err, 0.01 * peak) << "sleeping error";
  EXPECT_LT(max_awake, all.nodes());  // never integrates the whole sphere
  EXPECT_TRUE(a_lazy.nodes.empty());  // back at rest: everything asleep
  EXPECT_EQ((lazy.X - lazy.X_rest).norm(), 0.0);
  std::printf("sleeping: at most %ld of %ld nodes awake, max error %.3g m\n", max_awake,
              all.nodes(), max_err);
}
