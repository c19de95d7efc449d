// `palplab bench integrators`: symplectic Euler, backward Euler with each linear solver (CG,
// LDLT refactorised every step, frozen LDLT as CG preconditioner) and RK4 at h = 0.1 ... 5 ms
// on soft and stiff tissue. The body is the stomach surface model (192 nodes, 564 springs:
// 5 mm wall, 1000 kg/m^3, 2e5 N/m^3 foundation, Rayleigh beta 2 ms; soft = E 10 kPa, stiff =
// E 1 MPa). Load: 1 N on one node for 60 % of the run, then released. Error: the largest node
// distance from a converged reference (RK4 at h = 10 us; its own error is estimated against
// RK4 at 20 us and reported as ref_self_err), sampled every 10 ms of simulated time, relative
// to the reference's largest displacement. A run is unstable when a position goes non-finite
// or any node moves more than 10 x the reference's largest displacement; "largest stable h"
// is the largest tested h with a stable run. Time per step = wall time of the run / steps.
#include <chrono>
#include <cmath>

#include "analysis/svg.hpp"
#include "app/bench.hpp"
#include "app/bench_scene.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/models/mass_spring_material.hpp"
#include "engine/solvers/integrators.hpp"

namespace {
using namespace palplab;
using namespace palplab::engine;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;
using Clock = std::chrono::steady_clock;

MassSpringSystem stomach(double youngs) {
  const mesh::SurfaceMesh m = mesh::generate_stomach(0);
  MassSpringSystem s;
  const long n = m.V.rows();
  s.X_rest = m.V;
  s.X = m.V;
  s.V.setZero(n, 3);
  s.F_ext.setZero(n, 3);
  const Eigen::VectorXd c = Eigen::VectorXd::Constant(m.F.rows(), youngs * 0.005);
  const Eigen::VectorXd area = lumped_area(m.V, m.F);
  s.mass = area * (1000.0 * 0.005);
  s.home_ks = 2e5 * area;
  s.home_kd = 200.0 * area;
  s.fixed.assign(n, 0);
  s.springs = membrane_springs(m.V, m.F, c, 0.002);
  build_adjacency(s);
  return s;
}

struct Method {
  std::string name;
  Integrator m;
  LinearSolver s;
};

struct Run {
  std::vector<RowMatX3d> samples;  // every 10 ms
  double step_s = 0;
  long steps = 0;
  bool stable = true;
  double mean_cg_iters = 0;
};

Run simulate(const MassSpringSystem& s0, const Method& me, double h, double T, double bound) {
  MassSpringSystem s = s0;
  ActiveSet act;
  activate_all(s, act);
  IntegratorWorkspace ws;
  ws.solver = me.s;
  ws.cg_tolerance = 1e-8;
  ws.cg_force_tolerance = 1e-10;
  const int node = 100;
  const Eigen::Vector3d dir =
      (s.X_rest.colwise().mean() - s.X_rest.row(node)).normalized();  // into the body
  Run r;
  r.steps = std::lround(T / h);
  const long every = std::lround(0.01 / h);
  long iters = 0;
  const auto t0 = Clock::now();
  for (long k = 0; k < r.steps; ++k) {
    s.F_ext.row(node) = (k * h < 0.6 * T ? 1.0 : 0.0) * dir.transpose();
    integrate(s, act, h, me.m, ws);
    iters += ws.last.cg_iterations;
    if ((k + 1) % every == 0) {
      const double d = (s.X - s.X_rest).rowwise().norm().maxCoeff();
      if (!std::isfinite(d) || d > bound) {
        r.stable = false;
        break;
      }
      r.samples.push_back(s.X);
    }
  }
  r.step_s = std::chrono::duration<double>(Clock::now() - t0).count() / r.steps;
  r.mean_cg_iters = static_cast<double>(iters) / r.steps;
  return r;
}

double error(const Run& r, const Run& ref, const MassSpringSystem& s0) {
  double e = 0, scale = 0;
  for (size_t k = 0; k < ref.samples.size(); ++k) {
    scale = std::max(scale, (ref.samples[k] - s0.X_rest).rowwise().norm().maxCoeff());
    if (k < r.samples.size())
      e = std::max(e, (r.samples[k] - ref.samples[k]).rowwise().norm().maxCoeff());
  }
  return e / scale;
}

std::vector<BenchResult> run_integrators(const BenchOptions& o) {
  const double T = o.quick ? 0.05 : 0.2;
  const int reps = 5;
  const std::vector<double> hs = o.quick ? std::vector<double>{1e-4, 1e-3, 5e-3}
                                         : std::vector<double>{1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3};
  const std::vector<Method> methods = {
      {"symplectic_euler", Integrator::symplectic_euler, LinearSolver::cg},
      {"backward_euler_cg", Integrator::backward_euler, LinearSolver::cg},
      {"backward_euler_ldlt_refactor", Integrator::backward_euler, LinearSolver::ldlt_refactor},
      {"backward_euler_ldlt_frozen", Integrator::backward_euler, LinearSolver::ldlt_frozen},
      {"rk4", Integrator::rk4, LinearSolver::cg}};
  std::vector<BenchResult> out;
  for (const auto& [tissue, E] : {std::pair<std::string, double>{"soft", 1e4}, {"stiff", 1e6}}) {
    const MassSpringSystem s0 = stomach(E);
    const Method rk4 = methods.back();
    // The reference: RK4 at the largest h_ref (10 us, halved up to 4 times) whose run agrees
    // with the run at 2 h_ref to 1e-6 (relative).
    double h_ref = 1e-5, ref_err = 1;
    Run ref;
    for (int halve = 0; halve <= 4; ++halve) {
      if (halve) h_ref /= 2;
      ref = simulate(s0, rk4, h_ref, T, 1e3);
      const Run ref2 = simulate(s0, rk4, 2 * h_ref, T, 1e3);
      if (!ref.stable) continue;
      ref_err = ref2.stable ? error(ref2, ref, s0) : 1.0;
      if (ref_err < 1e-6) break;
    }
    if (!ref.stable || ref.samples.empty())
      throw std::runtime_error("integrators: no stable RK4 reference for " + tissue + " tissue");
    double bound = 0;
    for (const auto& x : ref.samples)
      bound = std::max(bound, 10 * (x - s0.X_rest).rowwise().norm().maxCoeff());
    std::vector<analysis::Series> series;
    for (size_t mi = 0; mi < methods.size(); ++mi) {
      const Method& me = methods[mi];
      double largest_stable = 0;
      analysis::Series sr;
      sr.name = me.name;
      sr.colour = static_cast<int>(mi);
      for (double h : hs) {
        std::vector<double> t;
        Run first;
        for (int rep = 0; rep <= reps; ++rep) {
          Run r = simulate(s0, me, h, T, bound);
          if (rep == 0) {
            first = std::move(r);
            if (!first.stable) break;  // no timing of a diverging run
            continue;
          }
          t.push_back(r.step_s);
        }
        if (first.stable) largest_stable = std::max(largest_stable, h);
        char hb[32];
        std::snprintf(hb, sizeof hb, "%g", h * 1e3);
        BenchResult r = app::result_from_samples(
            tissue + "_" + me.name + "_h" + hb,
            tissue + " tissue, " + me.name + ", h = " + hb + " ms (s per step)", t, first.step_s);
        const double err = first.stable ? error(first, ref, s0) : 0;
        r.metrics = {{"h_s", h}, {"stable", first.stable ? 1.0 : 0.0}};
        if (first.stable) r.metrics.push_back({"rel_error", err});  // none for a diverged run
        r.metrics.push_back({"ref_self_err", ref_err});
        r.metrics.push_back({"ref_h_s", h_ref});
        if (me.m == Integrator::backward_euler)
          r.metrics.push_back({"cg_iters", first.mean_cg_iters});
        if (first.stable) {
          sr.x.push_back(std::log10(h * 1e3));
          sr.y.push_back(std::log10(std::max(err, 1e-12)));
        }
        out.push_back(r);
      }
      BenchResult sum;
      sum.name = tissue + "_" + me.name + "_largest_stable_h";
      sum.what = tissue + " tissue, " + me.name + ": largest stable tested h (0 = none)";
      sum.reps = 0;
      sum.metrics = {{"largest_stable_h_s", largest_stable}};
      out.push_back(sum);
      series.push_back(sr);
    }
    app::write_figure(
        o, "integrators_" + tissue + ".svg",
        analysis::svg_line_plot(series, "Integrator error vs step, " + tissue + " tissue",
                                "log10 h (ms)", "log10 relative error"));
  }
  return out;
}

palplab::app::BenchSectionRegistration section_integrators{
    "integrators",
    "symplectic Euler, backward Euler (CG / LDLT / frozen LDLT), RK4 at h = 0.1-5 ms: time, error "
    "against a converged reference, largest stable h",
    run_integrators};
}  // namespace
