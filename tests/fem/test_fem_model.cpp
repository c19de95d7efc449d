// FemModel (the haptic-scene FEM) and the co-rotational code path the integrator calls:
// steady states equal the static solve, the condensed model equals the full one at equilibrium,
// the Sherman–Morrison contact step equals the directly assembled implicit step, and the
// tangent used by the step matches finite differences of the forces used by the step,
// including an inverted element; the contact patch step equals its assembled step.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <random>

#include "common/input_error.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_model.hpp"
#include "engine/solvers/fem_static.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

struct Column {
  mesh::TetMesh m = fem_block_mesh(2, 2, 4, Eigen::Vector3d(0.02, 0.02, 0.04), 101, 0.1, 5);
  TetMaterials mat = tet_materials(m, mesh::default_materials());
  std::vector<std::uint8_t> fixed;
  int top = 0;  // node (1,1,4), top centre
  Column() {
    fixed.assign(m.V.rows(), 0);
    for (long i = 0; i < m.V.rows(); ++i) fixed[i] = m.V(i, 2) < 1e-12;
    top = 1 + 3 * (1 + 3 * 4);
  }
  std::vector<std::uint8_t> top_half() const {
    std::vector<std::uint8_t> op(m.T.rows(), 0);
    for (long t = 0; t < m.T.rows(); ++t) {
      double z = 0;
      for (int k = 0; k < 4; ++k) z += m.V(m.T(t, k), 2) / 4;
      op[t] = z > 0.025;
    }
    return op;
  }
  Eigen::VectorXd static_u(const Eigen::VectorXd& f) const {
    const FemSystem s = fem_precompute(m.V, m.T, mat);
    StaticSolver ss;
    static_precompute(s.K, node_to_dof_flags(fixed), ss);
    return static_solve(ss, f);
  }
};

FemModelOptions options(FemFormulation f, const Column& s) {
  FemModelOptions o;
  o.formulation = f;
  o.rayleigh_alpha = 300;  // heavy damping: reach equilibrium in a few hundred steps
  o.rayleigh_beta = 0.0;
  if (f == FemFormulation::condensed) o.operational_tet = s.top_half();
  return o;
}

// A four-node contact patch on the column's top (weights w, normal n) and the plain backward
// Euler quantities of its free dofs a reference step is written with: K, lumped masses, the
// patch's gap direction g (gap = sum_q w_q ((x_q - point) . n - off_q)) and A = (1 + h alpha) M +
// (h beta + h^2) K.
struct PatchReference {
  const Column& s;
  std::vector<int> patch;
  std::vector<double> w = {0.4, 0.2, 0.25, 0.15};
  Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.2, 1).normalized();
  DofSplit split;
  SparseMatrixd K;
  Eigen::VectorXd mass, g;
  std::vector<double> off;
  Eigen::Vector3d xp;
  explicit PatchReference(const Column& c)
      : s(c),
        patch{c.top, 0 + 3 * (1 + 3 * 4), 2 + 3 * (1 + 3 * 4), 1 + 3 * (0 + 3 * 4)},
        split(split_dofs(node_to_dof_flags(c.fixed))),
        xp(c.m.V.row(c.top).transpose()) {
    const FemSystem sys = fem_precompute(s.m.V, s.m.T, s.mat);
    K = submatrix(sys.K, split.free, split.free);
    mass = gather(sys.m_lumped, split.free);
    g = Eigen::VectorXd::Zero(K.rows());
    for (size_t q = 0; q < patch.size(); ++q) {
      g.segment<3>(split.local[3 * patch[q]]) += w[q] * n;
      off.push_back(std::max(0.0, (s.m.V.row(patch[q]).transpose() - xp).dot(n)));
    }
  }
  SparseMatrixd A(double h, double alpha, double beta) const {
    SparseMatrixd a = (h * beta + h * h) * K;
    for (long j = 0; j < a.rows(); ++j) a.coeffRef(j, j) += (1 + h * alpha) * mass[j];
    return a;
  }
  // The patch's gap for free-dof displacements u and a probe point.
  double gap(const Eigen::VectorXd& u, const Eigen::Vector3d& point) const {
    double d = 0;
    for (size_t q = 0; q < patch.size(); ++q) {
      const Eigen::Vector3d x =
          s.m.V.row(patch[q]).transpose() + u.segment<3>(split.local[3 * patch[q]]);
      d += w[q] * ((x - point).dot(n) - off[q]);
    }
    return d;
  }
  void attach(FemModel& model, double k) const {
    model.contact_node = s.top;
    model.contact_nodes = patch;
    model.contact_weights = w;
    model.contact_normal = n;
    model.contact_k = k;
  }
};

