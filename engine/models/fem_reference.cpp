#include "engine/models/fem_reference.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>

#include "common/input_error.hpp"
#include "engine/haptics/scene_config.hpp"
#include "engine/models/fem_refine.hpp"
#include "engine/models/model.hpp"
#include "engine/solvers/fem_assembly.hpp"
#include "engine/solvers/fem_corotational.hpp"
#include "engine/solvers/fem_stability.hpp"
#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

namespace {
// The longest edge of the faces of F whose three vertices carry load in f (3#V).
double loaded_edge(const mesh::Positions& V, const mesh::Faces& F, const Eigen::VectorXd& f) {
  double h = 0;
  for (long k = 0; k < F.rows(); ++k) {
    // A face under the patch loads all three of its vertices (interior quadrature points);
    // a face of the ring around it only touches loaded vertices.
    bool loaded = true;
    for (int j = 0; j < 3; ++j) loaded = loaded && f.segment<3>(3 * F(k, j)).squaredNorm() > 0;
    if (!loaded) continue;
    for (int j = 0; j < 3; ++j)
      h = std::max(h, (mesh::row3(V, F(k, j)) - mesh::row3(V, F(k, (j + 1) % 3))).norm());
  }
  return h;
}
}  // namespace

double press_edge(const mesh::Positions& V, const mesh::Faces& F, const Eigen::Vector3d& point,
                  const Eigen::Vector3d& direction, double radius) {
  return loaded_edge(V, F, smooth_press_load(V, F, point, direction, 1.0, radius).f);
}

int auto_grade_rounds(const FemReferenceOptions& opt) {
  const double h = press_edge(opt.surface.V, opt.surface.F, opt.press_point, opt.press_direction,
                              opt.press_radius);
  int k = 0;
  while (k < 6 && h / std::pow(2.0, k) > opt.press_radius) ++k;
  return k;
}

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

std::string reference_untrusted_reason(const FemReferenceResult& r, double max_finest_error) {
  std::string why;
  const auto add = [&](const std::string& s) { why += (why.empty() ? "" : "; ") + s; };
  char buf[160];
  if (!std::isfinite(r.observed_order)) {
    add("the differences between levels do not shrink monotonically (no observed order)");
  } else if (!r.order_plausible) {
    std::snprintf(buf, sizeof buf, "observed order %.3g outside the asymptotic range [%.2g, %.2g]",
                  r.observed_order, kPlausibleOrder[0], kPlausibleOrder[1]);
    add(buf);
  }
  if (!r.monotone) add("estimated error not decreasing over the levels");
  const size_t L = r.levels.size();
  if (L >= 3 && r.press_radius > 0 && r.levels[L - 3].press_h > r.press_radius) {
    std::snprintf(buf, sizeof buf,
                  "press not resolved: on level %zu the loaded faces' edges reach %.3g mm > the "
                  "press radius %.3g mm (pre-asymptotic: a point load in effect)",
                  L - 3, 1e3 * r.levels[L - 3].press_h, 1e3 * r.press_radius);
    add(buf);
  }
  if (!r.levels.empty() && r.order_plausible && !(r.levels.back().est_error <= max_finest_error)) {
    std::snprintf(buf, sizeof buf, "finest level's estimated error %.3g above %.3g",
                  r.levels.back().est_error, max_finest_error);
    add(buf);
  }
  return why;
}

