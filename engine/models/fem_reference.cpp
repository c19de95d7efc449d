#include "engine/models/fem_reference.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <string>

#include "common/input_error.hpp"
#include "engine/solvers/fem_assembly.hpp"
#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

bool richardson(double q0, double q1, double q2, double r, double& order, double& extrapolated) {
  const double d1 = q1 - q0, d2 = q2 - q1;
  if (!(d1 != 0) || d1 * d2 <= 0 || std::abs(d2) >= std::abs(d1)) {
    order = std::nan("");
    extrapolated = q2;
    return false;
  }
  order = std::log(d1 / d2) / std::log(r);
  extrapolated = q2 + d2 / (std::pow(r, order) - 1);
  return true;
}

bool richardson_sizes(const double q[3], const double h[3], double& order, double& extrapolated) {
  const double d1 = q[1] - q[0], d2 = q[2] - q[1];
  order = std::nan("");
  extrapolated = q[2];
  if (!(d1 != 0) || d1 * d2 <= 0 || !(h[0] > h[1] && h[1] > h[2] && h[2] > 0)) return false;
  // g(p) = d1 (h1^p - h2^p) - d2 (h0^p - h1^p) = 0, scaled by h0^-p for range.
  const auto g = [&](double p) {
    const double a = std::pow(h[1] / h[0], p), b = std::pow(h[2] / h[0], p);
    return d1 * (a - b) - d2 * (1 - a);
  };
  double lo = 0.05, hi = 12;
  if (g(lo) * g(hi) > 0) return false;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (g(lo) * g(mid) <= 0 ? hi : lo) = mid;
  }
  order = 0.5 * (lo + hi);
  const double C = d2 / (std::pow(h[2], order) - std::pow(h[1], order));
  extrapolated = q[2] - C * std::pow(h[2], order);
  return true;
}

FemReferenceOptions reference_options_from_mesh(const mesh::TetMesh& m, int press_node,
                                                double force, double press_radius) {
  if (press_node < 0 || press_node >= m.V.rows())
    throw InputError("fem reference: press node " + std::to_string(press_node) + " out of range");
  const mesh::BoundaryFaces bf = mesh::boundary_faces(m);
  std::vector<int> map(m.V.rows(), -1);
  std::vector<int> verts;
  mesh::Faces F(bf.F.rows(), 3);
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (long f = 0; f < bf.F.rows(); ++f) {
    const Eigen::Vector3d a = mesh::row3(m.V, bf.F(f, 0)), b = mesh::row3(m.V, bf.F(f, 1)),
                          c = mesh::row3(m.V, bf.F(f, 2));
    for (int k = 0; k < 3; ++k) {
      int& v = map[bf.F(f, k)];
      if (v < 0) {
        v = static_cast<int>(verts.size());
        verts.push_back(bf.F(f, k));
      }
      F(f, k) = v;
      if (bf.F(f, k) == press_node) normal += 0.5 * (b - a).cross(c - a);
    }
  }
  if (map[press_node] < 0)
    throw InputError("fem reference: press node " + std::to_string(press_node) +
                     " is not on the surface");
  mesh::Positions V(static_cast<long>(verts.size()), 3);
  for (size_t i = 0; i < verts.size(); ++i) V.row(static_cast<long>(i)) = m.V.row(verts[i]);
  FemReferenceOptions o;
  o.surface = mesh::make_surface_mesh(std::move(V), std::move(F));
  std::map<int, long> count;
  for (long t = 0; t < m.attribute.size(); ++t) ++count[m.attribute[t]];
  long best = -1;
  for (const auto& [a, c] : count)
    if (c > best) {
      best = c;
      o.default_attribute = a;
    }
  o.max_volume = m.volume.sum() / static_cast<double>(m.T.rows());
  o.press_point = mesh::row3(m.V, press_node);
  o.press_direction = -normal.normalized();
  o.force = force;
  o.press_radius = press_radius;
  return o;
}