double rel(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff();
}

}  // namespace

TEST(FemModel, LinearAndCondensedSettleOnTheStaticSolution) {
  const Column s;
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * s.m.V.rows());
  f.segment<3>(3 * s.top) = Eigen::Vector3d(0.01, 0.0, -0.02);
  const Eigen::VectorXd u_static = s.static_u(f);
  for (FemFormulation form : {FemFormulation::linear, FemFormulation::condensed}) {
    FemModel model(s.m, s.mat, s.fixed, options(form, s));
    model.f_ext = f;
    for (int i = 0; i < 3000; ++i) model.step(1e-3);
    EXPECT_LT(rel(model.displacement(), u_static), 1e-8) << to_string(form);
    EXPECT_NEAR(model.positions()(s.top, 2), s.m.V(s.top, 2) + u_static[3 * s.top + 2], 1e-12);
  }
  // Consistent mass: same equilibrium; and the first step from rest under the same load equals
  // the co-rotational one (tangent = K at rest) with consistent mass.
  FemModelOptions oc = options(FemFormulation::linear, s);
  oc.lumped_mass = false;
  FemModel consistent(s.m, s.mat, s.fixed, oc);
  consistent.f_ext = f;
  for (int i = 0; i < 3000; ++i) consistent.step(1e-3);
  EXPECT_LT(rel(consistent.displacement(), u_static), 1e-8);
  oc.formulation = FemFormulation::corotational;
  FemModel c1(s.m, s.mat, s.fixed, oc);
  oc.formulation = FemFormulation::linear;
  FemModel l1(s.m, s.mat, s.fixed, oc);
  c1.f_ext = l1.f_ext = 1e-3 * f;
  c1.step(1e-3);
  l1.step(1e-3);
  EXPECT_LT(rel(c1.displacement(), l1.displacement()), 1e-9);
  // Consistent and lumped mass give different transients.
  FemModel lumped1(s.m, s.mat, s.fixed, options(FemFormulation::linear, s));
  lumped1.f_ext = l1.f_ext;
  lumped1.step(1e-3);
  EXPECT_GT(rel(lumped1.displacement(), l1.displacement()), 1e-3);
  FemModel cond(s.m, s.mat, s.fixed, options(FemFormulation::condensed, s));
  FemModel lin(s.m, s.mat, s.fixed, options(FemFormulation::linear, s));
  EXPECT_LT(cond.dofs(), lin.dofs());
  EXPECT_EQ(lin.dofs(), 3 * (s.m.V.rows() - 9));
}

TEST(FemModel, CorotationalSettlesNearLinearForSmallLoads) {
  const Column s;
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * s.m.V.rows());
  f.segment<3>(3 * s.top) = Eigen::Vector3d(0.0, 0.0, -1e-4);  // strain ~1e-4
  const Eigen::VectorXd u_static = s.static_u(f);
  FemModel model(s.m, s.mat, s.fixed, options(FemFormulation::corotational, s));
  model.f_ext = f;
  for (int i = 0; i < 1000; ++i) model.step(1e-3);
  EXPECT_LT(rel(model.displacement(), u_static), 1e-3);
  // A load 1000x larger (strains ~10 %) is visibly nonlinear but stays finite.
  model.f_ext = 1000 * f;
  for (int i = 0; i < 200; ++i) model.step(1e-3);
  EXPECT_TRUE(model.displacement().allFinite());
  EXPECT_GT(rel(model.displacement(), 1000 * u_static), 1e-3);
}

