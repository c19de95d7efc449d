// The multi-rate co-rotational FEM (FemFormulation::corotational_multirate, fem_multirate.hpp):
// before its first update it is the linear FEM's static contact response at any load (the
// tangent at rest is K); at small load it stays linear; a held press converges (one Newton step
// per update) on the co-rotational static equilibrium that the full co-rotational model settles
// on; during a press ramp its force stays within the claimed bound of that equilibrium, while
// the linear model does not; the background update is deterministic and equals the in-step one
// one interval later.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>
#include <vector>

#include "common/input_error.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_model.hpp"
#include "engine/solvers/fem_corotational.hpp"
#include "engine/solvers/fem_static.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

constexpr double kH = 1e-3;   // haptic step (s)
constexpr double kK = 200.0;  // probe coupling (N/m): the column is ~100 N/m

// A soft column 2 x 2 x 4 cm (E = 10 kPa), base pinned, pressed on its top face by a flat
// probe (the nine top nodes, equal weights) at 45 degrees: down and sideways, so that the
// column bends and its elements rotate (a straight compression has no rotation: co-rotational
// = linear there).
struct TiltedColumn {
  mesh::TetMesh m = fem_block_mesh(2, 2, 4, Eigen::Vector3d(0.02, 0.02, 0.04), 101, 0.0, 5);
  TetMaterials mat = uniform_materials(m.T.rows(), 1e4, 0.45, 1000);
  std::vector<std::uint8_t> fixed;
  std::vector<int> top;
  int centre = 1 + 3 * (1 + 3 * 4);
  Eigen::Vector3d n = Eigen::Vector3d(-1, 0, 1).normalized();  // outward probe normal
  double offset = 0;  // the patch's rest gap with the device at the centre node (m, <= 0)
  TiltedColumn() {
    fixed.assign(m.V.rows(), 0);
    for (long i = 0; i < m.V.rows(); ++i) {
      fixed[i] = m.V(i, 2) < 1e-12;
      if (m.V(i, 2) > 0.04 - 1e-12) top.push_back(static_cast<int>(i));
    }
    // The tilted face: nodes below the tangent plane through the centre count their distance.
    for (int i : top) offset += std::min(0.0, (m.V.row(i) - m.V.row(centre)).dot(n)) / top.size();
  }
  // Where the device is when the patch's penetration at rest is `depth` (m).
  Eigen::Vector3d point(double depth) const {
    return m.V.row(centre).transpose() - (depth - offset) * n;
  }
  void touch(FemModel& f, double depth, double k = kK) const {
    f.contact_node = centre;
    f.contact_nodes = top;
    f.contact_weights.assign(top.size(), 1.0 / top.size());
    f.contact_normal = n;
    f.contact_point = point(depth);
    f.contact_k = k;
  }
};

// Deterministic unless asked: the worker is waited for at the next update.
FemModelOptions multirate(bool background, double interval = 1.0 / 60, bool realtime = false) {
  FemModelOptions o;
  o.formulation = FemFormulation::corotational_multirate;
  o.update_interval = interval;
  o.multirate_background = background;
  o.multirate_deterministic = !realtime;
  return o;
}

// The static equilibrium of the column with the probe's penalty spring at `depth`: linear FEM
// (closed form: f = k d / (1 + k e^T K^-1 e)) or co-rotational FEM (Newton with the exact
// tangent, the contact by Sherman–Morrison). Returns the force on the probe (N, along +z).
double static_force(const TiltedColumn& s, double depth, double k, bool corot) {
  const FemSystem sys = fem_precompute(s.m.V, s.m.T, s.mat);
  const auto fixed_dof = node_to_dof_flags(s.fixed);
  const long n3 = sys.dofs();
  Eigen::VectorXd e = Eigen::VectorXd::Zero(n3);
  for (int i : s.top) e.segment<3>(3 * i) = s.n / s.top.size();
  // The penetration of FemModel's patch: o_i = max(0, (X_i - X_c) . n) above the tangent plane.
  const Eigen::Vector3d xc = s.m.V.row(s.centre).transpose(), p = s.point(depth);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(n3);
  const auto gap = [&] {
    double g = 0;
    for (int i : s.top) {
      const Eigen::Vector3d X = s.m.V.row(i).transpose();
      g += ((X + u.segment<3>(3 * i) - p).dot(s.n) - std::max(0.0, (X - xc).dot(s.n))) /
           s.top.size();
    }
    return g;
  };
  StaticSolver ss;
  if (!corot) {
    static_precompute(sys.K, fixed_dof, ss);
    const Eigen::VectorXd y = static_solve(ss, e);
    return k * gap() / (1 + k * e.dot(y));
  }
  const Eigen::VectorXd X = flatten(sys.X0);
  std::vector<Matrix12d> ws;
  SparseMatrixd Kt;
  Eigen::VectorXd f;
  for (int it = 0; it < 50; ++it) {
    corotational_stiffness(sys, X + u, CorotJacobian::exact, ws, Kt, &f);
    const double g = gap();
    Eigen::VectorXd r = f - k * std::max(0.0, g) * e;
    for (long i = 0; i < n3; ++i)
      if (fixed_dof[i]) r[i] = 0;
    static_precompute(Kt, fixed_dof, ss);
    Eigen::VectorXd du = static_solve(ss, r);
    if (g > 0) {  // (K_t + k e e^T)^-1 r
      const Eigen::VectorXd z = static_solve(ss, e);
      du -= z * (k * e.dot(du) / (1 + k * e.dot(z)));
    }
    u += du;
    if (du.cwiseAbs().maxCoeff() < 1e-15) break;
  }
  return k * std::max(0.0, gap());
}

}  // namespace