FemReferenceResult fem_reference(const FemReferenceOptions& opt) {
  if (opt.levels < 3) throw InputError("fem reference: --levels must be >= 3");
  if (!opt.mesher && !(opt.max_volume > 0))
    throw InputError("fem reference: max_volume must be > 0");
  if (!(opt.force > 0)) throw InputError("fem reference: --force must be > 0 N");
  if (!(opt.press_radius > 0)) throw InputError("fem reference: press radius must be > 0 m");
  if (!opt.is_fixed) throw InputError("fem reference: no fixed (pinned) region given");
  if (!(opt.support_modulus >= 0))
    throw InputError("fem reference: support modulus must be >= 0 N/m^3");
  const Eigen::Vector3d dir = opt.press_direction.normalized();
  const long ns = opt.surface.V.rows();
  FemReferenceResult res;
  std::vector<Eigen::VectorXd> surface_u;
  for (int l = 0; l < opt.levels; ++l) {
    const auto t0 = std::chrono::steady_clock::now();
    mesh::TetOptions to;
    to.max_volume = opt.max_volume / std::pow(2.0, l);
    to.quality = opt.quality;
    to.keep_surface = false;  // uniform refinement includes the surface
    to.seeds = opt.seeds;
    to.default_attribute = opt.default_attribute;
    const mesh::TetMesh m = opt.mesher ? opt.mesher(l) : mesh::tetrahedralize(opt.surface, to);
    if (!opt.mesher && m.V.rows() < ns)
      throw InputError("fem reference: a level lost surface vertices");
    const TetMaterials mat = tet_materials(m, opt.materials);
    const FemSystem sys = fem_precompute(m.V, m.T, mat);
    std::vector<std::uint8_t> fixed = rigid_nodes(m, mat);
    long nfixed = 0;
    for (long i = 0; i < m.V.rows(); ++i) {
      fixed[i] = fixed[i] || opt.is_fixed(mesh::row3(m.V, i));
      nfixed += fixed[i];
    }
    if (nfixed == 0) throw InputError("fem reference: the fixed region contains no node");
    // Press: a smooth pressure profile (1 - (r/a)^2)^2 within radius a, as the consistent
    // load f_j = int p N_j dA (16-point sub-triangle rule per face), scaled to the total force.
    // The load functional is then (nearly) the same at every level, so nested refinements give
    // a monotone compliance and the differences between levels are discretisation error only.
    const mesh::BoundaryFaces bf = mesh::boundary_faces(m);
    Eigen::VectorXd f = Eigen::VectorXd::Zero(sys.dofs());
    Eigen::VectorXd w = Eigen::VectorXd::Zero(m.V.rows());
    double area = 0, total = 0;
    constexpr int kSub = 4;
    for (long k = 0; k < bf.F.rows(); ++k) {
      const Eigen::Vector3d a = mesh::row3(m.V, bf.F(k, 0)), b = mesh::row3(m.V, bf.F(k, 1)),
                            c = mesh::row3(m.V, bf.F(k, 2));
      const double ak = 0.5 * (b - a).cross(c - a).norm();
      const double reach = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()});
      if ((a - opt.press_point).norm() > opt.press_radius + reach) continue;
      bool in = false;
      const auto add = [&](double s1, double t1) {
        const Eigen::Vector3d x = a + s1 * (b - a) + t1 * (c - a);
        const double rr = (x - opt.press_point).norm() / opt.press_radius;
        if (rr >= 1) return;
        const double pw = (1 - rr * rr) * (1 - rr * rr) * ak / (kSub * kSub);
        w[bf.F(k, 0)] += pw * (1 - s1 - t1);
        w[bf.F(k, 1)] += pw * s1;
        w[bf.F(k, 2)] += pw * t1;
        total += pw;
        in = true;
      };
      for (int i = 0; i < kSub; ++i)
        for (int j = 0; i + j < kSub; ++j) {
          add((i + 1.0 / 3) / kSub, (j + 1.0 / 3) / kSub);
          if (i + j < kSub - 1) add((i + 2.0 / 3) / kSub, (j + 2.0 / 3) / kSub);
        }
      if (in) area += ak;
    }
    if (!(total > 0))
      throw InputError("fem reference: no surface within the press radius of the point");
    for (long i = 0; i < m.V.rows(); ++i)
      if (w[i] > 0) f.segment<3>(3 * i) = opt.force * dir * (w[i] / total);
    SparseMatrixd K = sys.K;
    if (opt.support_modulus > 0) {
      Eigen::VectorXd node_area = Eigen::VectorXd::Zero(m.V.rows());
      for (long k = 0; k < bf.F.rows(); ++k) {
        const Eigen::Vector3d a = mesh::row3(m.V, bf.F(k, 0)), b = mesh::row3(m.V, bf.F(k, 1)),
                              c = mesh::row3(m.V, bf.F(k, 2));
        for (int j = 0; j < 3; ++j) node_area[bf.F(k, j)] += (b - a).cross(c - a).norm() / 6;
      }
      for (long i = 0; i < m.V.rows(); ++i)
        for (int c = 0; c < 3; ++c)  // the diagonal is in the pattern: no insertion
          K.coeffRef(3 * i + c, 3 * i + c) += opt.support_modulus * node_area[i];
    }
    StaticSolver ss;
    static_precompute(K, node_to_dof_flags(fixed), ss);
    const Eigen::VectorXd u = static_solve(ss, f);
    const double delta = f.dot(u) / opt.force;  // work-conjugate contact displacement
    FemReferenceLevel lv;
    lv.max_volume = opt.mesher ? 0.0 : to.max_volume;
    lv.nodes = m.V.rows();
    lv.tets = m.T.rows();
    lv.dofs = static_cast<long>(ss.split.free.size());
    lv.patch_area = area;
    lv.mesh_size = std::cbrt(m.volume.sum() / static_cast<double>(m.T.rows()));
    lv.displacement = delta;
    lv.stiffness = opt.force / delta;
    lv.solve_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    res.levels.push_back(lv);
    if (!opt.mesher) surface_u.push_back(u.head(3 * ns));
  }
  const int L = opt.levels;
  const double q[3] = {res.levels[L - 3].stiffness, res.levels[L - 2].stiffness,
                       res.levels[L - 1].stiffness};
  double r = opt.refinement_ratio;
  if (opt.mesher) {
    if (!(r > 1)) r = std::cbrt(2.0);
    richardson(q[0], q[1], q[2], r, res.observed_order, res.stiffness);
  } else {
    const double h[3] = {res.levels[L - 3].mesh_size, res.levels[L - 2].mesh_size,
                         res.levels[L - 1].mesh_size};
    richardson_sizes(q, h, res.observed_order, res.stiffness);
    r = h[1] / h[2];  // for the field: the last pair
  }
  res.displacement = opt.force / res.stiffness;
  // Field: the same order, vertex by vertex (a per-vertex order would be noise).
  const double p = std::isfinite(res.observed_order) ? res.observed_order : 1.0;
  Eigen::VectorXd uf;
  double umax = 1;
  if (!surface_u.empty()) {
    uf = surface_u[L - 1] + (surface_u[L - 1] - surface_u[L - 2]) / (std::pow(r, p) - 1);
    res.field = unflatten(uf);
    umax = uf.cwiseAbs().maxCoeff();
  }
  res.order_plausible = res.observed_order >= 0.5 && res.observed_order <= 4.0;
  res.monotone = true;
  for (int l = 0; l < L; ++l) {
    auto& lv = res.levels[l];
    lv.est_error = std::abs(lv.stiffness - res.stiffness) / std::abs(res.stiffness);
    if (!surface_u.empty()) lv.field_error = (surface_u[l] - uf).cwiseAbs().maxCoeff() / umax;
    if (l > 0) res.monotone = res.monotone && lv.est_error < res.levels[l - 1].est_error;
  }
  return res;
}

}  // namespace palplab::engine