TEST(FemModel, ShermanMorrisonContactStepEqualsAssembledStep) {
  // From rest the co-rotational tangent is K and its forces vanish, so its step (contact
  // Jacobian assembled into the matrix, refactorised) must equal the linear step (contact by
  // Sherman–Morrison on cached columns).
  const Column s;
  std::unique_ptr<FemModel> m[2];
  m[0] = std::make_unique<FemModel>(s.m, s.mat, s.fixed, options(FemFormulation::linear, s));
  m[1] = std::make_unique<FemModel>(s.m, s.mat, s.fixed, options(FemFormulation::corotational, s));
  for (auto& p : m) {
    p->contact_node = s.top;
    p->contact_normal = Eigen::Vector3d(0.2, 0.1, 1.0).normalized();
    p->contact_point = s.m.V.row(s.top).transpose() - 0.002 * p->contact_normal;
    p->contact_k = 500;
    EXPECT_NEAR(p->penetration(), 0.002, 1e-15);
    EXPECT_NEAR(p->device_force().norm(), 1.0, 1e-12);
    p->step(1e-3);
  }
  EXPECT_LT(rel(m[1]->displacement(), m[0]->displacement()), 1e-10);
}

TEST(FemModel, PenaltyContactEquilibrium) {
  const Column s;
  for (FemFormulation form : {FemFormulation::linear, FemFormulation::condensed}) {
    FemModel model(s.m, s.mat, s.fixed, options(form, s));
    model.contact_node = s.top;
    model.contact_normal = Eigen::Vector3d::UnitZ();
    model.contact_point = s.m.V.row(s.top).transpose() - Eigen::Vector3d(0, 0, 0.003);
    model.contact_k = 50;
    for (int i = 0; i < 3000; ++i) model.step(1e-3);
    // At rest the node carries -k d n and the body is in static equilibrium under it.
    Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * s.m.V.rows());
    f.segment<3>(3 * s.top) = -model.device_force();
    EXPECT_GT(model.device_force().z(), 0.0);
    EXPECT_LT(rel(model.displacement(), s.static_u(f)), 1e-8) << to_string(form);
  }
}

TEST(FemModel, InputErrors) {
  const Column s;
  EXPECT_THROW(fem_formulation_from_string("quadratic"), InputError);
  EXPECT_EQ(fem_formulation_from_string("corotational"), FemFormulation::corotational);
  // No fixed node: the body floats, the stiffness is singular.
  EXPECT_THROW(FemModel(s.m, s.mat, {}, {}), std::runtime_error);
  FemModelOptions o;
  o.formulation = FemFormulation::condensed;
  EXPECT_THROW(FemModel(s.m, s.mat, s.fixed, o), InputError);  // no operational flags
  FemModelOptions oc = options(FemFormulation::condensed, s);
  oc.lumped_mass = false;
  EXPECT_THROW(FemModel(s.m, s.mat, s.fixed, oc), InputError);  // Guyan model is lumped
  FemModel cond(s.m, s.mat, s.fixed, options(FemFormulation::condensed, s));
  EXPECT_FALSE(cond.solves_node(1 + 3 * (1 + 3 * 1)));  // interior of the condensed part
  cond.contact_node = 1 + 3 * (1 + 3 * 1);
  cond.contact_k = 10;
  cond.contact_point = s.m.V.row(cond.contact_node).transpose() - Eigen::Vector3d(0, 0, 0.001);
  EXPECT_THROW(cond.step(1e-3), std::logic_error);
  EXPECT_THROW(cond.step(0), std::invalid_argument);
}

