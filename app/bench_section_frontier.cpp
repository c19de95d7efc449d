// `palplab bench frontier`: speed against error of the prototypes. For the same presses (three
// regions — the left ovary only in --quick), time per haptic step (median and p99 over the
// steps in contact) against
//  (a) the error of the force-displacement curve at the contact: RMS over the press samples
//      with 1 N <= F <= 4 N of (d_model - d_ref(F)) / d_ref(F), d_model the device's depth
//      below the rest surface (what the hand feels) and d_ref(F) = F / k_ref the contact
//      displacement of the converged FEM reference (linear elasticity: one solve per region);
//  (b) the displacement-field error over the surface, at the sample whose force is nearest 2 N:
//      max over the reference's surface vertices of |u_model - u_ref| / max |u_ref|, u_model at
//      the nearest rest vertex of the model's surface (a rigid model has u = 0: error 1).
// The reference is engine::fem_reference (the core of `palplab fem reference`) on Model-C's
// body: E = 100 kPa (prototype C's material), nu = 0.45, base 2 cm pinned, the press a smooth
// 1 cm pressure patch (prototype C's pad radius) along the inward normal of the node nearest the
// region's centroid; three TetGen levels (the prototype's own mesh size, then max tet volume
// halved twice), Richardson-extrapolated when the observed order is plausible (else the finest
// level; metric ref_extrapolated). NOT modelled by the reference: the elastic foundation
// (support_modulus) that holds prototype C's surface — FemReferenceOptions has no such support —
// so the reference body is a cantilever pinned at its base and far softer than every prototype
// at the horns and ovaries; the errors below are dominated by that difference. Two controls make
// the error measure auditable: a planted model with exactly 20 % too much displacement (curve and
// field) must show 0.2 on both; and the linear FEM on the coarsest level is placed with its own
// discretisation error (its time is one static solve, not a haptic step). Prototype D (FEM model in
// the haptic loop) and its condensed / co-rotational variants are not wired into scenes yet and are
// missing here. Presses follow a fixed trajectory (2 cm/s ramp, hold), the same for every model.
#include <chrono>
#include <cmath>

#include "analysis/svg.hpp"
#include "app/bench.hpp"
#include "app/bench_scene.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/models/fem_reference.hpp"
#include "engine/spatial/octree.hpp"
#include "prototypes/factory.hpp"