PressLoad smooth_press_load(const mesh::Positions& V, const mesh::Faces& F,
                            const Eigen::Vector3d& point, const Eigen::Vector3d& direction,
                            double force, double radius) {
  // Degree-4 rule (Dunavant 1985, 6 points): barycentric (a, a, 1-2a) and permutations.
  static constexpr double kA[2] = {0.445948490915965, 0.091576213509771};
  static constexpr double kW[2] = {0.223381589678011, 0.109951743655322};
  PressLoad out;
  out.f = Eigen::VectorXd::Zero(3 * V.rows());
  Eigen::VectorXd w = Eigen::VectorXd::Zero(V.rows());
  const double a2 = radius * radius;
  for (long k = 0; k < F.rows(); ++k) {
    const Eigen::Vector3d a = mesh::row3(V, F(k, 0)), b = mesh::row3(V, F(k, 1)),
                          c = mesh::row3(V, F(k, 2));
    const double reach = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()});
    if ((a - point).norm() > radius + reach) continue;
    const double ak = 0.5 * (b - a).cross(c - a).norm();
    // n x n sub-triangles of edge <= radius / 8: the profile is a quartic on a flat face
    // (exact for the rule) except across the rim r = a, where it is only C1; sub-triangles
    // that may straddle the rim are split 1 -> 4 recursively (depth 6) so the rim error is far
    // below the discretisation error (flat face: relative error < 1e-6, tests/fem).
    const int n = std::max(2, static_cast<int>(std::ceil(8 * reach / radius)));
    bool in = false;
    const auto at = [&](const Eigen::Vector2d& st) {
      return a + st[0] * (b - a) + st[1] * (c - a);
    };
    // One sub-triangle with face coordinates (s, t) of its corners; area `sub` (m^2).
    std::function<void(const Eigen::Vector2d&, const Eigen::Vector2d&, const Eigen::Vector2d&,
                       double, int)>
        tri = [&](const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, const Eigen::Vector2d& p2,
                  double sub, int depth) {
          const Eigen::Vector3d x0 = at(p0), x1 = at(p1), x2 = at(p2);
          const double d0 = (x0 - point).norm(), d1 = (x1 - point).norm(), d2 = (x2 - point).norm();
          const double diam = std::max({(x1 - x0).norm(), (x2 - x0).norm(), (x2 - x1).norm()});
          if (std::min({d0, d1, d2}) - diam >= radius) return;        // wholly outside
          if (depth < 6 && std::max({d0, d1, d2}) + diam > radius) {  // may straddle the rim
            const Eigen::Vector2d m01 = 0.5 * (p0 + p1), m02 = 0.5 * (p0 + p2),
                                  m12 = 0.5 * (p1 + p2);
            tri(p0, m01, m02, sub / 4, depth + 1);
            tri(m01, p1, m12, sub / 4, depth + 1);
            tri(m02, m12, p2, sub / 4, depth + 1);
            tri(m01, m12, m02, sub / 4, depth + 1);
            return;
          }
          for (int g = 0; g < 2; ++g)
            for (int perm = 0; perm < 3; ++perm) {
              double l[3] = {kA[g], kA[g], kA[g]};
              l[perm] = 1 - 2 * kA[g];
              const Eigen::Vector2d st = l[0] * p0 + l[1] * p1 + l[2] * p2;
              const double rr = (at(st) - point).squaredNorm() / a2;
              if (rr >= 1) continue;
              const double pw = (1 - rr) * (1 - rr) * kW[g] * sub;
              w[F(k, 0)] += pw * (1 - st[0] - st[1]);
              w[F(k, 1)] += pw * st[0];
              w[F(k, 2)] += pw * st[1];
              out.profile_integral += pw;
              in = true;
            }
        };
    const double h = 1.0 / n, sub = ak / (n * n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        tri({i * h, j * h}, {(i + 1) * h, j * h}, {i * h, (j + 1) * h}, sub, 0);
        if (i + j < n - 1)
          tri({(i + 1) * h, j * h}, {(i + 1) * h, (j + 1) * h}, {i * h, (j + 1) * h}, sub, 0);
      }
    if (in) out.patch_area += ak;
  }
  if (!(out.profile_integral > 0))
    throw InputError("fem reference: no surface within the press radius of the point");
  const Eigen::Vector3d dir = direction.normalized();
  for (long i = 0; i < V.rows(); ++i)
    if (w[i] > 0) out.f.segment<3>(3 * i) = force * dir * (w[i] / out.profile_integral);
  return out;
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
  o.base = m;
  o.base_surface_nodes = std::move(verts);
  return o;
}

