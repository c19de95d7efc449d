// `palplab bench frontier`: speed against error of every prototype, against the converged FEM
// reference of the same physical problem (engine::fem_reference, the core of
// `palplab fem reference`).
//
// The problem. Prototype D's body (Model-C, prototypes/D.json): its tet mesh, E and nu of its
// tissue, its elastic foundation (support_modulus on the boundary, lumped by area), its pinned
// base (fixed_z_below), pressed with 1 N over a disc of contact.patch_radius at the node nearest
// the region's centroid, along the scene's inward normal there (reference_problem below: the
// rules of `palplab fem reference PROTOTYPE --press REGION`). Prototypes C, C1, C2 and their
// variants share that mesh, material and support exactly (checked: the section throws if not);
// A and B are surface models of the same tract shape (generate_tract, other tessellations):
// their press is at their node nearest the same point and their field is compared at their node
// nearest each reference vertex (a documented mapping, not the same mesh).
//
// The presses (the same device trajectory for every model of a region): from 2 mm outside, in
// along the inward normal at 2 cm/s, holding `hold` steps at four depths d_j = j (1/k_ref +
// 1/k_c) (k_c = 2000 N/m, the coupling of C and D), sized so that the reference with C's coupling
// would feel 1, 2, 3, 4 N. The errors are read at the end of each hold (quasi-static: the ramp's
// viscous force would otherwise be part of the "error"; metric settle_rel says how settled).
//
// (a) force-displacement curve error: RMS over the holds of c_model / c_ref - 1, c = contact
//     displacement per newton. The load shapes differ: the reference loads the smooth profile
//     s = (1 - (r/a)^2)^2, the models' flat probe face puts the force on the pad nodes by lumped
//     area (w). So the models' contact displacement is their surface displacement read with the
//     weights s (u_c = sum_v s_v u_v . dir) and the reference's is its field read with the pad
//     weights w (c_ref = sum_v w_v g_v . dir, g = the reference field per newton): by Maxwell-
//     Betti reciprocity both are the same mixed compliance s^T G w of a linear body, so the two
//     numbers describe the same problem exactly — the penalty penetration F / k_c of the device
//     coupling is not tissue displacement and is not counted (see felt_curve_rel_err).
//     A and B render the force by Hooke's law on the device's penetration of the rest surface
//     (B's rings show that penetration): their contact displacement is the device depth and
//     c_ref = 1 / k_ref (the reference's own work-conjugate compliance).
// (b) surface displacement-field error: RMS over the holds of the area-weighted relative L2
//     error sqrt(sum A_v |u_v - F g_v|^2 / sum A_v |F g_v|^2) over the reference's surface
//     vertices at rest distance >= 2 a from the press point. The loaded zone is left out because
//     the two load shapes (same resultant) differ there by design; beyond 2 a their difference
//     decays below ~2 % (Saint-Venant; the half-space estimate). A rigid model (A) has u = 0:
//     error 1 by definition.
// felt_curve_rel_err: RMS of depth_j k_ref / F_j - 1, what the hand feels against a rigid probe
// on the reference tissue (includes the coupling compliance 1/k_c).
//
// Controls in every run: a planted model with exactly 20 % too much compliance and field must
// show 0.2 on (a) and (b) (tests/cli_bench); the linear FEM on the coarsest reference level is
// placed with its own discretisation error (time = meshing (--quick: TetGen; full: none, level
// 0 is D's mesh) + assembly + one static solve).
//
// Trust: each region's reference carries engine::reference_untrusted_reason (ref_trusted, and
// the reason in the reference case's description and on stderr). An untrusted reference is not
// extrapolated (its finest level stands in) and its region is left out of the figures. Measured
// (docs/PERFORMANCE.md): the body press is not resolved on D's mesh — D's surface edges there
// are 12.9 mm against the 10 mm pad radius, so D's pad is one node (a point load) and the
// reference's first levels see a point load too: pre-asymptotic, whatever order they show.
//
// Time per haptic step: median and p99 over the contact steps of the timed presses (each step
// one repetition of the unit of work; models are interleaved press by press so that they see
// the same machine load; a model slower than 2 ms per step is timed on its measured press).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>

#include "analysis/svg.hpp"
#include "app/bench.hpp"
#include "app/bench_scene.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/haptics/scene_config.hpp"
#include "engine/models/fem_reference.hpp"
#include "engine/models/model.hpp"
#include "prototypes/factory.hpp"

