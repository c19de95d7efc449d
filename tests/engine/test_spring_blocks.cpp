// The rank_one storage of the backward-Euler spring blocks (SpringBlocks::rank_one, the CG
// default): spring_tangent expands to spring_eval's blocks; one step solves the linearised
// backward-Euler system whose matrix-vector products are checked by central finite differences
// of compute_forces (the code path the integrator uses); and the step agrees with the 3x3-matrix
// path and with the exact LDLT solve.
#include <gtest/gtest.h>

#include <array>
#include <random>
#include <tuple>

#include "engine/solvers/integrators.hpp"

using namespace palplab::engine;

namespace {

// A 3x3x3 lattice of nodes 1 cm apart with springs to every neighbour within a cube diagonal,
// displaced at random by up to 1.5 mm (some springs stretched, some compressed), home springs on
// the bottom layer, node 0 fixed.
MassSpringSystem lattice(unsigned seed, bool moving) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  MassSpringSystem s;
  const int n = 27;
  s.X_rest.resize(n, 3);
  for (int i = 0; i < n; ++i) s.X_rest.row(i) << 0.01 * (i % 3), 0.01 * (i / 3 % 3), 0.01 * (i / 9);
  std::vector<std::pair<int, int>> e;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if ((s.X_rest.row(i) - s.X_rest.row(j)).norm() < 0.0175) e.emplace_back(i, j);
  RowMatX2i E(static_cast<long>(e.size()), 2);
  for (size_t k = 0; k < e.size(); ++k) E.row(static_cast<long>(k)) << e[k].first, e[k].second;
  s.springs = springs_from_edges(s.X_rest, E, 300.0, 0.6);
  for (long k = 0; k < s.springs.size(); ++k) s.springs.ks[k] *= 1.0 + 0.5 * u(rng);
  s.X = s.X_rest;
  s.V.setZero(n, 3);
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      s.X(i, c) += 0.0015 * u(rng);
      if (moving) s.V(i, c) = 0.05 * u(rng);
    }
  s.F_ext.setZero(n, 3);
  s.F_ext(26, 2) = -0.3;
  s.mass = Eigen::VectorXd::Constant(n, 2e-3);
  s.home_ks = Eigen::VectorXd::Zero(n);
  s.home_kd = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < 9; ++i) s.home_ks[i] = 50.0, s.home_kd[i] = 0.05;
  s.fixed.assign(n, 0);
  s.fixed[0] = 1;
  build_adjacency(s);
  return s;
}

// The refinement's dent ties (engine/models/refinement.hpp) added to a lattice: each middle node
// m of an x row is tied to the mean of its row neighbours a, b by three zero-rest-length springs,
// (m, a) and (m, b) with k/2 and (a, b) with -k/4.
MassSpringSystem with_ties(MassSpringSystem s, double k) {
  const long S = s.springs.size();
  std::vector<std::array<int, 3>> t;
  for (int i = 0; i < s.nodes(); ++i)
    if (i % 3 == 1) t.push_back({i, i - 1, i + 1});
  const long add = 3 * static_cast<long>(t.size());
  s.springs.E.conservativeResize(S + add, 2);
  s.springs.rest.conservativeResize(S + add);
  s.springs.ks.conservativeResize(S + add);
  s.springs.kd.conservativeResize(S + add);
  long w = S;
  for (const auto& [m, a, b] : t)
    for (const auto& [p, q, share] :
         {std::tuple{m, a, 0.5}, std::tuple{m, b, 0.5}, std::tuple{a, b, -0.25}}) {
      s.springs.E.row(w) << p, q;
      s.springs.rest[w] = 0.0;
      s.springs.ks[w] = share * k;
      s.springs.kd[w] = 0.0;
      ++w;
    }
  build_adjacency(s);
  return s;
}
// dv of one backward-Euler step of `blocks` / `solver` from s (s is not changed).
RowMatX3d step_dv(const MassSpringSystem& s0, LinearSolver solver, SpringBlocks blocks,
                  SpringJacobian jac, double h, ActiveSet* act_in = nullptr) {
  MassSpringSystem s = s0;
  ActiveSet act;
  if (act_in)
    act = *act_in;
  else
    activate_all(s, act);
  IntegratorWorkspace ws;
  ws.solver = solver;
  ws.blocks = blocks;
  ws.jacobian = jac;
  ws.cg_tolerance = 1e-14;
  ws.cg_force_tolerance = 0.0;
  integrate(s, act, h, Integrator::backward_euler, ws);
  return s.V - s0.V;
}

}  // namespace