namespace {

// Quasi-static ramp of the dead load f (total force `force`) to the loads force k / steps,
// k = 1..max_points, on the co-rotational FEM (plus the linear foundation `support`, 3#V
// diagonal), from rest. ss is the factorised linear K (with the foundation) of the same
// constraints: modified Newton on it (or on the last exact tangent once one was needed), then
// full Newton with the exact co-rotational tangent and a backtracking line search when that
// stalls. A load step that does not converge is retried as two half steps, recursively, down to
// 1 / 2^opt.curve_bisections of a step; below that the ramp stops and the level's curve ends at
// the last converged load (lv.curve_failure says why). The tangents are factorised with ss's
// kind (CHOLMOD on the large levels): with the default LDL^T a 107k-dof level spent 85 % of a
// 4 N curve's CPU in SimplicialLDLT factorisations (perf, docs/ARCHITECTURE.md).
// The smallest volume ratio det F = det[x1-x0, x2-x0, x3-x0] / det[X1-X0, ...] over the tets
// at positions x (3#V), and the number of tets with det F <= 0 (inverted) in `inverted`.
double min_det_f(const FemSystem& sys, const Eigen::VectorXd& x, long& inverted) {
  double m = std::numeric_limits<double>::infinity();
  inverted = 0;
  for (long t = 0; t < sys.T.rows(); ++t) {
    Eigen::Matrix3d Ds, Dm;
    for (int j = 0; j < 3; ++j) {
      Ds.col(j) = x.segment<3>(3 * sys.T(t, j + 1)) - x.segment<3>(3 * sys.T(t, 0));
      Dm.col(j) = (sys.X0.row(sys.T(t, j + 1)) - sys.X0.row(sys.T(t, 0))).transpose();
    }
    const double j = Ds.determinant() / Dm.determinant();
    m = std::min(m, j);
    if (!(j > 0)) ++inverted;
  }
  return m;
}

void quasi_static_curve(const FemSystem& sys, const StaticSolver& ss,
                        const Eigen::VectorXd& support, const Eigen::VectorXd& f,
                        const FemReferenceOptions& opt, int max_points, FemReferenceLevel& lv) {
  const auto t0 = std::chrono::steady_clock::now();
  const double force = opt.force, tol = opt.curve_tolerance;
  const int steps = opt.curve_steps;
  const Eigen::VectorXd X0 = flatten(sys.X0);
  const std::vector<int>& fixed = ss.split.fixed;
  std::vector<std::uint8_t> fixed_dof(static_cast<size_t>(sys.dofs()), 0);
  for (int d : fixed) fixed_dof[static_cast<size_t>(d)] = 1;
  Eigen::VectorXd u = Eigen::VectorXd::Zero(sys.dofs()), fint, r;
  std::vector<Matrix12d> Ke_t;
  SparseMatrixd K_t;
  const auto residual_at = [&](const Eigen::VectorXd& uu, const Eigen::VectorXd& fk,
                               Eigen::VectorXd& rr) {
    corotational_forces(sys, X0 + uu, fint, nullptr, opt.curve_material);
    rr = fk + fint - support.cwiseProduct(uu);
    for (int d : fixed) rr[d] = 0;
    const double n = rr.norm();
    return std::isfinite(n) ? n : std::numeric_limits<double>::infinity();
  };
  // The exact tangent at u, factorised into st (with ss's kind; LDL^T when CHOLMOD refuses an
  // indefinite tangent). Returns its negative pivots (the inertia of K_ff by Sylvester's law:
  // 0 for a CHOLMOD factor, which exists only for a positive definite matrix), or -1 when the
  // tangent is singular (no factor).
  const auto tangent = [&](StaticSolver& st) -> long {
    corotational_stiffness(sys, X0 + u, CorotJacobian::exact, Ke_t, K_t, nullptr,
                           opt.curve_material);
    for (long d = 0; d < support.size(); ++d)
      if (support[d] != 0) K_t.coeffRef(d, d) += support[d];
    // CHOLMOD's LL^T needs a positive definite matrix; the exact co-rotational tangent can be
    // indefinite under a large load (the 4 N body press), where LDL^T still factorises it.
    try {
      static_precompute(K_t, fixed_dof, st, ss.kind);
    } catch (const std::runtime_error&) {
      if (ss.kind == SparseSolverKind::ldlt) return -1;  // a (near) zero pivot: singular
      try {
        static_precompute(K_t, fixed_dof, st, SparseSolverKind::ldlt);
      } catch (const std::runtime_error&) {
        return -1;  // a (near) zero pivot: singular tangent
      }
    }
    if (st.kind != SparseSolverKind::ldlt) return 0;
    const Eigen::VectorXd dd = st.ldlt.vectorD();
    return static_cast<long>((dd.array() < 0).count());
  };
  // Converged: residual below tol x the load's force, or the update below tol x max |u|, or
  // the residual at its round-off floor (eps |K| |x| from forces computed on positions; it no
  // longer decreases and is below 1e-6 of the load's force).
  const auto converged = [&](const Eigen::VectorXd& du, double res, double prev, double scale) {
    return res <= tol * scale * force ||
           du.cwiseAbs().maxCoeff() <= tol * u.cwiseAbs().maxCoeff() ||
           (res >= prev && res <= 1e-6 * scale * force);
  };
  StaticSolver st;               // the last exact tangent, factorised
  const StaticSolver* mn = &ss;  // the matrix of the modified Newton iterations
  long last_negative = 0;        // negative pivots of the last tangent factorised
  bool any_indefinite = false;   // of the current attempt's tangents
  // Equilibrium at load fraction `scale` from the current u. Returns whether it converged; the
  // iterations are added to `it`, the final residual left in `res`.
  const auto equilibrate = [&](double scale, int& it, double& res) {
    const Eigen::VectorXd fk = scale * f;
    res = residual_at(u, fk, r);
    bool done = res <= tol * scale * force;
    // Modified Newton: linear convergence at the rate of |1 - K^-1 K_t|, cheap (one
    // back-substitution per iteration); left for the full Newton when it contracts too slowly.
    // A step that leaves the material's domain (an inverted tet of the neo-Hookean solid: its
    // residual is inf) is undone first, so the full Newton starts from the last finite iterate.
    for (double prev = res; !done && it < 200;) {
      const Eigen::VectorXd du = static_solve(*mn, r);
      u += du;
      ++it;
      prev = res;
      res = residual_at(u, fk, r);
      done = converged(du, res, prev, scale);
      if (!done && !(res <= 0.9 * prev)) {
        if (!std::isfinite(res)) {
          u -= du;
          res = residual_at(u, fk, r);
        }
        break;
      }
    }
    Eigen::VectorXd r_try;
    for (int newton = 0; !done && newton < opt.curve_max_newton; ++newton, ++it) {
      if (!std::isfinite(res)) return false;
      last_negative = tangent(st);
      if (last_negative < 0) return false;
      any_indefinite = any_indefinite || last_negative > 0;
      mn = &st;  // the latest tangent drives the modified Newton of the next loads
      const Eigen::VectorXd du = static_solve(st, r);
      // Backtracking line search on |r|: the full step unless it does not decrease the
      // residual, else the best of the halved steps (down to 1/32); the full step when none
      // does better (Newton may need to climb out of a region where |r| is not convex).
      double alpha = 1, best_alpha = 1;
      double res_try = residual_at(u + du, fk, r_try), best = res_try;
      for (int h = 0; h < opt.curve_line_search && !(res_try < res); ++h) {
        alpha *= 0.5;
        res_try = residual_at(u + alpha * du, fk, r_try);
        if (res_try < best) {
          best = res_try;
          best_alpha = alpha;
        }
      }
      if (!std::isfinite(best)) {  // every trial step leaves the material's domain
        ++it;
        return false;
      }
      const Eigen::VectorXd step = best_alpha * du;
      u += step;
      const double prev = res;
      res = residual_at(u, fk, r);
      done = converged(step, res, prev, scale);
      if (best_alpha < 1) ++lv.curve_line_searches;
    }
    return done;
  };
  Eigen::VectorXd u_try_end;  // the last iterate of the last failed attempt
  double lambda = 0;          // the last converged load fraction
  const double dl0 = 1.0 / steps, dl_min = dl0 / std::pow(2.0, opt.curve_bisections);
  for (int k = 1; k <= max_points; ++k) {
    const double target = static_cast<double>(k) / steps;
    double dl = target - lambda;
    int it = 0, sub = 0;
    while (lambda < target) {
      // The step's own load exactly when it is reached (as without bisection: F_k = F k/steps).
      const double scale = lambda + dl >= target * (1 - 1e-12) ? target : lambda + dl;
      const Eigen::VectorXd u_prev = u;
      double res = 0;
      any_indefinite = false;
      int it_try = 0;
      if (equilibrate(scale, it_try, res)) {
        it += it_try;
        ++sub;
        lambda = scale;
        lv.curve_path.push_back({force * lambda, f.dot(u) / force});
        dl = std::min(2 * dl, dl0);  // grow back after a bisected sub-step
        continue;
      }
      it += it_try;
      // Not converged: restore the last equilibrium and halve the increment (modified Newton
      // on the linear K again: st holds a tangent of the failed attempt's last iterate).
      u_try_end = u;
      u = u_prev;
      mn = &ss;
      if (dl * 0.5 >= dl_min * (1 - 1e-12)) {
        dl *= 0.5;
        ++lv.curve_bisections;
        continue;
      }
      FemCurveFailure& fl = lv.curve_failure;
      fl.failed = true;
      fl.step = k;
      fl.force = force * scale;
      fl.last_converged_force = force * lambda;
      fl.substep_force = force * dl;
      fl.residual = res;
      fl.iterations = it_try;
      fl.tangent_indefinite = any_indefinite || last_negative > 0;
      fl.negative_pivots = last_negative;
      {
        long inv = 0;
        fl.min_det_f = min_det_f(sys, X0 + u_try_end, inv);
        fl.inverted_tets = inv;
        fl.converged_min_det_f = min_det_f(sys, X0 + u, inv);
      }
      // The inertia of the tangent at the last converged equilibrium: negative pivots there
      // mean the path already passed a limit or bifurcation point (unstable equilibrium); none
      // means the load cannot be raised by dl from a stable state (a limit point within dl, or
      // a Newton failure).
      if (lambda > 0) {
        StaticSolver sc;
        corotational_stiffness(sys, X0 + u, CorotJacobian::exact, Ke_t, K_t, nullptr,
                               opt.curve_material);
        for (long d = 0; d < support.size(); ++d)
          if (support[d] != 0) K_t.coeffRef(d, d) += support[d];
        const std::vector<double> margin = ellipticity_margin(sys, X0 + u, opt.curve_material);
        fl.non_elliptic_tets = static_cast<long>(
            std::count_if(margin.begin(), margin.end(), [](double v) { return v <= 0; }));
        fl.min_ellipticity_margin = *std::min_element(margin.begin(), margin.end());
        try {
          static_precompute(K_t, fixed_dof, sc, SparseSolverKind::ldlt);
          const Eigen::VectorXd dd = sc.ldlt.vectorD();
          fl.converged_negative_pivots = static_cast<long>((dd.array() < 0).count());
          // The tangent's eigenvalues nearest zero and the first mode (fem_stability.hpp).
          const LowestModes lm = lowest_modes(sc, 3);
          fl.eigenvalues.assign(lm.values.data(), lm.values.data() + lm.values.size());
          fl.eigen_residual = lm.residual;
          if (lm.vectors.cols() > 0) {
            Eigen::VectorXd phi = Eigen::VectorXd::Zero(sys.dofs());
            scatter(lm.vectors.col(0), sc.split.free, phi);
            const Eigen::VectorXd phif = lm.vectors.col(0);
            fl.mode_linear_stiffness = phif.dot(ss.K_ff * phif);
            const ModeShape ms = mode_shape(sys, phi, f, opt.press_point, opt.press_radius, margin);
            fl.mode_load_cosine = ms.load_cosine;
            fl.mode_max_distance = ms.max_node_distance;
            fl.mode_near_press = ms.near_press_fraction;
            fl.mode_participation = ms.participation;
            fl.mode_non_elliptic = ms.non_elliptic_fraction;
          }
        } catch (const std::runtime_error&) {
          fl.converged_negative_pivots = -1;
        }
      }
      break;
    }
    if (lv.curve_failure.failed) break;
    lv.curve_displacement.push_back(f.dot(u) / force);
    {
      const std::vector<double> margin = ellipticity_margin(sys, X0 + u, opt.curve_material);
      lv.curve_non_elliptic.push_back(static_cast<long>(
          std::count_if(margin.begin(), margin.end(), [](double v) { return v <= 0; })));
    }
    lv.curve_iterations.push_back(it);
    lv.curve_substeps.push_back(sub);
  }
  lv.curve_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

namespace {

// Preconditioned CG on a nested level with the two-level additive preconditioner
//   M^-1 r = P K_c^-1 P^T r + D^-1 r
// (P: the exact prolongation of the coarser nested level's free dofs, K_c: that level's
// factorised K_ff, D: the diagonal of K_ff). Nested spaces make P^T K P = K_c, so the coarse
// part removes the smooth error that Jacobi-PCG needs thousands of iterations for; the
// iteration count then stays bounded under refinement (h ratio 2). Returns the iterations;
// x holds the start on entry.
long pcg_two_level(const SparseMatrixd& A, const Eigen::VectorXd& b, Eigen::VectorXd& x, double tol,
                   long max_it, const StaticSolver& coarse, long coarse_nodes,
                   const std::vector<std::array<int, 2>>& parent, const DofSplit& fine) {
  const Eigen::VectorXd inv_diag = A.diagonal().cwiseInverse();
  Eigen::VectorXd full = Eigen::VectorXd::Zero(3 * static_cast<long>(parent.size()));
  Eigen::VectorXd rc = Eigen::VectorXd::Zero(3 * coarse_nodes);
  const auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) {
    full.setZero();
    scatter(r, fine.free, full);
    rc.setZero();
    for (size_t i = 0; i < parent.size(); ++i) {
      const Eigen::Vector3d ri = 0.5 * full.segment<3>(3 * static_cast<long>(i));
      rc.segment<3>(3 * parent[i][0]) += ri;
      rc.segment<3>(3 * parent[i][1]) += ri;
    }
    const Eigen::VectorXd zc_free = coarse.solve_free(gather(rc, coarse.split.free));
    rc.setZero();
    scatter(zc_free, coarse.split.free, rc);
    z = gather(prolongate(parent, rc), fine.free) + inv_diag.cwiseProduct(r);
  };
  Eigen::VectorXd r = b - A * x, z, p, Ap;
  const double bnorm = b.norm();
  if (!(bnorm > 0)) {
    x.setZero();
    return 0;
  }
  precondition(r, z);
  p = z;
  double rz = r.dot(z);
  long it = 0;
  while (r.norm() > tol * bnorm) {
    if (it >= max_it) return -1;
    Ap = A * p;
    const double alpha = rz / p.dot(Ap);
    x += alpha * p;
    r -= alpha * Ap;
    ++it;
    precondition(r, z);
    const double rz_new = r.dot(z);
    p = z + (rz_new / rz) * p;
    rz = rz_new;
  }
  return it;
}

}  // namespace

ReferenceLevelBuilder::ReferenceLevelBuilder(const FemReferenceOptions& opt) : opt_(opt) {
  nested_ = !opt.mesher && opt.refinement == FemRefinement::nested;
  have_base_ = nested_ && opt.base.T.rows() > 0 && opt.grade_rounds == 0;
}

const ReferenceLevelSystem& ReferenceLevelBuilder::next() {
  const FemReferenceOptions& opt = opt_;
  const int l = level_++;
  mesh::TetOptions to;
  to.max_volume = opt.max_volume / std::pow(2.0, l);
  to.quality = opt.quality;
  to.keep_surface = false;  // uniform refinement includes the surface
  to.seeds = opt.seeds;
  to.default_attribute = opt.default_attribute;
  ReferenceLevelSystem& ls = cur_;
  ls.level = l;
  ls.parent.clear();
  if (opt.mesher) {
    ls.mesh = opt.mesher(l);
  } else if (!nested_) {
    ls.mesh = mesh::tetrahedralize(opt.surface, to);
  } else if (l == 0 && opt.grade_rounds > 0) {
    const double radius = opt.grade_radius > 0 ? opt.grade_radius : 3 * opt.press_radius;
    ls.mesh = mesh::tetrahedralize(
        refine_surface_near(opt.surface, opt.press_point, radius, opt.grade_rounds), to);
  } else if (l == 0) {
    ls.mesh = have_base_ ? opt.base : mesh::tetrahedralize(opt.surface, to);
  } else {
    RedRefinement rr = refine_red(ls.mesh);
    ls.mesh = std::move(rr.mesh);
    ls.parent = std::move(rr.parent);
  }
  const mesh::TetMesh& m = ls.mesh;
  if (!opt.mesher && m.V.rows() < opt.surface.V.rows())
    throw InputError("fem reference: a level lost surface vertices");
  const TetMaterials mat = tet_materials(m, opt.materials);
  ls.sys = fem_precompute(m.V, m.T, mat);
  std::vector<std::uint8_t> fixed = rigid_nodes(m, mat);
  long nfixed = 0;
  for (long i = 0; i < m.V.rows(); ++i) {
    if (!ls.parent.empty())  // nested: the Dirichlet set of level 0, refined
      fixed[i] = fixed[i] || (fixed_prev_[ls.parent[i][0]] && fixed_prev_[ls.parent[i][1]]);
    else
      fixed[i] = fixed[i] || opt.is_fixed(mesh::row3(m.V, i));
    nfixed += fixed[i];
  }
  if (nfixed == 0) throw InputError("fem reference: the fixed region contains no node");
  fixed_prev_ = fixed;
  ls.fixed_dof = node_to_dof_flags(fixed);
  // Press: the smooth pressure profile as the consistent load (smooth_press_load): the load
  // functional is (to quadrature accuracy) the same at every level, so on nested levels the
  // compliance grows monotonically and the differences are discretisation error only.
  ls.bf = mesh::boundary_faces(m);
  ls.load = smooth_press_load(m.V, ls.bf.F, opt.press_point, opt.press_direction, opt.force,
                              opt.press_radius);
  ls.K = ls.sys.K;
  ls.support = Eigen::VectorXd::Zero(ls.sys.dofs());
  if (opt.support_modulus > 0) {
    const mesh::Faces& F = ls.bf.F;
    for (long k = 0; k < F.rows(); ++k) {
      const Eigen::Vector3d a = mesh::row3(m.V, F(k, 0)), b = mesh::row3(m.V, F(k, 1)),
                            c = mesh::row3(m.V, F(k, 2));
      const double share = opt.support_modulus * (b - a).cross(c - a).norm() / 6;
      for (int j = 0; j < 3; ++j) ls.support.segment<3>(3 * F(k, j)).array() += share;
    }
    for (long d = 0; d < ls.sys.dofs(); ++d)  // the diagonal is in the pattern: no insertion
      ls.K.coeffRef(d, d) += ls.support[d];
  }
  return ls;
}

Eigen::VectorXd prolongate(const std::vector<std::array<int, 2>>& parent,
                           const Eigen::VectorXd& u_coarse) {
  Eigen::VectorXd u(3 * static_cast<long>(parent.size()));
  for (size_t i = 0; i < parent.size(); ++i)
    u.segment<3>(3 * static_cast<long>(i)) =
        0.5 * (u_coarse.segment<3>(3 * parent[i][0]) + u_coarse.segment<3>(3 * parent[i][1]));
  return u;
}

FemAutoGradeResult fem_reference_auto_grade(FemReferenceOptions opt, int max_rounds,
                                            double max_finest_error) {
  if (opt.mesher || opt.refinement != FemRefinement::nested)
    throw InputError("fem reference: automatic grading needs nested levels");
  if (max_rounds < 0 || max_rounds > 6 || !(max_finest_error > 0))
    throw InputError(
        "fem reference: automatic grading needs 0 to 6 rounds at most and an error bound > 0");
  FemAutoGradeResult out;
  const int start = std::min(std::max(opt.grade_rounds, auto_grade_rounds(opt)), max_rounds);
  for (int g = start; g <= max_rounds; ++g) {
    const auto t0 = std::chrono::steady_clock::now();
    opt.grade_rounds = g;
    FemReferenceResult r = fem_reference(opt);
    FemGradeAttempt at;
    at.rounds = g;
    at.finest_tets = r.levels.back().tets;
    at.finest_error = r.levels.back().est_error;
    at.reason = reference_untrusted_reason(r, max_finest_error);
    at.trusted = at.reason.empty();
    at.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.attempts.push_back(at);
    out.result = std::move(r);
    out.rounds = g;
    if (at.trusted) break;
  }
  return out;
}

FemReferenceResult fem_reference(const FemReferenceOptions& opt) {
  if (opt.levels < 3) throw InputError("fem reference: --levels must be >= 3");
  const bool nested = !opt.mesher && opt.refinement == FemRefinement::nested;
  const bool have_base = nested && opt.base.T.rows() > 0 && opt.grade_rounds == 0;
  if (opt.grade_rounds < 0 || opt.grade_rounds > 6 || !(opt.grade_radius >= 0))
    throw InputError("fem reference: grading rounds must be 0 to 6 and the radius >= 0 m");
  if (!opt.mesher && !have_base && !(opt.max_volume > 0))
    throw InputError("fem reference: max_volume must be > 0");
  if (!(opt.force > 0)) throw InputError("fem reference: --force must be > 0 N");
  if (!(opt.press_radius > 0)) throw InputError("fem reference: press radius must be > 0 m");
  if (!opt.is_fixed) throw InputError("fem reference: no fixed (pinned) region given");
  if (!(opt.support_modulus >= 0))
    throw InputError("fem reference: support modulus must be >= 0 N/m^3");
  if (opt.curve_steps < 0 || !(opt.curve_tolerance > 0))
    throw InputError("fem reference: curve steps must be >= 0 and the tolerance > 0");
  if (opt.curve_max_newton < 0 || opt.curve_bisections < 0 || opt.curve_bisections > 20 ||
      opt.curve_line_search < 0 || opt.curve_line_search > 20)
    throw InputError(
        "fem reference: curve Newton iterations must be >= 0, bisections and line-search halvings "
        "0 to 20");
  if (opt.pcg_min_dofs < 0 || !(opt.pcg_tolerance > 0 && opt.pcg_tolerance < 1))
    throw InputError("fem reference: PCG threshold must be >= 0 and its tolerance in (0, 1)");
  if (opt.pcg_min_dofs > 0 && opt.curve_steps > 0)
    throw InputError(
        "fem reference: the PCG solver is for static references only (the quasi-static curve "
        "reuses a factorisation): use --steps 0 or a direct solver");
  const long ns = opt.surface.V.rows();
  // Node of each surface vertex in every level's mesh (TetGen and nested keep them).
  std::vector<int> surface_node(static_cast<size_t>(ns));
  for (long i = 0; i < ns; ++i) surface_node[i] = static_cast<int>(i);
  if (have_base) {
    if (static_cast<long>(opt.base_surface_nodes.size()) != ns)
      throw InputError("fem reference: base_surface_nodes must have one node per surface vertex");
    for (long i = 0; i < ns; ++i) {
      const int v = opt.base_surface_nodes[i];
      if (v < 0 || v >= opt.base.V.rows())
        throw InputError("fem reference: base_surface_nodes out of range");
      surface_node[i] = v;
    }
  }
  FemReferenceResult res;
  std::vector<Eigen::VectorXd> surface_u;
  ReferenceLevelBuilder builder(opt);
  Eigen::VectorXd u_prev;    // the previous level's solution (PCG's start on nested levels)
  long fixed_prev_size = 0;  // its node count
  // The previous level's factor (the PCG's coarse correction), if any (StaticSolver is not
  // movable: held by pointer).
  std::unique_ptr<StaticSolver> ss_prev;
  int curve_points = opt.curve_steps;  // the loads every level so far reached
  for (int l = 0; l < opt.levels; ++l) {
    const auto t0 = std::chrono::steady_clock::now();
    const ReferenceLevelSystem& ls = builder.next();
    const mesh::TetMesh& m = ls.mesh;
    const FemSystem& sys = ls.sys;
    const SparseMatrixd& K = ls.K;
    const Eigen::VectorXd& f = ls.load.f;
    const Eigen::VectorXd& support = ls.support;
    const mesh::BoundaryFaces& bf = ls.bf;
    const PressLoad& load = ls.load;
    FemReferenceLevel lv;
    auto ss_ptr = std::make_unique<StaticSolver>();
    StaticSolver& ss = *ss_ptr;
    Eigen::VectorXd u;
    const long free_dofs =
        static_cast<long>(std::count(ls.fixed_dof.begin(), ls.fixed_dof.end(), std::uint8_t{0}));
    const bool nested_prev =
        !ls.parent.empty() && u_prev.size() == 3 * static_cast<long>(fixed_prev_size);
    if (opt.pcg_min_dofs > 0 && free_dofs >= opt.pcg_min_dofs && l == opt.levels - 1 &&
        nested_prev && ss_prev) {
      // The finest nested level: PCG with the coarser level's factor as coarse correction
      // (pcg_two_level), from the coarser level's solution prolongated.
      const auto ts = std::chrono::steady_clock::now();
      ss.split = split_dofs(ls.fixed_dof);
      const SparseMatrixd Kff = submatrix(K, ss.split.free, ss.split.free);
      const Eigen::VectorXd b = gather(f, ss.split.free);
      Eigen::VectorXd x = gather(prolongate(ls.parent, u_prev), ss.split.free);
      lv.factor_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ts).count();
      const long it = pcg_two_level(Kff, b, x, opt.pcg_tolerance, 100000, *ss_prev, fixed_prev_size,
                                    ls.parent, ss.split);
      if (it < 0)
        throw std::runtime_error("fem reference: PCG on level " + std::to_string(l) +
                                 " did not reach the relative residual " +
                                 std::to_string(opt.pcg_tolerance));
      u = Eigen::VectorXd::Zero(f.size());
      scatter(x, ss.split.free, u);
      lv.solver = "pcg-two-level";
      lv.pcg_iterations = it;
    } else if (opt.pcg_min_dofs > 0 && free_dofs >= opt.pcg_min_dofs && l == opt.levels - 1) {
      // One solve, no factor: Jacobi-PCG from the coarser level's solution (nested spaces:
      // prolongation is exact interpolation, so the start is the coarse FE function).
      const auto ts = std::chrono::steady_clock::now();
      ss.split = split_dofs(ls.fixed_dof);
      const SparseMatrixd Kff = submatrix(K, ss.split.free, ss.split.free);
      const Eigen::VectorXd b = gather(f, ss.split.free);
      Eigen::VectorXd x0 = Eigen::VectorXd::Zero(b.size());
      if (nested_prev) x0 = gather(prolongate(ls.parent, u_prev), ss.split.free);
      Eigen::ConjugateGradient<SparseMatrixd, Eigen::Lower | Eigen::Upper,
                               Eigen::DiagonalPreconditioner<double>>
          cg;
      cg.setTolerance(opt.pcg_tolerance);
      cg.setMaxIterations(std::max<long>(100000, 10 * b.size() / 100));
      cg.compute(Kff);
      lv.factor_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ts).count();
      const Eigen::VectorXd x = cg.solveWithGuess(b, x0);
      if (cg.info() != Eigen::Success)
        throw std::runtime_error("fem reference: PCG on level " + std::to_string(l) +
                                 " did not reach the relative residual " +
                                 std::to_string(opt.pcg_tolerance) + " in " +
                                 std::to_string(cg.iterations()) + " iterations");
      u = Eigen::VectorXd::Zero(f.size());
      scatter(x, ss.split.free, u);
      lv.solver = "pcg-jacobi";
      lv.pcg_iterations = static_cast<long>(cg.iterations());
    } else {
      static_precompute(K, ls.fixed_dof, ss, opt.solver);
      u = static_solve(ss, f);
      lv.solver = to_string(ss.kind);
      lv.factor_ms = ss.factor_ms;
      lv.factor_mb = 8e-6 * ss.factor_nnz;
    }
    u_prev = u;
    fixed_prev_size = m.V.rows();
    const double delta = f.dot(u) / opt.force;  // work-conjugate contact displacement
    lv.max_volume = opt.mesher ? 0.0 : m.volume.maxCoeff();
    if (!opt.mesher && !nested) lv.max_volume = opt.max_volume / std::pow(2.0, l);
    lv.nodes = m.V.rows();
    lv.tets = m.T.rows();
    lv.dofs = free_dofs;
    lv.patch_area = load.patch_area;
    lv.press_h = loaded_edge(m.V, bf.F, f);
    lv.mesh_size = std::cbrt(m.volume.sum() / static_cast<double>(m.T.rows()));
    lv.displacement = delta;
    lv.stiffness = opt.force / delta;
    lv.solve_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    // The curve of a level goes at most as far as those of the coarser levels (a partial curve
    // is extrapolated over the loads every level reached).
    if (opt.curve_steps > 0 && curve_points > 0) {
      quasi_static_curve(sys, ss, support, f, opt, curve_points, lv);
      if (lv.curve_failure.failed && !res.curve_failure.failed) {
        res.curve_failure = lv.curve_failure;
        res.curve_failure_level = l;
      }
      curve_points = static_cast<int>(lv.curve_displacement.size());
    }
    // Kept for the next level's PCG coarse correction (none after a PCG level: no factor).
    ss_prev.reset();
    if (opt.pcg_min_dofs > 0 && lv.solver.rfind("pcg", 0) != 0) ss_prev = std::move(ss_ptr);
    res.levels.push_back(std::move(lv));
    if (!opt.mesher) {
      Eigen::VectorXd us(3 * ns);
      for (long i = 0; i < ns; ++i) us.segment<3>(3 * i) = u.segment<3>(3 * surface_node[i]);
      surface_u.push_back(std::move(us));
    }
  }
  const int L = opt.levels;
  const double q[3] = {res.levels[L - 3].stiffness, res.levels[L - 2].stiffness,
                       res.levels[L - 1].stiffness};
  double r = opt.refinement_ratio;
  if (opt.mesher || nested) {
    if (nested) r = 2;
    if (!(r > 1)) r = std::cbrt(2.0);
    richardson(q[0], q[1], q[2], r, res.observed_order, res.stiffness);
  } else {
    const double h[3] = {res.levels[L - 3].mesh_size, res.levels[L - 2].mesh_size,
                         res.levels[L - 1].mesh_size};
    richardson_sizes(q, h, res.observed_order, res.stiffness);
    r = h[1] / h[2];  // for the field: the last pair
  }
  res.refinement_ratio = r;
  res.press_radius = opt.press_radius;
  res.displacement = opt.force / res.stiffness;
  res.order_plausible =
      res.observed_order >= kPlausibleOrder[0] && res.observed_order <= kPlausibleOrder[1];
  // Field and curve: the same order, vertex by vertex / point by point (a per-vertex order
  // would be noise); unextrapolated (finest level) when the order is not plausible.
  const double p = std::isfinite(res.observed_order) ? res.observed_order : 1.0;
  const double factor = res.order_plausible ? 1 / (std::pow(r, p) - 1) : 0.0;
  Eigen::VectorXd uf;
  double umax = 1;
  if (!surface_u.empty()) {
    uf = surface_u[L - 1] + (surface_u[L - 1] - surface_u[L - 2]) * factor;
    res.field = unflatten(uf);
    umax = uf.cwiseAbs().maxCoeff();
  }
  res.curve_complete = curve_points == opt.curve_steps;
  for (int k = 0; k < curve_points; ++k) {
    FemCurvePoint c;
    c.force = opt.force * (k + 1) / opt.curve_steps;
    const double d2 = res.levels[L - 1].curve_displacement[k],
                 d1 = res.levels[L - 2].curve_displacement[k],
                 d0 = res.levels[L - 3].curve_displacement[k];
    // The point's own convergence: Richardson on its secant stiffness F/u on the three finest
    // levels (the quantity the static value extrapolates: compliance and stiffness have
    // different orders before the asymptotic range); extrapolated only when that order is
    // plausible too.
    double pk = std::nan(""), ext = c.force / d2;
    richardson(c.force / d0, c.force / d1, c.force / d2, r, pk, ext);
    c.observed_order = pk;
    c.extrapolated = res.order_plausible && pk >= kPlausibleOrder[0] && pk <= kPlausibleOrder[1];
    c.displacement = c.extrapolated ? c.force / ext : d2;
    c.linear_displacement = c.force / res.stiffness;
    c.secant_stiffness = c.force / c.displacement;
    res.curve.push_back(c);
  }
  res.monotone = true;
  for (int l = 0; l < L; ++l) {
    auto& lv = res.levels[l];
    lv.est_error = std::abs(lv.stiffness - res.stiffness) / std::abs(res.stiffness);
    if (!surface_u.empty()) lv.field_error = (surface_u[l] - uf).cwiseAbs().maxCoeff() / umax;
    if (l > 0) res.monotone = res.monotone && lv.est_error < res.levels[l - 1].est_error;
  }
  return res;
}