TEST(FemMultirate, BeforeItsFirstUpdateItIsTheLinearStaticResponseAtAnyLoad) {
  const TiltedColumn s;
  for (double depth : {1e-6, 0.004, 0.012}) {
    FemModel f(s.m, s.mat, s.fixed, multirate(true));
    s.touch(f, depth);
    f.step(kH);
    const double lin = static_force(s, depth, kK, false);
    EXPECT_NEAR(f.device_force().dot(s.n), lin, 1e-10 * lin) << depth;
    EXPECT_NEAR(f.device_force().cross(s.n).norm(), 0.0, 1e-12 * lin);
    EXPECT_NEAR(f.penetration(), lin / kK, 1e-12);
  }
}

TEST(FemMultirate, SmallLoadEqualsLinear) {
  // After 300 ms (18 updates, converged) the force is the co-rotational equilibrium, which
  // differs from the linear one at relative O(strain) (the tangent's stress terms): 1 um gives
  // strains ~1e-5 (measured 2.7e-5 relative), 0.1 um ten times less.
  const TiltedColumn s;
  for (double depth : {1e-6, 1e-7}) {
    FemModel f(s.m, s.mat, s.fixed, multirate(true));
    s.touch(f, depth);
    for (int i = 0; i < 300; ++i) f.step(kH);
    const double lin = static_force(s, depth, kK, false);
    EXPECT_NEAR(f.device_force().dot(s.n), lin, 100 * depth * lin) << depth;
  }
}

TEST(FemMultirate, HeldPressConvergesOnTheCorotationalEquilibrium) {
  // 12 mm into the 4 cm column at 45 degrees: it bends, the co-rotational force is visibly not
  // linear.
  const TiltedColumn s;
  const double depth = 0.012, k = kK;
  const double ref = static_force(s, depth, k, true), lin = static_force(s, depth, k, false);
  std::printf("12 mm: co-rotational %.6g N, linear %.6g N\n", ref, lin);
  EXPECT_GT(std::abs(ref - lin), 0.01 * ref);  // nonlinear enough to tell them apart
  for (bool bg : {false, true}) {
    FemModel f(s.m, s.mat, s.fixed, multirate(bg));
    s.touch(f, depth, k);
    for (int i = 0; i < 400; ++i) f.step(kH);  // 24 updates: Newton has converged
    EXPECT_NEAR(f.device_force().dot(s.n), ref, 1e-9 * ref) << bg;
  }
  // The full (dynamic) co-rotational model, heavily damped, settles on the same force.
  FemModelOptions o;
  o.formulation = FemFormulation::corotational;
  o.rayleigh_alpha = 300;
  o.rayleigh_beta = 0;
  FemModel full(s.m, s.mat, s.fixed, o);
  s.touch(full, depth, k);
  for (int i = 0; i < 1500; ++i) full.step(kH);
  EXPECT_NEAR(full.device_force().dot(s.n), ref, 1e-5 * ref);
}