// The element routine the step calls (corotational_element via corotational_stiffness).
TEST(FemCorotational, TangentMatchesForcesIncludingInvertedElement) {
  const Eigen::Vector3d a(0, 0, 0), b(0.01, 0, 0), c(0, 0.01, 0), d(0, 0, 0.01);
  const TetShape s = tet_shape(a, b, c, d);
  const Matrix12d Ke = element_stiffness(s, 1e4, 0.45);
  Vector12d X0;
  X0 << a, b, c, d;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  const Eigen::Matrix3d Q =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix();
  for (int inverted = 0; inverted < 2; ++inverted) {
    Vector12d x;
    for (int r = 0; r < 4; ++r) x.segment<3>(3 * r) = Q * X0.segment<3>(3 * r);
    for (int i = 0; i < 12; ++i) x[i] += 0.001 * U(rng);
    if (inverted) x.segment<3>(9) = Q * Eigen::Vector3d(0.002, 0.003, -0.004);  // d through abc
    const double vol =
        tet_shape(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), x.segment<3>(9)).volume;
    EXPECT_EQ(vol < 0, inverted == 1);
    Vector12d f;
    Matrix12d Kt;
    corotational_element(s.grad, Ke, X0, x, CorotJacobian::exact, f, &Kt);
    Matrix12d Kfd;
    const double h = 1e-9;
    for (int j = 0; j < 12; ++j) {
      Vector12d xp = x, xm = x, fp, fm;
      xp[j] += h;
      xm[j] -= h;
      corotational_element(s.grad, Ke, X0, xp, CorotJacobian::exact, fp, nullptr);
      corotational_element(s.grad, Ke, X0, xm, CorotJacobian::exact, fm, nullptr);
      Kfd.col(j) = -(fp - fm) / (2 * h);
    }
    EXPECT_LT((Kt - Kfd).cwiseAbs().maxCoeff(), 1e-6 * Kfd.cwiseAbs().maxCoeff()) << inverted;
    if (inverted) {
      // The force on the inverted node points back through the face (towards +normal side).
      const Eigen::Vector3d n = Q * Eigen::Vector3d::UnitZ();
      EXPECT_GT(f.segment<3>(9).dot(n), 0.0);
    }
  }
}