TEST(SpringBlocks, TangentExpandsToSpringEval) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int t = 0; t < 20; ++t)
    for (SpringJacobian jac : {SpringJacobian::exact, SpringJacobian::definite}) {
      const Eigen::Vector3d x1(u(rng), u(rng), u(rng)), x2(u(rng), u(rng), u(rng)),
          v1(u(rng), u(rng), u(rng)), v2(u(rng), u(rng), u(rng));
      const double len = (x1 - x2).norm(), rest = len * (1.0 + 0.4 * u(rng));  // both signs
      Eigen::Vector3d f1;
      Eigen::Matrix3d Kx, Kv;
      spring_eval(x1, x2, v1, v2, 200.0, 0.3, rest, jac, f1, Kx, Kv);
      SpringTangent tg;
      spring_tangent(x1, x2, v1, v2, 200.0, 0.3, rest, jac, tg);
      const Eigen::Matrix3d P = tg.d * tg.d.transpose();
      EXPECT_EQ((tg.f1 - f1).norm(), 0.0);
      EXPECT_LT((-(tg.axial * P + tg.lateral * (Eigen::Matrix3d::Identity() - P)) - Kx).norm(),
                1e-12 * Kx.norm());
      EXPECT_LT((-tg.kd * P - Kv).norm(), 1e-12 * Kv.norm());
      EXPECT_NEAR(tg.d.norm(), 1.0, 1e-15);
      if (jac == SpringJacobian::definite) {
        EXPECT_GE(tg.lateral, 0.0);
      }
    }
  // A zero-rest-length spring (a dent tie, k of either sign): its tangent k I is exact, also
  // with the `definite` Jacobian (which clamps only compressed springs with a rest length).
  for (double k : {80.0, -40.0}) {
    const Eigen::Vector3d x1(0.01, 0.002, -0.003), x2(-0.004, 0.001, 0.002), v(0, 0, 0);
    SpringTangent tg;
    spring_tangent(x1, x2, v, v, k, 0.0, 0.0, SpringJacobian::definite, tg);
    EXPECT_EQ(tg.lateral, k);
    EXPECT_EQ(tg.axial, k);
    EXPECT_LT((tg.f1 + k * (x1 - x2)).norm(), 1e-15);
  }
  SpringTangent z;
  spring_tangent(Eigen::Vector3d::Ones(), Eigen::Vector3d::Ones(), Eigen::Vector3d::Zero(),
                 Eigen::Vector3d::UnitX(), 10.0, 1.0, 0.1, SpringJacobian::exact, z);
  EXPECT_EQ(z.f1.norm() + z.d.norm() + z.axial + z.lateral + z.kd, 0.0);
}

// From rest velocity (v0 = 0, so the omitted position derivative of the damping force is 0),
// with the exact spring Jacobian, the rank_one CG step solves
//   M dv - h D dv - h^2 K dv = h f0   (K v0 = 0),
// with K u and D u taken here by central differences of compute_forces.
TEST(SpringBlocks, RankOneStepSolvesTheFiniteDifferenceSystem) {
  const double h = 1e-3;
  // Seed 3 with dent ties (k = 60 N/m, of the order of the springs' 300 N/m), whose negative
  // (a, b) springs must enter the step exactly.
  for (unsigned seed : {1u, 2u, 3u, 103u}) {
    const MassSpringSystem s =
        seed > 100 ? with_ties(lattice(seed - 100, false), 60.0) : lattice(seed, false);
    const RowMatX3d dv =
        step_dv(s, LinearSolver::cg, SpringBlocks::rank_one, SpringJacobian::exact, h);
    RowMatX3d f0, fp, fm, gp, gm;
    compute_forces(s, s.X, s.V, f0);
    const double eps = 1e-7;  // dv is ~1e-4 m/s: eps * dv ~ 1e-11 m
    const double scale = eps / dv.norm();
    compute_forces(s, s.X + scale * dv, s.V, fp);
    compute_forces(s, s.X - scale * dv, s.V, fm);
    compute_forces(s, s.X, s.V + scale * dv, gp);
    compute_forces(s, s.X, s.V - scale * dv, gm);
    const RowMatX3d Kdv = (fp - fm) / (2 * scale), Ddv = (gp - gm) / (2 * scale);
    double res = 0.0, rhs = 0.0;
    for (long i = 0; i < s.nodes(); ++i) {
      if (s.fixed[i]) {
        EXPECT_EQ(dv.row(i).norm(), 0.0);
        continue;
      }
      const Eigen::RowVector3d r =
          s.mass[i] * dv.row(i) - h * Ddv.row(i) - h * h * Kdv.row(i) - h * f0.row(i);
      res += r.squaredNorm();
      rhs += (h * f0.row(i)).squaredNorm();
    }
    EXPECT_GT(dv.norm(), 1e-6);
    EXPECT_LT(std::sqrt(res), 1e-7 * std::sqrt(rhs)) << "seed " << seed;
  }
}

// With velocities (damping and K v0 terms), compressed springs, the definite tangent and a held
// node: rank_one CG = matrix CG = exact LDLT, to the CG tolerance.
TEST(SpringBlocks, RankOneMatchesMatrixAndLdlt) {
  const double h = 1e-3;
  for (unsigned seed : {4u, 5u, 105u}) {
    const MassSpringSystem s =
        seed > 100 ? with_ties(lattice(seed - 100, true), 60.0) : lattice(seed, true);
    ActiveSet act;
    activate_all(s, act);
    // Hold node 13 (the centre): its springs are "held" links of CG.
    act.is_active[13] = 0;
    act.nodes.erase(std::find(act.nodes.begin(), act.nodes.end(), 13));
    rebuild_active_springs(s, act);
    for (SpringJacobian jac : {SpringJacobian::definite, SpringJacobian::exact}) {
      const RowMatX3d a = step_dv(s, LinearSolver::cg, SpringBlocks::rank_one, jac, h, &act);
      const RowMatX3d b = step_dv(s, LinearSolver::cg, SpringBlocks::matrix, jac, h, &act);
      const RowMatX3d c =
          step_dv(s, LinearSolver::ldlt_refactor, SpringBlocks::rank_one, jac, h, &act);
      EXPECT_GT(c.norm(), 1e-4);
      EXPECT_EQ(a.row(13).norm(), 0.0);
      EXPECT_LT((a - c).norm(), 1e-10 * c.norm()) << "seed " << seed;
      EXPECT_LT((b - c).norm(), 1e-10 * c.norm()) << "seed " << seed;
    }
  }
}