namespace {
using namespace palplab;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;

struct Reference {
  double k = 0;            // N/m, extrapolated contact stiffness
  mesh::Positions surf;    // reference surface vertices (rest), m
  mesh::Positions u_unit;  // displacement field per newton (m/N)
  double order = 0, k0 = 0, level0_field = 0, level0_solve_s = 0;
  bool plausible = false;  // extrapolated (observed order plausible), else the finest level
};

Reference reference_for(const mesh::TetMesh& tm, const Eigen::Vector3d& p, bool quick) {
  const int node = spatial::linear_nearest(tm.V, p);
  engine::FemReferenceOptions o = engine::reference_options_from_mesh(tm, node, 1.0, 0.01);
  o.materials = mesh::default_materials();
  for (auto& m : o.materials.materials)
    if (m.first <= 101 && 101 <= m.last) m.youngs_modulus = 1e5;
  const double zmin = tm.V.col(2).minCoeff();
  o.is_fixed = [zmin](const Eigen::Vector3d& x) { return x.z() < zmin + 0.02; };
  o.levels = 3;
  if (quick) o.max_volume *= 2;  // coarser levels: a cheaper, less converged reference
  const engine::FemReferenceResult r = engine::fem_reference(o);
  Reference ref;
  ref.order = r.observed_order;
  ref.plausible = r.order_plausible && r.stiffness > 0;
  // An implausible extrapolation (non-nested TetGen levels, fem_reference.hpp) is not used:
  // the finest level stands in, and ref_extrapolated = 0 says so.
  ref.k = ref.plausible ? r.stiffness : r.levels.back().stiffness;
  ref.surf = o.surface.V;
  ref.u_unit = r.field;  // force 1 N (extrapolated field; fem_reference's only field output)
  ref.k0 = r.levels[0].stiffness;
  ref.level0_field = r.levels[0].field_error;
  ref.level0_solve_s = r.levels[0].solve_ms * 1e-3;
  return ref;
}

// (a): RMS relative error of the depth at the forces of the press in [1, 4] N (0.5 N and up
// when the press never reaches 1 N; NaN when it never reaches 0.5 N).
double curve_error(const std::vector<double>& force, const std::vector<double>& depth, double k) {
  for (double lo : {1.0, 0.5}) {
    double s = 0;
    int n = 0;
    for (size_t i = 0; i < force.size(); ++i)
      if (force[i] >= lo && force[i] <= 4.0) {
        const double d_ref = force[i] / k;
        s += std::pow((depth[i] - d_ref) / d_ref, 2);
        ++n;
      }
    if (n > 0) return std::sqrt(s / n);
  }
  return std::nan("");
}

// (b): u_model(i) for the reference's vertex i, scaled reference field at force F.
double field_error(const mesh::Positions& u_model_at_ref, const Reference& ref, double F) {
  double e = 0, m = 0;
  for (long i = 0; i < ref.u_unit.rows(); ++i) {
    const Eigen::Vector3d ur = F * ref.u_unit.row(i).transpose();
    e = std::max(e, (u_model_at_ref.row(i).transpose() - ur).norm());
    m = std::max(m, ur.norm());
  }
  return e / m;
}

struct Model {
  std::string name, id, what;
  std::function<void(nlohmann::json&)> edit;
};

struct Point {
  std::string name;
  double t_us, err_a, err_b;
};

std::string frontier_svg(const std::vector<Point>& pts, bool field) {
  std::vector<analysis::Series> series;
  double ymin = 1e9, ymax = -1e9;
  for (size_t k = 0; k < pts.size(); ++k) {
    const double e = field ? pts[k].err_b : pts[k].err_a;
    if (!(e > 0) || !(pts[k].t_us > 0)) continue;
    analysis::Series s;
    s.name = pts[k].name;
    s.colour = static_cast<int>(k);
    s.x = {std::log10(pts[k].t_us)};
    s.y = {std::log10(e)};
    ymin = std::min(ymin, s.y[0]), ymax = std::max(ymax, s.y[0]);
    series.push_back(s);
  }
  // Pareto front: no other point is both faster and more accurate.
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
  budget.y = {std::min(ymin, std::log10(0.07)) - 0.2, std::max(ymax, 0.0) + 0.2};
  series.push_back(budget);
  return analysis::svg_line_plot(series,
                                 field ? "Speed vs displacement-field error (FEM reference)"
                                       : "Speed vs force-displacement error (FEM reference)",
                                 "log10 time per haptic step (us)", "log10 relative error", true,
                                 {{"force Weber fraction 7 %", std::log10(0.07), "#aa0000"}});
}

std::vector<BenchResult> run(const BenchOptions& o) {
  const std::vector<std::string> regions =
      o.quick ? std::vector<std::string>{"ovary_left"}
              : std::vector<std::string>{"ovary_left", "horn_right", "body"};
  const double depth = o.quick ? 0.008 : 0.012;
  const int steps = static_cast<int>((depth + 0.002) / 0.02 / 0.001) + 100;
  const int reps = 5;
  const std::vector<Model> models = {
      {"A", "A", "prototype A (rigid, penalty)", [](nlohmann::json&) {}},
      {"B", "B", "prototype B (ring model)", [](nlohmann::json&) {}},
      {"C", "C", "prototype C (scope 3 cm + sleeping)", [](nlohmann::json&) {}},
      {"C1", "C1", "prototype C1", [](nlohmann::json&) {}},
      {"C2", "C2", "prototype C2", [](nlohmann::json&) {}},
      {"C_full", "C", "prototype C, every node every step",
       [](nlohmann::json& j) {
         j["model"]["scope_radius"] = 0.0;
         j["model"]["sleeping"]["enabled"] = false;
       }},
      {"C_sleeping", "C", "prototype C, sleeping only (no scope)",
       [](nlohmann::json& j) { j["model"]["scope_radius"] = 0.0; }}};
  std::vector<engine::Scene> scenes;
  for (const Model& m : models)
    scenes.push_back(
        prototypes::build_scene(app::prototype_variant(o, m.id, "frontier_" + m.name, m.edit)));
  const mesh::TetMesh tm = mesh::generate_model_c();
  std::vector<BenchResult> out;
  std::vector<Point> points;
  for (const std::string& region : regions) {
    const auto& g0 = scenes[2].geometry();
    const Reference ref = reference_for(tm, g0.V.row(g0.region_node(region)).transpose(), o.quick);
    double c_force_at = 0;
    std::vector<double> c_force;
    for (size_t k = 0; k < models.size(); ++k) {
      engine::Scene& s = scenes[k];
      std::vector<double> med, all;
      app::PressTrace first;
      double field_err = 0, f_at = 0;
      for (int rep = 0; rep <= reps; ++rep) {
        s.reset();
        // The field is read at the step whose force is nearest 2 N (first repetition).
        app::PressTrace t;
        const auto& g = s.geometry();
        const int node = g.region_node(region);
        const Eigen::Vector3d p = g.V.row(node).transpose(), n = g.N.row(node).transpose();
        double best = 1e9;
        mesh::Positions u_at_ref;
        for (int i = 0; i < steps; ++i) {
          const double d = std::min(depth, -0.002 + 0.02 * i * s.dt());
          const auto t0 = std::chrono::steady_clock::now();
          const engine::Rendered r = s.step(p - d * n);
          const double dt =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          if (r.contact) t.contact_step_s.push_back(dt);
          t.force.push_back(r.force.norm());
          t.depth.push_back(d);
          if (rep == 0 && std::abs(r.force.norm() - 2.0) < best) {
            best = std::abs(r.force.norm() - 2.0);
            f_at = r.force.norm();
            Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> V;
            Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor> F;
            s.current_surface(V, F);
            u_at_ref.setZero(ref.surf.rows(), 3);
            const long nv = g.V.rows();
            for (long v = 0; v < ref.surf.rows(); ++v) {
              const int j = g.nearest_node(ref.surf.row(v).transpose());
              if (j >= 0 && j < nv && V.rows() >= nv) u_at_ref.row(v) = V.row(j) - g.V.row(j);
            }
          }
        }
        if (rep == 0) {
          field_err = u_at_ref.rows() ? field_error(u_at_ref, ref, f_at) : std::nan("");
          first = t;
          continue;
        }
        med.push_back(app::bench_median(t.contact_step_s));
        all.insert(all.end(), t.contact_step_s.begin(), t.contact_step_s.end());
      }
      const double err_a = curve_error(first.force, first.depth, ref.k);
      if (models[k].name == "C") c_force = first.force, c_force_at = f_at;
      BenchResult r =
          app::result_from_samples(region + "_" + models[k].name,
                                   region + " press: " + models[k].what + " (s per contact step)",
                                   med, app::bench_median(first.contact_step_s));
      r.metrics = {{"p99_step_s", app::bench_quantile(all, 0.99)},
                   {"force_curve_rel_err", err_a},
                   {"field_rel_err", field_err},
                   {"force_at_field_N", f_at},
                   {"peak_force_N", *std::max_element(first.force.begin(), first.force.end())},
                   {"k_ref_N_per_m", ref.k},
                   {"ref_order", std::isfinite(ref.order) ? ref.order : -1.0},
                   {"ref_extrapolated", ref.plausible ? 1.0 : 0.0}};
      out.push_back(r);
      points.push_back({region + " " + models[k].name, r.median_s * 1e6, err_a, field_err});
    }
    // Controls: the planted model (20 % too much displacement, curve and field) at prototype
    // C's press forces, and the linear FEM on the coarsest level.
    {
      std::vector<double> d(c_force.size());
      for (size_t i = 0; i < d.size(); ++i) d[i] = 1.2 * c_force[i] / ref.k;
      mesh::Positions u = 1.2 * c_force_at * ref.u_unit;
      BenchResult r;
      r.name = region + "_planted_20pct";
      r.what = region + ": control, a planted model with 20 % too much displacement (no timing)";
      r.metrics = {{"force_curve_rel_err", curve_error(c_force, d, ref.k)},
                   {"field_rel_err", field_error(u, ref, c_force_at)},
                   {"planted_rel_err", 0.2}};
      out.push_back(r);
      BenchResult f;
      f.name = region + "_fem_level0";
      f.what = region + ": linear FEM on the coarsest reference level (time = one static solve)";
      f.reps = 1;
      f.median_s = f.min_s = f.max_s = f.cold_s = ref.level0_solve_s;
      // A linear model of stiffness k0: d = F / k0, so the curve error is |k_ref / k0 - 1|.
      f.metrics = {{"force_curve_rel_err", std::abs(ref.k / ref.k0 - 1)},
                   {"field_rel_err", ref.level0_field}};
      out.push_back(f);
      points.push_back({region + " FEM level 0 (static)", ref.level0_solve_s * 1e6,
                        f.metrics[0].second, ref.level0_field});
    }
  }
  app::write_figure(o, "frontier.svg", frontier_svg(points, false));
  app::write_figure(o, "frontier_field.svg", frontier_svg(points, true));
  return out;
}

palplab::app::BenchSectionRegistration reg{
    "frontier",
    "speed vs error of every prototype against the converged FEM reference (prototype D not "
    "wired yet)",
    run};
}  // namespace