TEST(FemCorotational, RigidMotionOfRestShapeHasNoForce) {
  const mesh::TetMesh m = fem_block_mesh(2, 2, 2, Eigen::Vector3d(0.02, 0.02, 0.02), 101, 0.1);
  const FemSystem s = fem_precompute(m.V, m.T, uniform_materials(m.T.rows(), 1e4, 0.45, 1000));
  const Eigen::Matrix3d Q =
      Eigen::AngleAxisd(2.5, Eigen::Vector3d(0.3, 1, -0.2).normalized()).toRotationMatrix();
  Eigen::VectorXd x(s.dofs());
  for (long i = 0; i < s.nodes(); ++i)
    x.segment<3>(3 * i) = Q * s.X0.row(i).transpose() + Eigen::Vector3d(1, 2, 3);
  Eigen::VectorXd f, f2;
  corotational_forces(s, x, f);
  std::vector<Matrix12d> ws;
  SparseMatrixd Kt;
  corotational_stiffness(s, x, CorotJacobian::exact, ws, Kt, &f2);
  // Linear FEM would give |K (x - X0)| ~ E * 0.02 m = 200 N here.
  EXPECT_LT(f.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ((f - f2).cwiseAbs().maxCoeff(), 0.0);  // the step's pass gives the same forces
}

// The linear step (Sherman–Morrison contact, K u carried without products between resyncs)
// against a plain backward Euler written out here with the assembled matrix, over 300 steps
// with the contact on (past the first resync at 256).
TEST(FemModel, LinearStepMatchesPlainBackwardEuler) {
  const Column s;
  FemModelOptions o;  // default damping alpha 1/s, beta 1 ms
  FemModel model(s.m, s.mat, s.fixed, o);
  const FemSystem sys = fem_precompute(s.m.V, s.m.T, s.mat);
  const DofSplit split = split_dofs(node_to_dof_flags(s.fixed));
  const SparseMatrixd K = submatrix(sys.K, split.free, split.free);
  const Eigen::VectorXd mass = gather(sys.m_lumped, split.free);
  const double h = 1e-3, k = 200, alpha = o.rayleigh_alpha, beta = o.rayleigh_beta;
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.2, 1).normalized();
  const int lp = split.local[3 * s.top];
  Eigen::VectorXd u = Eigen::VectorXd::Zero(K.rows()), v = u;
  model.contact_node = s.top;
  model.contact_normal = n;
  model.contact_k = k;
  Eigen::Vector3d point = s.m.V.row(s.top).transpose() - 0.002 * n;
  for (int i = 0; i < 300; ++i) {
    if (i == 150) point -= 0.001 * n;  // press deeper halfway
    model.contact_point = point;
    const Eigen::Vector3d x = s.m.V.row(s.top).transpose() + u.segment<3>(lp);
    const double d = std::max(0.0, (x - point).dot(n));
    ASSERT_GT(d, 0.0) << i;  // the contact stays on
    SparseMatrixd A = (h * beta + h * h) * K;
    for (long j = 0; j < A.rows(); ++j) A.coeffRef(j, j) += (1 + h * alpha) * mass[j];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) A.coeffRef(lp + r, lp + c) += h * h * k * n[r] * n[c];
    Eigen::VectorXd f = -(K * u);
    f.segment<3>(lp) -= k * d * n;
    SparseLdlt ldlt(A);
    const Eigen::VectorXd rhs = mass.cwiseProduct(v) + h * f;  // (no aliasing of v)
    v = ldlt.solve(rhs);
    u += h * v;
    model.step(h);
  }
  const Eigen::VectorXd um = gather(model.displacement(), split.free);
  EXPECT_LT((um - u).cwiseAbs().maxCoeff(), 1e-9 * u.cwiseAbs().maxCoeff());
}

// The contact patch (model "fem": the probe face shared by area): the same plain backward Euler
// with the rank-1 patch Jacobian h^2 k g g^T (g = sum_i w_i e_i n) assembled, the penetration
// d = sum_i w_i ((x_i - point) . n - o_i) with the rest offsets o_i above the tangent plane.
// The linear model (Sherman–Morrison on cached A^-1 G) must follow it over 300 steps, and the
// co-rotational model (Sherman–Morrison with a fresh solve) must equal the linear one on the
// first step from rest.
TEST(FemModel, PatchContactStepMatchesPlainBackwardEuler) {
  const Column s;
  const PatchReference P(s);
  FemModelOptions o;
  FemModel model(s.m, s.mat, s.fixed, o);
  const double h = 1e-3, k = 300;
  EXPECT_GT(*std::max_element(P.off.begin(), P.off.end()), 0.0);  // the offsets are exercised
  P.attach(model, k);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(P.K.rows()), v = u;
  Eigen::Vector3d point = P.xp - 0.003 * P.n;
  const Eigen::MatrixXd Ad = Eigen::MatrixXd(P.A(h, o.rayleigh_alpha, o.rayleigh_beta)) +
                             h * h * k * P.g * P.g.transpose();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(Ad);
  for (int i = 0; i < 300; ++i) {
    if (i == 150) point -= 0.001 * P.n;
    model.contact_point = point;
    const double d = P.gap(u, point);
    ASSERT_GT(d, 0.0) << i;
    EXPECT_NEAR(model.penetration(), d, 1e-12) << i;
    const Eigen::VectorXd f = -(P.K * u) - k * d * P.g;
    v = ldlt.solve(Eigen::VectorXd(P.mass.cwiseProduct(v) + h * f));
    u += h * v;
    model.step(h);
  }
  const Eigen::VectorXd um = gather(model.displacement(), P.split.free);
  EXPECT_LT((um - u).cwiseAbs().maxCoeff(), 1e-9 * u.cwiseAbs().maxCoeff());
  EXPECT_NEAR(model.device_force().norm(), k * model.penetration(), 1e-12);

  std::unique_ptr<FemModel> m[2];
  m[0] = std::make_unique<FemModel>(s.m, s.mat, s.fixed, options(FemFormulation::linear, s));
  m[1] = std::make_unique<FemModel>(s.m, s.mat, s.fixed, options(FemFormulation::corotational, s));
  for (auto& p : m) {
    P.attach(*p, 500);
    p->contact_point = P.xp - 0.002 * P.n;
    p->step(1e-3);
  }
  EXPECT_LT(rel(m[1]->displacement(), m[0]->displacement()), 1e-10);
}