TEST(FemMultirate, RampStaysWithinTheClaimedBoundOfTheEquilibrium) {
  // The probe goes 12 mm in at 2 cm/s (600 steps, 36 updates at 60 Hz). At every step the
  // multi-rate force is compared with the co-rotational static equilibrium at that depth (what
  // a quasi-static press of the full model feels). Claimed bound: 1 % of the peak force (the
  // linearisation is one to two intervals old: the probe moved <= 0.7 mm since; measured
  // 0.19 %). Also in real time (the worker adopted when finished: here within the interval).
  const TiltedColumn s;
  const double k = kK, v = 0.02;
  std::vector<double> ref, lin;
  for (int i = 25; i <= 600; i += 25) {  // the reference costs a Newton solve
    ref.push_back(static_force(s, v * kH * i, k, true));
    lin.push_back(static_force(s, v * kH * i, k, false));
  }
  for (bool realtime : {false, true}) {
    FemModel f(s.m, s.mat, s.fixed, multirate(true, 1.0 / 60, realtime));
    double max_err = 0, max_err_lin = 0, peak = 0;
    auto next = std::chrono::steady_clock::now();
    for (int i = 1; i <= 600; ++i) {
      if (realtime) {  // paced at 1 kHz, as the haptic loop: the worker runs beside it
        next += std::chrono::milliseconds(1);
        std::this_thread::sleep_until(next);
      }
      s.touch(f, v * kH * i, k);
      f.step(kH);
      if (i % 25 != 0) continue;
      const size_t q = i / 25 - 1;
      max_err = std::max(max_err, std::abs(f.device_force().dot(s.n) - ref[q]));
      max_err_lin = std::max(max_err_lin, std::abs(lin[q] - ref[q]));
      peak = std::max(peak, ref[q]);
    }
    const long lag = f.linearisation_max_lag();
    std::printf(
        "ramp: max |F - F_eq| %.4g N (%.3g %% of the peak %.4g N); linear: %.4g N; "
        "%ld re-linearisations, largest lag %ld intervals\n",
        max_err, 100 * max_err / peak, peak, max_err_lin, f.relinearisations(), lag);
    // The claim holds for a linearisation one interval old when adopted (deterministic, or a
    // worker that kept up). A worker made late by the machine (a loaded CI, a sanitizer build)
    // leaves an older one in use: then only the comparison with the linear model is claimed.
    if (!realtime) {
      EXPECT_EQ(lag, 1);
    }
    if (lag <= 1) {
      EXPECT_LT(max_err, 0.01 * peak) << realtime;
    }
    if (lag <= 2) {
      EXPECT_GT(max_err_lin, 3 * max_err);  // the linear model is not within it
    }
    // Deterministic: one per update after the first (35 in the 36 intervals); real time: at
    // least 10, fewer when the machine made the worker (~1 ms here) late: one per `lag`
    // intervals then.
    EXPECT_GE(f.relinearisations(), realtime ? std::min(10L, 36 / std::max(lag, 1L) - 1) : 35L)
        << "largest lag " << lag;
  }
}

TEST(FemMultirate, BackgroundUpdateIsDeterministicAndLagsOneInterval) {
  const TiltedColumn s;
  const auto run = [&](bool bg, double interval) {
    FemModel f(s.m, s.mat, s.fixed, multirate(bg, interval));
    std::vector<double> F;
    for (int i = 1; i <= 200; ++i) {
      s.touch(f, 0.00005 * i);
      f.step(kH);
      F.push_back(f.device_force().dot(s.n));
    }
    Eigen::VectorXd u = f.displacement();
    EXPECT_TRUE(u.allFinite());
    EXPECT_GT(u.cwiseAbs().maxCoeff(), 1e-3);          // the graphics state moved
    EXPECT_EQ(f.linearisation_max_lag(), bg ? 1 : 0);  // adopted one interval late, or at once
    return F;
  };
  const auto a = run(true, 0.01), b = run(true, 0.01), c = run(false, 0.01);
  EXPECT_EQ(a, b);  // independent of thread timing
  double diff = 0;
  for (size_t i = 0; i < a.size(); ++i) diff = std::max(diff, std::abs(a[i] - c[i]));
  EXPECT_GT(diff, 0.0);              // the background one uses the previous linearisation
  EXPECT_LT(diff, 0.01 * c.back());  // ... which costs little
  // Up to the first update both are the linear response about rest.
  EXPECT_EQ(a[5], c[5]);
}

TEST(FemMultirate, ResetAndInputErrors) {
  const TiltedColumn s;
  EXPECT_EQ(fem_formulation_from_string("corotational_multirate"),
            FemFormulation::corotational_multirate);
  EXPECT_STREQ(to_string(FemFormulation::corotational_multirate), "corotational_multirate");
  EXPECT_THROW(FemModel(s.m, s.mat, s.fixed, multirate(true, 0.0)), InputError);
  FemModel f(s.m, s.mat, s.fixed, multirate(true));
  EXPECT_EQ(f.dofs(), 3 * (s.m.V.rows() - 9));
  s.touch(f, 0.005);
  for (int i = 0; i < 50; ++i) f.step(kH);
  const double F1 = f.device_force().dot(s.n);
  f.reset();
  EXPECT_EQ(f.displacement().cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(f.device_force().norm(), 0.0);
  for (int i = 0; i < 50; ++i) f.step(kH);
  EXPECT_EQ(f.device_force().dot(s.n), F1);  // the same run again
  f.contact_node = -1;
  f.step(kH);
  EXPECT_EQ(f.device_force().norm(), 0.0);
}