namespace {
using namespace palplab;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;
using RowPositions = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// The reference of one region's press and what the error measures need of it.
struct Reference {
  int node = -1;           // press node (surface index of the C/D scenes = reference vertex)
  Eigen::Vector3d p, dir;  // press point, inward unit direction
  mesh::Positions surf;    // reference surface vertices (rest) = the C/D scene surface, m
  mesh::Positions g;       // displacement field per newton at those vertices (m/N)
  Eigen::VectorXd s, w;    // smooth-load and pad weights per surface vertex (sum 1)
  Eigen::VectorXd area;    // lumped area per surface vertex (m^2)
  std::vector<char> far;   // vertex used by the field error (rest distance >= 2 a)
  double k = 0;            // N/m, the reference's contact stiffness (1 / c_ss)
  double c_ws = 0;         // m/N, the pad-read compliance w^T g (= s^T G w)
  double order = 0, k0 = 0, k_finest = 0, level0_field = 0, level0_s = 0, total_s = 0;
  double field_scale = 1;
  bool extrapolated = false;
  bool nested = false;
  int grade_rounds = 0;   // rounds of surface grading around the press before level 0 (0: D's mesh)
  std::string untrusted;  // why the reference is not trusted ("" = trusted)
  double press_h0 = 0;    // m, mesh size under the press on the first extrapolation level
  double press_h_d = 0;   // m, the same on D's own mesh
  long finest_nodes = 0, finest_tets = 0;
};

double dot_dir(const Eigen::VectorXd& wt, const mesh::Positions& u, const Eigen::Vector3d& d) {
  double c = 0;
  for (long v = 0; v < wt.size(); ++v)
    if (wt[v] != 0) c += wt[v] * u.row(v).dot(d.transpose());
  return c;
}

// The smooth profile (1 - (r/a)^2)^2 around p as consistent nodal weights of the surface
// (V, F) — the 16-point sub-triangle rule of fem_reference — normalised to sum 1.
Eigen::VectorXd smooth_weights(const RowPositions& V, const Eigen::Matrix<int, -1, 3, 1>& F,
                               const Eigen::Vector3d& p, double a) {
  Eigen::VectorXd w = Eigen::VectorXd::Zero(V.rows());
  constexpr int kSub = 4;
  for (long f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d A = V.row(F(f, 0)).transpose(), B = V.row(F(f, 1)).transpose(),
                          C = V.row(F(f, 2)).transpose();
    const double ar = 0.5 * (B - A).cross(C - A).norm();
    const double reach = std::max({(B - A).norm(), (C - A).norm(), (C - B).norm()});
    if ((A - p).norm() > a + reach) continue;
    const auto add = [&](double s1, double t1) {
      const double rr = (A + s1 * (B - A) + t1 * (C - A) - p).norm() / a;
      if (rr >= 1) return;
      const double pw = (1 - rr * rr) * (1 - rr * rr) * ar / (kSub * kSub);
      w[F(f, 0)] += pw * (1 - s1 - t1);
      w[F(f, 1)] += pw * s1;
      w[F(f, 2)] += pw * t1;
    };
    for (int i = 0; i < kSub; ++i)
      for (int j = 0; i + j < kSub; ++j) {
        add((i + 1.0 / 3) / kSub, (j + 1.0 / 3) / kSub);
        if (i + j < kSub - 1) add((i + 2.0 / 3) / kSub, (j + 2.0 / 3) / kSub);
      }
  }
  return w / w.sum();
}

// The pad of the deformable models' probe face (mass_spring_model.cpp, fem_scene_model.cpp):
// surface nodes within radius a of the centre node (rest distance, reached through surface
// edges inside the disc), weighted by lumped area, normalised to sum 1.
Eigen::VectorXd pad_weights(const RowPositions& V, const Eigen::Matrix<int, -1, 3, 1>& F,
                            const Eigen::VectorXd& area, int center, double a) {
  std::vector<std::vector<int>> adj(V.rows());
  for (long f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      adj[F(f, k)].push_back(F(f, (k + 1) % 3));
      adj[F(f, (k + 1) % 3)].push_back(F(f, k));
    }
  Eigen::VectorXd w = Eigen::VectorXd::Zero(V.rows());
  std::vector<int> q{center};
  w[center] = area[center];
  for (size_t i = 0; i < q.size(); ++i)
    for (int j : adj[q[i]])
      if (w[j] == 0 && (V.row(j) - V.row(center)).norm() <= a) {
        w[j] = area[j];
        q.push_back(j);
      }
  return w / w.sum();
}

Eigen::VectorXd lumped_area(const RowPositions& V, const Eigen::Matrix<int, -1, 3, 1>& F) {
  Eigen::VectorXd a = Eigen::VectorXd::Zero(V.rows());
  for (long f = 0; f < F.rows(); ++f) {
    const double ar =
        0.5 * (V.row(F(f, 1)) - V.row(F(f, 0))).cross(V.row(F(f, 2)) - V.row(F(f, 0))).norm();
    for (int k = 0; k < 3; ++k) a[F(f, k)] += ar / 3;
  }
  return a;
}

// The two configurations describe the same body, material, support and pad (else the models
// and the reference would not be comparable, and the section says so by failing).
void check_same_problem(const engine::SceneConfig& ref, const engine::SceneConfig& c) {
  const auto E = [](const engine::SceneConfig& x) { return x.material.youngs_modulus.value_or(0); };
  if (ref.mesh.key() != c.mesh.key() || E(ref) != E(c) ||
      ref.material.tissue != c.material.tissue || ref.support.modulus != c.support.modulus ||
      ref.support.fixed_z_below != c.support.fixed_z_below ||
      ref.support.fixed_region != c.support.fixed_region ||
      ref.contact.patch_radius != c.contact.patch_radius ||
      ref.contact.stiffness != c.contact.stiffness)
    throw std::runtime_error("bench frontier: prototype " + c.id +
                             " no longer has prototype D's mesh, material, support and pad; the "
                             "frontier's reference would not describe it");
}

// The reference problem of `palplab fem reference D.json --press REGION` (the one rule set,
// engine::reference_options_for_prototype), direction = the scene's inward normal at the node.
Reference reference_for(const engine::Scene& d_scene, const std::string& region, bool quick) {
  const engine::SceneConfig& cfg = d_scene.config();
  const engine::SceneGeometry& g = d_scene.geometry();
  Reference ref;
  ref.node = g.region_node(region);
  ref.p = g.V.row(ref.node).transpose();
  ref.dir = -g.N.row(ref.node).transpose();
  const double a = cfg.contact.patch_radius;
  engine::FemReferenceOptions o = engine::reference_options_for_prototype(cfg, ref.node, 1.0);
  o.press_direction = ref.dir;
  o.levels = 3;
  // Full run: nested red refinements (the spaces are nested and the extrapolation's ratio is
  // exact, fem_reference.hpp) of D's own mesh where it resolves the press (9264 -> 74k -> 593k
  // tets), else of a level 0 graded around the press (below); the finest levels are factorised
  // by CHOLMOD (docs/PERFORMANCE.md "Solvers on the reference levels": the LDL^T needed
  // > 5.9 GB and > 9.7 CPU min there). --quick: a finest nested level of 593k tets does not fit
  // 3 minutes, so the quick run keeps three TetGen levels of D's surface (not nested, max
  // volume twice the prototype's mean, halved per level) and says whether they can be trusted.
  // The mesh size under the press on D's own mesh: where it exceeds the pad radius (the body:
  // 12.9 mm edges, one surface vertex within 1 cm) D's own mesh sees a point load and nested
  // levels of it cannot converge (reference_untrusted_reason).
  double h_d = 0;
  {
    const mesh::Positions V = g.V;
    const mesh::Faces F = g.F;
    const engine::PressLoad pl = engine::smooth_press_load(V, F, ref.p, ref.dir, 1.0, a);
    for (long k = 0; k < F.rows(); ++k) {
      bool loaded = true;
      for (int j = 0; j < 3; ++j) loaded = loaded && pl.f.segment<3>(3 * F(k, j)).squaredNorm() > 0;
      if (loaded)
        for (int j = 0; j < 3; ++j)
          h_d = std::max(h_d, (V.row(F(k, j)) - V.row(F(k, (j + 1) % 3))).norm());
    }
  }
  // Full run: where D's mesh does not resolve the press, level 0 is graded around it instead
  // (engine::auto_grade_rounds: TetGen of D's surface refined under the pad until its edges are
  // <= the pad radius; docs/ARCHITECTURE.md "Graded level 0"), so the nested levels can
  // converge; the large levels are factorised by CHOLMOD (SparseSolverKind::automatic).
  const bool unresolved_on_d = h_d > a;
  ref.press_h_d = h_d;
  ref.nested = !quick;
  if (!ref.nested) {
    o.refinement = engine::FemRefinement::tetgen;
    o.max_volume *= 2;
  } else {
    o.refinement = engine::FemRefinement::nested;
    o.grade_rounds = unresolved_on_d ? engine::auto_grade_rounds(o) : 0;
    if (unresolved_on_d) {
      // Measured on D's body press (docs/PERFORMANCE.md, "More grading"): the auto rounds (1)
      // give a resolved but untrusted reference (finest level > 5 % from the limit; order
      // ~1.15 whatever the grading); 4 rounds with a coarse far field (TetGen max volume 128x
      // D's mean: the tet count is then set by the surface) give 16.6k / 133k / 1.07M tets,
      // finest level 4.4 % from the limit: trusted (186 s CPU, 7.3 GB peak RSS with PCG).
      o.grade_rounds = std::max(o.grade_rounds, 4);
      o.max_volume *= 128;
    }
    // The frontier needs the static response only (no curve): the large levels are solved by
    // Jacobi-PCG from the prolongated coarser level, ~1/4 of CHOLMOD's CPU and no factor on
    // D's 593k-tet level (docs/PERFORMANCE.md "Solvers on the reference levels").
    o.pcg_min_dofs = engine::kCholmodMinDofs;
  }
  ref.grade_rounds = o.grade_rounds;
  const auto t0 = std::chrono::steady_clock::now();
  const engine::FemReferenceResult r = engine::fem_reference(o);
  ref.total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // The reference's surface is the scene's surface, vertex for vertex (both number the
  // boundary vertices in order of first appearance in the boundary faces).
  if (o.surface.V.rows() != g.V.rows() || (o.surface.V - g.V).cwiseAbs().maxCoeff() > 1e-12)
    throw std::runtime_error("bench frontier: the reference surface is not the scene's surface");
  ref.surf = o.surface.V;
  ref.order = r.observed_order;
  // An untrusted extrapolation (engine::reference_untrusted_reason: order implausible, not
  // monotone, the press unresolved on the levels used, or a large correction) is not used for
  // the stiffness: the finest level stands in, ref_extrapolated = 0 and ref_trusted = 0 say so.
  ref.untrusted = engine::reference_untrusted_reason(r);
  if (unresolved_on_d && !ref.nested) {
    char buf[400];  // the text is ~190 characters with two %.3g numbers
    std::snprintf(buf, sizeof buf,
                  "D's mesh does not resolve the press (edges up to %.3g mm under it > the pad "
                  "radius %.3g mm: a point load for D); the --quick run's TetGen levels do not "
                  "resolve it either (the full run grades level 0 around the press)",
                  1e3 * h_d, 1e3 * a);
    ref.untrusted = buf + (ref.untrusted.empty() ? "" : "; " + ref.untrusted);
  }
  ref.extrapolated = ref.untrusted.empty() && r.stiffness > 0;
  ref.press_h0 = r.levels[r.levels.size() - 3].press_h;
  ref.finest_tets = r.levels.back().tets;
  ref.k_finest = r.levels.back().stiffness;
  ref.k = ref.extrapolated ? r.stiffness : ref.k_finest;
  // The field's shape is fem_reference's (extrapolated) field; its magnitude is set so that its
  // smooth-load reading s^T g equals 1 / k_ref, the compliance the curve error uses. With an
  // implausible order fem_reference still extrapolates the field (with order 1) while k_ref is
  // the finest level's: the scale keeps the curve and the field on the same reference
  // (metric field_scale: 1 when both agree).
  ref.g = r.field;
  ref.k0 = r.levels[0].stiffness;
  ref.level0_field = r.levels[0].field_error;
  ref.level0_s = r.levels[0].solve_ms * 1e-3;
  ref.finest_nodes = r.levels.back().nodes;
  ref.area = lumped_area(g.V, g.F);
  ref.s = smooth_weights(g.V, g.F, ref.p, a);
  ref.w = pad_weights(g.V, g.F, ref.area, ref.node, a);
  ref.field_scale = (1.0 / ref.k) / dot_dir(ref.s, ref.g, ref.dir);
  ref.g *= ref.field_scale;
  ref.c_ws = dot_dir(ref.w, ref.g, ref.dir);
  ref.far.assign(g.V.rows(), 0);
  for (long v = 0; v < g.V.rows(); ++v)
    ref.far[v] = (g.V.row(v).transpose() - ref.p).norm() >= 2 * a;
  return ref;
}

// (b) at one hold: u (#ref vertices by 3) against F g over the far vertices.
double field_error(const mesh::Positions& u, const Reference& ref, double F) {
  double e = 0, m = 0;
  for (long v = 0; v < ref.g.rows(); ++v) {
    if (!ref.far[v]) continue;
    const Eigen::RowVector3d ur = F * ref.g.row(v);
    e += ref.area[v] * (u.row(v) - ur).squaredNorm();
    m += ref.area[v] * ur.squaredNorm();
  }
  return std::sqrt(e / m);
}

double rms(const std::vector<double>& v) {
  if (v.empty()) return std::nan("");
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

struct FrontierVariant {
  std::string name, id, what;
  std::function<void(nlohmann::json&, const std::string& region)> edit;
  bool per_region = false;  // the variant depends on the region (condensed: operational region)
  bool quick = true;        // also in --quick
};

// The device trajectory of a region: depth per step, and the last step of each hold.
struct Schedule {
  std::vector<double> depth;
  std::vector<int> hold_end;
};

Schedule make_schedule(double d_unit, int holds, int hold_steps, double dt) {
  Schedule s;
  double d = -0.002;
  for (int j = 1; j <= holds; ++j) {
    const double target = j * d_unit;
    while (d < target) {
      d = std::min(target, d + 0.02 * dt);
      s.depth.push_back(d);
    }
    for (int k = 0; k < hold_steps; ++k) s.depth.push_back(target);
    s.hold_end.push_back(static_cast<int>(s.depth.size()) - 1);
  }
  return s;
}

// What one press of one model measured.
struct Measured {
  std::vector<double> contact_step_s;
  std::vector<double> force, depth, contact_u;  // per hold end
  std::vector<mesh::Positions> field;           // per hold end, at the reference's vertices
  double settle = 0, peak = 0;
  bool diverged = false;
};

Measured press(engine::Scene& s, const Reference& ref, const Schedule& sch, bool measure) {
  Measured m;
  s.reset();
  const auto& g = s.geometry();
  // The model's press node: the node nearest the reference's press point (the same node for
  // the C/D scenes; the nearest one on A's and B's own tessellations).
  const int node = g.nearest_node(ref.p);
  const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
  const bool hooke =
      std::string(s.model_kind()) == "penalty" || std::string(s.model_kind()) == "ring";
  // Reference vertex -> row of the model's current_surface(): the model's surface vertex
  // nearest it (current_surface lists the scene's surface vertices first, then any refinement
  // nodes).
  std::vector<int> map;
  if (measure) {
    map.resize(ref.surf.rows());
    for (long v = 0; v < ref.surf.rows(); ++v) map[v] = g.nearest_node(ref.surf.row(v).transpose());
  }
  size_t next_hold = 0;
  std::vector<double> f_hist;
  for (size_t i = 0; i < sch.depth.size(); ++i) {
    const double d = sch.depth[i];
    const auto t0 = std::chrono::steady_clock::now();
    const engine::Rendered r = s.step(p - d * n);
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (r.contact) m.contact_step_s.push_back(dt);
    const double f = r.force.norm();
    m.peak = std::max(m.peak, f);
    f_hist.push_back(f);
    if (!measure || next_hold >= sch.hold_end.size() ||
        static_cast<int>(i) != sch.hold_end[next_hold])
      continue;
    ++next_hold;
    // Settling: the force change over the last 10 steps of the hold, relative.
    const double f10 = f_hist[f_hist.size() - 11];
    if (f > 0) m.settle = std::max(m.settle, std::abs(f - f10) / f);
    RowPositions V;
    Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor> F;
    s.current_surface(V, F);
    if (V.rows() < g.V.rows())
      throw std::runtime_error("bench frontier: a model lost surface vertices");
    mesh::Positions u(ref.surf.rows(), 3);
    for (long v = 0; v < ref.surf.rows(); ++v) u.row(v) = V.row(map[v]) - g.V.row(map[v]);
    m.force.push_back(f);
    m.depth.push_back(d);
    m.contact_u.push_back(hooke ? d : dot_dir(ref.s, u, ref.dir));
    m.field.push_back(std::move(u));
  }
  m.diverged = s.stats().nan_detected;
  return m;
}

struct Errors {
  double curve = std::nan(""), felt = std::nan(""), field = std::nan("");
};

// Errors of a press's hold ends (holds with less than 0.5 N are not read: no contact yet).
Errors errors(const Measured& m, const Reference& ref, double c_ref) {
  std::vector<double> ec, ef, eb;
  for (size_t j = 0; j < m.force.size(); ++j) {
    const double F = m.force[j];
    if (!(F >= 0.5)) continue;
    ec.push_back(m.contact_u[j] / F / c_ref - 1);
    ef.push_back(m.depth[j] * ref.k / F - 1);
    eb.push_back(field_error(m.field[j], ref, F));
  }
  return {rms(ec), rms(ef), rms(eb)};
}

struct Point {
  std::string name;
  int colour = 0;
  std::vector<double> t_us, err;  // one per region
};

std::string frontier_svg(const std::vector<Point>& pts, bool field, const std::string& note) {
  std::vector<analysis::Series> series;
  double ymin = std::log10(0.07), ymax = 0, xmax = 3;
  for (const Point& pt : pts) {
    std::vector<double> t, e;
    for (size_t k = 0; k < pt.t_us.size(); ++k)
      if (pt.t_us[k] > 0 && pt.err[k] > 0) t.push_back(pt.t_us[k]), e.push_back(pt.err[k]);
    if (t.empty()) continue;
    // One point per model: median time and mean error over the regions, the error's range over
    // the regions as the bar.
    analysis::Series s;
    s.name = pt.name;
    s.colour = pt.colour;
    double em = 0;
    for (double x : e) em += x;
    em /= static_cast<double>(e.size());
    s.x = {std::log10(engine::median(t))};
    s.y = {std::log10(em)};
    s.lo = {std::log10(*std::min_element(e.begin(), e.end()))};
    s.hi = {std::log10(*std::max_element(e.begin(), e.end()))};
    ymin = std::min(ymin, s.lo[0]), ymax = std::max(ymax, s.hi[0]);
    xmax = std::max(xmax, s.x[0]);
    series.push_back(s);
  }
  // Pareto front: no other model is both faster and more accurate.
  std::vector<std::pair<double, double>> front;
  for (const auto& s : series) {
    bool dominated = false;
    for (const auto& t : series)
      dominated = dominated ||
                  (t.x[0] <= s.x[0] && t.y[0] <= s.y[0] && (t.x[0] < s.x[0] || t.y[0] < s.y[0]));
    if (!dominated) front.push_back({s.x[0], s.y[0]});
  }
  std::sort(front.begin(), front.end());
  analysis::Series pf;
  pf.name = "Pareto front";
  pf.colour = 7;
  for (auto [x, y] : front) pf.x.push_back(x), pf.y.push_back(y);
  series.push_back(pf);
  analysis::Series budget;
  budget.name = "1 ms haptic budget";
  budget.colour = 6;
  budget.x = {3.0, 3.0};
  budget.y = {ymin - 0.2, ymax + 0.2};
  series.push_back(budget);
  return analysis::svg_line_plot(
      series,
      (field ? "Speed vs surface displacement-field error (FEM reference, same problem)"
             : "Speed vs force-displacement curve error at the contact (FEM reference)") +
          note,
      "log10 time per haptic step (us), median over the regions",
      "log10 relative error (mean; bar: range over the regions)", true,
      {{"force Weber fraction 7 %", std::log10(0.07), "#aa0000"}});
}

std::vector<BenchResult> run_frontier(const BenchOptions& o) {
  const std::vector<std::string> regions =
      o.quick ? std::vector<std::string>{"ovary_left"}
              : std::vector<std::string>{"ovary_left", "horn_right", "body"};
  const int holds = 4, hold_steps = o.quick ? 60 : 100;
  const auto none = [](nlohmann::json&, const std::string&) {};
  const std::vector<FrontierVariant> variants = {
      {"A", "A", "prototype A (rigid surface, Hooke's law on the penetration)", none},
      {"B", "B", "prototype B (ring model, force as A)", none},
      {"C", "C", "prototype C (mass-spring, scope 3 cm + sleeping, area-based refinement)", none},
      {"C1", "C1", "prototype C1", none},
      {"C2", "C2", "prototype C2 (A_t / 2)", none},
      {"C_full", "C", "prototype C, full integration (every node every step)",
       [](nlohmann::json& j, const std::string&) {
         j["model"]["scope_radius"] = 0.0;
         j["model"]["sleeping"]["enabled"] = false;
       }},
      {"C_sleeping", "C", "prototype C, sleeping only (no scope)",
       [](nlohmann::json& j, const std::string&) { j["model"]["scope_radius"] = 0.0; }},
      {"C_scope", "C",
       "prototype C, local scope 3 cm only (scope nodes never sleep: tolerances 1e-12; the scope "
       "acts through sleeping, so sleeping stays on to hold the rest)",
       [](nlohmann::json& j, const std::string&) {
         j["model"]["sleeping"]["position_tolerance"] = 1e-12;
         j["model"]["sleeping"]["velocity_tolerance"] = 1e-12;
       }},
      {"D", "D", "prototype D (linear FEM)", none},
      {"D_condensed", "D", "prototype D condensed (operational region = the pressed region)",
       [](nlohmann::json& j, const std::string& region) {
         j["model"]["formulation"] = "condensed";
         j["model"]["operational_region"] = region;
       },
       true},
      {"D_corot", "D_corot", "prototype D co-rotational (exact tangent)", none, false, false},
      // The frontier replays faster than real time: the multi-rate model waits for its
      // re-linearisation (deterministic_update), so its error is the designed one.
      {"D_multirate", "D_multirate",
       "prototype D multi-rate co-rotational (patch compliance at 1 kHz, re-linearised at 60 Hz)",
       [](nlohmann::json& j, const std::string&) { j["model"]["deterministic_update"] = true; },
       false, false}};
  std::vector<const FrontierVariant*> used;
  for (const FrontierVariant& v : variants)
    if (!o.quick || v.quick) used.push_back(&v);

  std::map<std::string, engine::Scene> shared;  // scenes that do not depend on the region
  for (const FrontierVariant* v : used)
    if (!v->per_region)
      shared.emplace(v->name, prototypes::build_scene(app::prototype_variant(
                                  o, v->id, "frontier_" + v->name,
                                  [&](nlohmann::json& j) { v->edit(j, ""); })));
  const engine::Scene& d_scene = shared.at("D");
  for (const auto& [name, sc] : shared)
    if (std::string(sc.model_kind()) == "mass_spring" || std::string(sc.model_kind()) == "fem")
      check_same_problem(d_scene.config(), sc.config());

  std::vector<BenchResult> out;
  std::vector<Point> pts_a(used.size()), pts_b(used.size());
  Point lvl0{"FEM reference level 0 (static solve)", static_cast<int>(used.size()), {}, {}};
  for (size_t k = 0; k < used.size(); ++k) {
    pts_a[k] = {used[k]->name, static_cast<int>(k), {}, {}};
    pts_b[k] = pts_a[k];
  }
  std::vector<std::string> untrusted_regions;
  for (const std::string& region : regions) {
    const Reference ref = reference_for(d_scene, region, o.quick);
    if (!ref.untrusted.empty()) {
      untrusted_regions.push_back(region);
      std::fprintf(stderr, "bench frontier: the %s reference is not trusted: %s\n", region.c_str(),
                   ref.untrusted.c_str());
    }
    const double kc = d_scene.config().contact.stiffness;
    const Schedule sch = make_schedule(1.0 / ref.k + 1.0 / kc, holds, hold_steps, d_scene.dt());
    std::vector<engine::Scene> regional;  // per-region variants, built for this region
    std::vector<engine::Scene*> scenes;
    regional.reserve(used.size());
    for (const FrontierVariant* v : used) {
      if (v->per_region) {
        regional.push_back(prototypes::build_scene(
            app::prototype_variant(o, v->id, "frontier_" + v->name + "_" + region,
                                   [&](nlohmann::json& j) { v->edit(j, region); })));
        check_same_problem(d_scene.config(), regional.back().config());
        scenes.push_back(&regional.back());
      } else {
        scenes.push_back(&shared.at(v->name));
      }
    }
    // The measured press (errors; its step times are the cold run), then the timed presses,
    // interleaved model by model. A model slower than 2 ms per step (hundreds of contact steps
    // per press already) is timed on its measured press alone: a second press of the
    // co-rotational FEM would cost a minute and add nothing but load.
    std::vector<Measured> meas;
    std::vector<std::vector<double>> samples(used.size());
    for (size_t k = 0; k < used.size(); ++k) meas.push_back(press(*scenes[k], ref, sch, true));
    const int timed = o.quick ? 2 : 5;
    for (size_t k = 0; k < used.size(); ++k)
      if (engine::median(meas[k].contact_step_s) > 2e-3) samples[k] = meas[k].contact_step_s;
    for (int rep = 0; rep < timed; ++rep)
      for (size_t k = 0; k < used.size(); ++k) {
        if (engine::median(meas[k].contact_step_s) > 2e-3) continue;
        const Measured t = press(*scenes[k], ref, sch, false);
        samples[k].insert(samples[k].end(), t.contact_step_s.begin(), t.contact_step_s.end());
      }
    const Measured* c_meas = nullptr;
    for (size_t k = 0; k < used.size(); ++k) {
      const FrontierVariant& v = *used[k];
      const bool hooke = std::string(scenes[k]->model_kind()) == "penalty" ||
                         std::string(scenes[k]->model_kind()) == "ring";
      const double c_ref = hooke ? 1.0 / ref.k : ref.c_ws;
      const Errors e = errors(meas[k], ref, c_ref);
      if (v.name == "C") c_meas = &meas[k];
      BenchResult r = app::result_from_samples(
          region + "_" + v.name, region + " press: " + v.what + " (s per contact step)", samples[k],
          engine::median(meas[k].contact_step_s));
      const double force_at = meas[k].force.size() > 1 ? meas[k].force[1] : 0.0;
      r.metrics = {{"p99_step_s", engine::quantile(samples[k], 0.99)},
                   {"force_curve_rel_err", e.curve},
                   {"field_rel_err", e.field},
                   {"felt_curve_rel_err", e.felt},
                   {"force_hold2_N", force_at},
                   {"peak_force_N", meas[k].peak},
                   {"settle_rel", meas[k].settle},
                   {"diverged", meas[k].diverged ? 1.0 : 0.0},
                   {"k_ref_N_per_m", ref.k},
                   {"c_ref_m_per_N", c_ref},
                   {"ref_order", std::isfinite(ref.order) ? ref.order : -1.0},
                   {"ref_extrapolated", ref.extrapolated ? 1.0 : 0.0},
                   {"ref_trusted", ref.untrusted.empty() ? 1.0 : 0.0}};
      out.push_back(r);
      pts_a[k].t_us.push_back(r.median_s * 1e6), pts_a[k].err.push_back(e.curve);
      pts_b[k].t_us.push_back(r.median_s * 1e6), pts_b[k].err.push_back(e.field);
    }
    // The reference itself: its levels and the two compliances (their ratio is how much the
    // load shape matters for this press).
    {
      BenchResult r;
      r.name = region + "_reference";
      r.what =
          region + ": the FEM reference (3 " +
          (ref.nested ? (ref.grade_rounds > 0 ? "nested red refinements of a level 0 graded around "
                                                "the press"
                                              : "nested red refinements of D's mesh")
                      : "TetGen levels, not nested") +
          "; time = all levels, once): " +
          (ref.untrusted.empty() ? "trusted" : "NOT TRUSTED: " + ref.untrusted);
      r.reps = 1;
      r.median_s = r.min_s = r.max_s = r.cold_s = ref.total_s;
      r.metrics = {{"k_ref_N_per_m", ref.k},
                   {"k_finest_level_N_per_m", ref.k_finest},
                   {"finest_level_nodes", static_cast<double>(ref.finest_nodes)},
                   {"finest_level_tets", static_cast<double>(ref.finest_tets)},
                   {"nested", ref.nested ? 1.0 : 0.0},
                   {"grade_rounds", static_cast<double>(ref.grade_rounds)},
                   {"ref_trusted", ref.untrusted.empty() ? 1.0 : 0.0},
                   {"press_h_level0_m", ref.press_h0},
                   {"press_h_on_D_m", ref.press_h_d},
                   {"ref_order", std::isfinite(ref.order) ? ref.order : -1.0},
                   {"ref_extrapolated", ref.extrapolated ? 1.0 : 0.0},
                   {"finest_vs_ref_rel", std::abs(ref.k_finest / ref.k - 1)},
                   {"c_ss_m_per_N", 1.0 / ref.k},
                   {"c_ws_m_per_N", ref.c_ws},
                   {"field_scale", ref.field_scale},
                   {"press_depth_unit_m", 1.0 / ref.k + 1.0 / kc}};
      out.push_back(r);
    }
    // Controls: the planted model (20 % too much compliance and field) at C's hold forces, and
    // the linear FEM on the coarsest level.
    if (c_meas) {
      Measured pl = *c_meas;
      for (size_t j = 0; j < pl.force.size(); ++j) {
        pl.contact_u[j] = 1.2 * ref.c_ws * pl.force[j];
        pl.field[j] = 1.2 * pl.force[j] * ref.g;
      }
      const Errors e = errors(pl, ref, ref.c_ws);
      BenchResult r;
      r.name = region + "_planted_20pct";
      r.what = region + ": control, a planted model with 20 % too much displacement (no timing)";
      r.metrics = {
          {"force_curve_rel_err", e.curve}, {"field_rel_err", e.field}, {"planted_rel_err", 0.2}};
      out.push_back(r);
    }
    BenchResult f;
    f.name = region + "_fem_level0";
    f.what = region + ": linear FEM on the coarsest reference level (time = one static solve)";
    f.reps = 1;
    f.median_s = f.min_s = f.max_s = f.cold_s = ref.level0_s;
    // A linear model of stiffness k0: its curve error is |k_ref / k0 - 1|; its field error is
    // fem_reference's (max over all surface vertices, a stricter norm than (b)).
    f.metrics = {{"force_curve_rel_err", std::abs(ref.k / ref.k0 - 1)},
                 {"level0_field_max_err", ref.level0_field}};
    out.push_back(f);
    lvl0.t_us.push_back(ref.level0_s * 1e6), lvl0.err.push_back(f.metrics[0].second);
  }
  pts_a.push_back(lvl0);
  // The figure places a model by its errors against trusted references only (when at least one
  // region has one): an error against an untrusted reference is not the model's error.
  std::string note;
  if (!untrusted_regions.empty() && untrusted_regions.size() < regions.size()) {
    std::vector<size_t> keep;
    for (size_t i = 0; i < regions.size(); ++i)
      if (std::find(untrusted_regions.begin(), untrusted_regions.end(), regions[i]) ==
          untrusted_regions.end())
        keep.push_back(i);
    for (auto* pts : {&pts_a, &pts_b})
      for (Point& pt : *pts) {
        Point k{pt.name, pt.colour, {}, {}};
        for (size_t i : keep)
          if (i < pt.t_us.size()) k.t_us.push_back(pt.t_us[i]), k.err.push_back(pt.err[i]);
        pt = k;
      }
    note = " (left out, reference not trusted:";
    for (const auto& r : untrusted_regions) note += " " + r;
    note += ")";
  } else if (!untrusted_regions.empty()) {
    note = " (NO region has a trusted reference)";
  }
  app::write_figure(o, "frontier.svg", frontier_svg(pts_a, false, note));
  app::write_figure(o, "frontier_field.svg", frontier_svg(pts_b, true, note));
  return out;
}

palplab::app::BenchSectionRegistration section_frontier{
    "frontier",
    "speed vs error of every prototype (A, B, C, C1, C2, C full / sleeping / scope, D, D "
    "condensed, D co-rotational) against the converged FEM reference of the same problem",
    run_frontier};
}  // namespace