// The contact is a one-sided penalty on the gap at the END of a step (complementarity): the
// step is solved free, and the patch is pushed only if that free motion ends inside the probe.
// Deciding from the gap at the step's start let a body released by a stiff probe rebound into
// it for a whole step unopposed (D with a 2e4 N/m pad: 2.05 N on withdrawal from a 1 N hold,
// 2026-12-07) and pulled a patch the probe was leaving. Checked against plain backward Euler
// with that rule, through a press, a sudden release (the body rebounds into the probe) and a
// withdrawal faster than the body follows; both of the cases the old rule got wrong occur.
TEST(FemModel, ContactActsOnTheGapAtTheEndOfTheStep) {
  const Column s;
  const PatchReference P(s);
  const double h = 1e-3, k = 2e4;
  // The linear formulation (the corotational one differs from plain backward Euler by its
  // rotations; its contact code is the same rule).
  FemModelOptions o;  // the default, light damping: the body rebounds
  FemModel model(s.m, s.mat, s.fixed, o);
  const Eigen::MatrixXd Ad = Eigen::MatrixXd(P.A(h, o.rayleigh_alpha, o.rayleigh_beta));
  const Eigen::LDLT<Eigen::MatrixXd> free(Ad), pushed(Ad + h * h * k * P.g * P.g.transpose());
  P.attach(model, k);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(P.K.rows()), v = u;
  int rebound = 0, left = 0;  // steps the old rule got wrong: d <= 0 < g_free, d > 0 >= g_free
  for (int i = 0; i < 600; ++i) {
    // In 1.5 mm deep at 5 cm/s and stopped (the body's inertia carries it on, away from the
    // probe), held; at 300 the probe steps back 30 um and stays (the body rebounds into it);
    // from 450 it withdraws at 5 cm/s.
    const double depth = i < 30    ? 5e-5 * i
                         : i < 300 ? 1.5e-3
                         : i < 450 ? 1.47e-3
                                   : 1.47e-3 - 5e-5 * (i - 449);
    const Eigen::Vector3d point = P.xp - depth * P.n;
    model.contact_point = point;
    const double d = P.gap(u, point);
    const Eigen::VectorXd b = P.mass.cwiseProduct(v) - h * (P.K * u);
    const Eigen::VectorXd v_free = free.solve(b);
    const double g_free = d + h * P.g.dot(v_free);
    rebound += d <= 0 && g_free > 0;
    left += d > 0 && g_free <= 0;
    v = g_free > 0 ? Eigen::VectorXd(pushed.solve(Eigen::VectorXd(b - h * k * d * P.g))) : v_free;
    u += h * v;
    model.step(h);
    const Eigen::VectorXd um = gather(model.displacement(), P.split.free);
    ASSERT_LT((um - u).cwiseAbs().maxCoeff(), 1e-9 * std::max(1e-6, u.cwiseAbs().maxCoeff()))
        << "step " << i;
    // The force is the end-of-step gap's, never adhesive.
    EXPECT_NEAR(model.device_force().norm(), k * std::max(0.0, d + h * P.g.dot(v)), 1e-9) << i;
  }
  EXPECT_GT(rebound, 0);
  EXPECT_GT(left, 0);
}
