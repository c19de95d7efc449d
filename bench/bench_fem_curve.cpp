// Why the reference's large-load (co-rotational) curve does not converge under refinement
// (issue 12): the verification block of tests/fem (4 x 4 x 2 cm, soft tissue, base pinned,
// the smooth press of fem_reference, radius 12 mm, along -z at the top centre), nested red
// refinements, linear and co-rotational static solutions of the same dead load. Per level:
// the work-conjugate compliance of both and their relative difference, the largest element
// rotation and displacement gradient |F - I| and where they are (distance to the pinned base's
// rim, to the press centre), the smallest det F, and the co-rotational minus linear strain
// energy of the solution split by region (near the pinned base, under the press, the rest).
// Build: cmake --build build --target bench_fem_curve; run: build/bench/bench_fem_curve [F_N]
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "engine/mesh/materials.hpp"
#include "engine/models/fem_block_mesh.hpp"
#include "engine/models/fem_reference.hpp"
#include "engine/models/fem_refine.hpp"
#include "engine/solvers/fem_corotational.hpp"
#include "engine/solvers/fem_static.hpp"

using namespace palplab;
using namespace palplab::engine;

int main(int argc, char** argv) {
  const double force = argc > 1 ? std::stod(argv[1]) : 0.3;
  const int levels = argc > 2 ? std::stoi(argv[2]) : 4;
  const Eigen::Vector3d size(0.04, 0.04, 0.02);
  mesh::TetMesh m = fem_block_mesh(2, 2, 1, size, 101);
  const Eigen::Vector3d centre(0.02, 0.02, 0.02);
  const double a = 0.012;
  std::printf("force %.3g N, press radius %.3g m, block %.2g x %.2g x %.2g m\n", force, a, size.x(),
              size.y(), size.z());
  std::printf("%6s %8s %12s %12s %9s | %9s %8s %8s | %9s %8s %8s | %9s | %10s %10s %10s\n", "level",
              "tets", "c_lin m/N", "c_cor m/N", "dev %", "max_rot", "d_rim", "d_pad", "max|F-I|",
              "d_rim", "d_pad", "min detF", "dE_rim", "dE_pad", "dE_rest");
  for (int level = 0; level < levels; ++level) {
    if (level > 0) m = refine_red(m).mesh;
    const TetMaterials mat = tet_materials(m, mesh::default_materials());
    const FemSystem sys = fem_precompute(m.V, m.T, mat);
    std::vector<std::uint8_t> fixed(m.V.rows(), 0);
    for (long i = 0; i < m.V.rows(); ++i) fixed[i] = m.V(i, 2) < 1e-9;
    const auto fixed_dof = node_to_dof_flags(fixed);
    const mesh::BoundaryFaces bf = mesh::boundary_faces(m);
    const PressLoad load =
        smooth_press_load(m.V, bf.F, centre, -Eigen::Vector3d::UnitZ(), force, a);
    StaticSolver ss;
    static_precompute(sys.K, fixed_dof, ss);
    const Eigen::VectorXd u_lin = static_solve(ss, load.f);
    // Co-rotational: ramp in 8 steps, full Newton with the exact tangent.
    const Eigen::VectorXd X = flatten(sys.X0);
    Eigen::VectorXd u = Eigen::VectorXd::Zero(sys.dofs()), fint;
    std::vector<Matrix12d> ws;
    SparseMatrixd Kt;
    StaticSolver st;
    for (int k = 1; k <= 8; ++k) {
      const Eigen::VectorXd fk = load.f * (k / 8.0);
      for (int it = 0; it < 40; ++it) {
        corotational_stiffness(sys, X + u, CorotJacobian::exact, ws, Kt, &fint);
        Eigen::VectorXd r = fk + fint;
        for (long d = 0; d < r.size(); ++d)
          if (fixed_dof[d]) r[d] = 0;
        static_precompute(Kt, fixed_dof, st);
        const Eigen::VectorXd du = static_solve(st, r);
        u += du;
        if (du.cwiseAbs().maxCoeff() < 1e-13 * u.cwiseAbs().maxCoeff()) break;
      }
    }
    const double c_lin = load.f.dot(u_lin) / force / force, c_cor = load.f.dot(u) / force / force;
    // Per element: rotation, |F - I|, det F, energy difference (co-rotational - linear) of u.
    double max_rot = 0, max_grad = 0, min_det = 1e9, rot_rim = 0, rot_pad = 0, g_rim = 0, g_pad = 0;
    double dE[3] = {0, 0, 0};
    for (long t = 0; t < m.T.rows(); ++t) {
      Vector12d x0, x, ue;
      Eigen::Vector3d ctr = Eigen::Vector3d::Zero();
      for (int r = 0; r < 4; ++r) {
        const int v = m.T(t, r);
        x0.segment<3>(3 * r) = X.segment<3>(3 * v);
        ue.segment<3>(3 * r) = u.segment<3>(3 * v);
        x.segment<3>(3 * r) = X.segment<3>(3 * v) + u.segment<3>(3 * v);
        ctr += X.segment<3>(3 * v) / 4;
      }
      const auto& grad = sys.shape[t].grad;
      Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
      for (int r = 0; r < 4; ++r) F += x.segment<3>(3 * r) * grad.row(r);
      Eigen::Matrix3d R, S;
      polar_decomposition(F, R, S);
      const double rot = std::acos(std::clamp((R.trace() - 1) / 2, -1.0, 1.0));
      const double g = (F - Eigen::Matrix3d::Identity()).norm();
      // Distance to the pinned base's rim (the bottom edges) and to the press centre.
      const double d_rim =
          std::hypot(ctr.z(), std::min({ctr.x(), size.x() - ctr.x(), ctr.y(), size.y() - ctr.y()}));
      const double d_pad = (ctr - centre).norm();
      if (rot > max_rot) max_rot = rot, rot_rim = d_rim, rot_pad = d_pad;
      if (g > max_grad) max_grad = g, g_rim = d_rim, g_pad = d_pad;
      min_det = std::min(min_det, F.determinant());
      Vector12d up;
      for (int r = 0; r < 4; ++r) up.segment<3>(3 * r) = R.transpose() * x.segment<3>(3 * r);
      up -= x0;
      // Translation-invariant: K_e annihilates rigid translations, so u' = R^T x - X0 is fine.
      const double e = 0.5 * up.dot(sys.Ke[t] * up) - 0.5 * ue.dot(sys.Ke[t] * ue);
      dE[d_rim < 0.004 ? 0 : d_pad < 1.5 * a ? 1 : 2] += e;
    }
    std::printf(
        "%6d %8ld %12.6g %12.6g %9.3f | %9.4f %8.4f %8.4f | %9.4f %8.4f %8.4f | %9.4f | %10.3g "
        "%10.3g %10.3g\n",
        level, static_cast<long>(m.T.rows()), c_lin, c_cor, 100 * (c_cor / c_lin - 1), max_rot,
        rot_rim, rot_pad, max_grad, g_rim, g_pad, min_det, dE[0], dE[1], dE[2]);
    std::fflush(stdout);
  }
  return 0;
}