FemReferenceOptions reference_options_for_prototype(const SceneConfig& cfg, int surface_node,
                                                    double force) {
  const auto cm = scene_mesh(cfg.mesh);
  if (!cm->tet)
    throw InputError("prototype " + cfg.id +
                         ": the FEM reference needs a tetrahedral mesh (generator model_c or a tet "
                         "mesh file)",
                     cfg.source);
  const mesh::TetMesh tm = mesh::make_tet_mesh(cm->model_V, cm->model_T, cm->tet_attribute);
  FemReferenceOptions o = reference_options_from_mesh(tm, cm->surface_to_model.at(surface_node),
                                                      force, cfg.contact.patch_radius);
  o.support_modulus = cfg.support.modulus;  // the foundation of C and D
  const MaterialConfig& mc = cfg.material;
  for (auto& e : o.materials.materials) {
    if (o.default_attribute < e.first || o.default_attribute > e.last) continue;
    if (!mc.tissue.empty())
      for (const auto& n : mesh::default_materials().materials)
        if (n.name == mc.tissue) {
          e.youngs_modulus = n.youngs_modulus;
          e.poisson_ratio = n.poisson_ratio;
          e.density = n.density;
        }
    if (mc.youngs_modulus) e.youngs_modulus = *mc.youngs_modulus;
    if (mc.density) e.density = *mc.density;
  }
  const double z0 = cm->model_V.col(2).minCoeff(), zf = cfg.support.fixed_z_below;
  std::vector<Eigen::Vector3d> region_pts;
  if (!cfg.support.fixed_region.empty())
    for (size_t i = 0; i < cm->vertex_region.size(); ++i)
      if (cm->vertex_region[i] >= 0 &&
          cm->region_names[cm->vertex_region[i]] == cfg.support.fixed_region)
        region_pts.push_back(cm->V.row(static_cast<long>(i)).transpose());
  if (zf <= 0 && region_pts.empty())
    throw InputError("prototype " + cfg.id +
                         " pins no node (fixed_z_below / fixed_region): the static press has no "
                         "unique solution",
                     cfg.source);
  const double tol2 = 0.25 * cm->mean_edge * cm->mean_edge;
  o.is_fixed = [=](const Eigen::Vector3d& p) {
    if (zf > 0 && p.z() < z0 + zf) return true;
    for (const auto& q : region_pts)
      if ((p - q).squaredNorm() <= tol2) return true;
    return false;
  };
  return o;
}

}  // namespace palplab::engine
