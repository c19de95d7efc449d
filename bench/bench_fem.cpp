// Tissue FEM costs on the Model-C tract (2410 nodes, 9223 tets, soft tissue from the tissue
// table, cervix end pinned): assembly, factorisation, a static solve, one backward-Euler step
// of FemModel for each formulation (with the penalty contact active), the condensed model's
// interior recovery, and the inverse-stiffness contact. Prints median and p99 (ms) per item.
// Then the haptic loop itself: Scene::step of prototype D (linear, condensed, co-rotational)
// against prototype C during the same press (median and p99 of the steps in contact), and the
// force error of the condensed model against the full linear one on that press.
// Build: cmake --build build --target bench_fem; run: build/bench/bench_fem [PROTOTYPES_DIR]
// (`--scene-only` skips the component items; `--multirate` runs only the multi-rate D against
// the full co-rotational D on presses to 1, 2.5 and 4 N and a sliding press; `--trace` prints
// both forces along the slide).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/press.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/models/fem_model.hpp"
#include "engine/solvers/fem_condensation.hpp"
#include "engine/solvers/fem_contact_compliance.hpp"
#include "engine/solvers/fem_corotational.hpp"
#include "engine/solvers/fem_static.hpp"
#include "prototypes/factory.hpp"

using namespace palplab;
using namespace palplab::engine;
using Clock = std::chrono::steady_clock;

namespace {

void report(const std::string& name, int reps, const std::function<void()>& fn) {
  std::vector<double> t(reps);
  for (int i = 0; i < reps; ++i) {
    const auto t0 = Clock::now();
    fn();
    t[i] = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  }
  const TimingSummary ts = summarize_times(t);
  std::printf("%-46s %6d %12.4f %12.4f\n", name.c_str(), reps, ts.median, ts.p99);
}

struct PressRun {
  std::vector<double> us;     // Scene::step time of the steps in contact
  std::vector<double> force;  // N, every step
};

// The press of bench_engine_step (the one press script, engine/haptics/press.hpp): 2 mm outside
// the region's node, in along the inward normal at 2 cm/s to `target` N, hold `hold` s, withdraw
// at 5 cm/s. With `replay` given, the device follows those positions instead (one per step: the
// same input for two models); `log` receives the positions this run used.
PressRun scene_press(Scene& s, const std::string& region, double target, double hold,
                     std::vector<Eigen::Vector3d>* log,
                     const std::vector<Eigen::Vector3d>* replay) {
  PressRun r;
  PressDevice press(press_at(s.geometry(), s.geometry().region_node(region), target, hold, 0.0));
  std::vector<std::pair<double, Eigen::Vector3d>> path;
  if (replay)
    for (size_t k = 0; k < replay->size(); ++k) path.push_back({k * s.dt(), (*replay)[k]});
  if (path.empty()) path.push_back({0.0, Eigen::Vector3d::Zero()});
  ScriptedDevice scripted(path);  // at the step times exactly the logged positions
  std::vector<double> us;
  TimedDevice timed(replay ? static_cast<Device&>(scripted) : press, us);
  const double duration = replay ? replay->size() * s.dt() : 20.0;
  run_lockstep(s, timed, {.duration = duration, .frame_period = 0.0},
               [&](const Rendered& out, const Sample& x) {
                 if (out.contact) r.us.push_back(us.back());
                 r.force.push_back(out.force.norm());
                 if (log) log->push_back(x.x);
               });
  return r;
}

std::string prototypes_dir(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]).rfind("--", 0) != 0 && std::string(argv[i - 1]) != "--case")
      return std::string(argv[i]) + "/";
  std::string d(__FILE__);
  d.erase(d.rfind('/'));
  d.erase(d.rfind('/'));
  return d + "/prototypes/";
}

// Scene::step per prototype in contact, and the condensed model's error on the same press.
void scene_steps(const std::string& dir) {
  std::printf("\nScene::step in contact (press on ovary_left to 2.5 N, hold, withdraw)\n");
  std::printf("%-34s %6s %8s %10s %10s %10s %10s\n", "prototype", "dofs", "steps", "median_us",
              "p99_us", "max_us", "peak_N");
  struct Variant {
    std::string name, file;
    FemFormulation form;
    bool fem;
    double hold;  // s
  };
  const std::vector<Variant> vs = {
      {"C (mass_spring)", "C.json", FemFormulation::linear, false, 1.0},
      {"D (fem linear)", "D.json", FemFormulation::linear, true, 1.0},
      {"D condensed (ovary_left+15 mm)", "D.json", FemFormulation::condensed, true, 1.0},
      {"D_corot (fem corotational)", "D_corot.json", FemFormulation::corotational, true, 0.2},
      {"D_multirate (corot, 60 Hz update)", "D_multirate.json",
       FemFormulation::corotational_multirate, true, 1.0}};
  std::vector<Eigen::Vector3d> path_full;
  std::vector<double> force_full;
  for (const auto& v : vs) {
    SceneConfig cfg = prototypes::load_prototype(dir + v.file);
    if (v.form == FemFormulation::condensed) {
      cfg.fem.formulation = FemFormulation::condensed;
      cfg.fem.operational_region = "ovary_left";
      cfg.fem.operational_radius = 0.015;
    }
    Scene s = make_scene(cfg);
    const bool linear = v.fem && v.form == FemFormulation::linear;
    const bool cond = v.form == FemFormulation::condensed;
    const PressRun r = scene_press(s, "ovary_left", 2.5, v.hold, linear ? &path_full : nullptr,
                                   cond ? &path_full : nullptr);
    long dofs = 0;
    const SceneStats st = s.stats();
    if (!st.model_info.empty()) {
      const auto pos = st.model_info.find("\"dofs\":");
      if (pos != std::string::npos) dofs = std::stol(st.model_info.substr(pos + 7));
    }
    const std::string dofs_s = v.fem ? std::to_string(dofs) : "-";
    std::printf("%-34s %6s %8zu %10.1f %10.1f %10.1f %10.3f\n", v.name.c_str(), dofs_s.c_str(),
                r.us.size(), summarize_times(r.us).median, summarize_times(r.us).p99,
                summarize_times(r.us).max, *std::max_element(r.force.begin(), r.force.end()));
    if (linear) force_full = r.force;
    if (cond) {
      double e = 0, fmax = 0;
      for (size_t k = 0; k < std::min(r.force.size(), force_full.size()); ++k) {
        e = std::max(e, std::abs(r.force[k] - force_full[k]));
        fmax = std::max(fmax, force_full[k]);
      }
      std::printf(
          "  condensed vs full linear, same device trajectory: max |F - F_full| = %.4g N "
          "(%.3g%% of the peak %.3g N; Guyan: the condensed interior is massless)\n",
          e, 100 * e / fmax, fmax);
    }
  }
}

// One device trajectory on a scene: positions, the force of every step, the step time (us) of
// the steps in contact, and the surface at the steps listed in `snap`.
struct Recorded {
  std::vector<Eigen::Vector3d> x, force;
  std::vector<double> us;
  std::vector<int> snap;
  std::vector<mesh::Positions> surface;
  int slide_begin = -1, slide_end = -1;  // steps of the slide (corot_press)
};

using RowMatX3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

void snapshot(Scene& s, Recorded& r) {
  RowMatX3 V;
  Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor> F;
  s.current_surface(V, F);
  r.snap.push_back(static_cast<int>(r.x.size()) - 1);
  r.surface.push_back(V);
}

// `device` on s in the one lock-step loop (paced: at the haptic rate in wall time, the
// multi-rate worker beside it, as in a study); after each step, `after(step index)`.
void record(Scene& s, Device& device, double duration, bool paced, Recorded& r,
            const std::function<void(int)>& after) {
  std::vector<double> all;  // the step time (us) of every step; r.us keeps those in contact
  TimedDevice timed(device, all);
  run_lockstep(s, timed, {.duration = duration, .frame_period = 0.0, .paced = paced},
               [&](const Rendered& out, const Sample& x) {
                 r.x.push_back(x.x);
                 r.force.push_back(out.force);
                 if (out.contact) r.us.push_back(all.back());
                 after(static_cast<int>(r.x.size()) - 1);
               });
}

// The press of scene_press on the full model, as one press script (engine/haptics/press.hpp):
// 2 cm/s in to `target` N, then the depth held (hold_depth) for 0.1 s; with `slide` > 0, a
// slide of that many m at 2 cm/s along a tangent and another 0.1 s hold; out at 5 cm/s. The
// surface is taken at the end of each hold. The full co-rotational model decides where the
// holds are; the other model replays the positions.
Recorded corot_press(Scene& s, const std::string& region, double target, double slide) {
  const auto& g = s.geometry();
  PressSpec spec = press_at(g, g.region_node(region), target, 0.0, 0.0);
  spec.hold_depth = true;
  spec.segments = {PressSegment::hold_for(0.1)};
  if (slide > 0)
    spec.segments.insert(spec.segments.end(),
                         {PressSegment::slide_by(slide * spec.normal.unitOrthogonal(), 0.02),
                          PressSegment::hold_for(0.1)});
  PressDevice press(spec);
  Recorded r;
  int segment = -1;
  record(s, press, 60.0, false, r, [&](int k) {
    if (press.segment() == segment) return;
    const int ended = segment;  // the step just taken was the last of this segment
    segment = press.segment();
    if (ended < 0) return;
    const PressSegment& done = spec.segments[ended];
    if (done.is_slide()) r.slide_end = k + 1;
    if (!done.is_slide()) snapshot(s, r);
    if (segment >= 0 && spec.segments[segment].is_slide()) r.slide_begin = k + 1;
  });
  return r;
}

// The positions of `ref` step by step (a ScriptedDevice at the step times), the surface at
// ref's snapshot steps.
Recorded replay(Scene& s, const Recorded& ref, bool paced) {
  std::vector<std::pair<double, Eigen::Vector3d>> path;
  for (size_t k = 0; k < ref.x.size(); ++k) path.push_back({k * s.dt(), ref.x[k]});
  ScriptedDevice scripted(path);
  Recorded r;
  size_t q = 0;
  record(s, scripted, ref.x.size() * s.dt(), paced, r, [&](int k) {
    if (q < ref.snap.size() && k == ref.snap[q]) {
      snapshot(s, r);
      ++q;
    }
  });
  return r;
}

// Multi-rate D against the full co-rotational D on the same device trajectories (issue 12):
// force error at the end of every hold (quasi-static) and over the whole trajectory (includes
// the full model's viscous and inertial force, which the quasi-static multi-rate model does not
// render), surface displacement error at the end of every hold, step times of both.
void multirate_error(const std::string& dir, int only, bool trace) {
  std::printf(
      "\nD_multirate vs D_corot (full co-rotational, dynamic) on the same device trajectory, "
      "press on ovary_left\n");
  std::printf("%-22s %-13s %7s %6s %9s %9s %9s %9s %9s %10s %10s %10s %10s\n", "press", "mode",
              "steps", "relin", "F_hold_N", "dF_hold%", "dx_hold%", "maxdF_N", "maxdF%pk",
              "corot_med", "corot_p99", "mr_med_us", "mr_p99_us");
  struct Case {
    std::string name;
    double target, slide;
  };
  const std::vector<Case> cases = {
      {"1 N", 1.0, 0.0}, {"2.5 N", 2.5, 0.0}, {"4 N", 4.0, 0.0}, {"2.5 N + 1 cm slide", 2.5, 0.01}};
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    if (only >= 0 && static_cast<int>(ci) != only) continue;
    const Case& c = cases[ci];
    Scene co = make_scene(prototypes::load_prototype(dir + "D_corot.json"));
    const Recorded a = corot_press(co, "ovary_left", c.target, c.slide);
    const double s_dt = co.dt();
    for (bool det : {false, true}) {
      SceneConfig mc = prototypes::load_prototype(dir + "D_multirate.json");
      mc.fem.multirate_deterministic = det;
      Scene mr = make_scene(mc);
      const Recorded b = replay(mr, a, !det);
      long relin = 0;
      {
        const std::string info = mr.stats().model_info;
        const auto pos = info.find("\"relinearisations\":");
        if (pos != std::string::npos) relin = std::stol(info.substr(pos + 19));
      }
      double hold_err = 0, disp_err = 0, f_hold = 0, max_df = 0, peak = 0;
      for (size_t q = 0; q < a.snap.size(); ++q) {
        const int k = a.snap[q];
        f_hold = a.force[k].norm();
        hold_err = std::max(hold_err, (b.force[k] - a.force[k]).norm() / a.force[k].norm());
        const RowMatX3 V0 = co.geometry().V;
        const double umax = (a.surface[q] - V0).rowwise().norm().maxCoeff();
        disp_err =
            std::max(disp_err, (b.surface[q] - a.surface[q]).rowwise().norm().maxCoeff() / umax);
      }
      for (size_t k = 0; k < a.force.size(); ++k) {
        max_df = std::max(max_df, (b.force[k] - a.force[k]).norm());
        peak = std::max(peak, a.force[k].norm());
      }
      std::printf(
          "%-22s %-13s %7zu %6ld %9.3f %9.3f %9.3f %9.4f %9.3f %10.0f %10.0f %10.1f %10.1f\n",
          c.name.c_str(), det ? "deterministic" : "real time", a.x.size(), relin, f_hold,
          100 * hold_err, 100 * disp_err, max_df, 100 * max_df / peak, summarize_times(a.us).median,
          summarize_times(a.us).p99, summarize_times(b.us).median, summarize_times(b.us).p99);
      if (trace && a.slide_begin >= 0) {
        // Force along the slide (and 100 steps on): both models, every 20 steps and at the
        // largest difference.
        std::printf("    %6s %9s %9s %9s %9s\n", "step", "slide_mm", "F_corot", "F_mr", "dF_N");
        size_t worst = 0;
        for (size_t k = 0; k < a.force.size(); ++k)
          if ((b.force[k] - a.force[k]).norm() > (b.force[worst] - a.force[worst]).norm())
            worst = k;
        for (int k = a.slide_begin - 20; k < a.slide_end + 100 && k < static_cast<int>(a.x.size());
             ++k)
          if ((k - a.slide_begin) % 20 == 0 || k == static_cast<int>(worst))
            std::printf("    %6d %9.3f %9.4f %9.4f %9.4f%s\n", k,
                        1e3 * 0.02 * s_dt *
                            std::clamp(k - a.slide_begin + 1, 0, a.slide_end - a.slide_begin),
                        a.force[k].norm(), b.force[k].norm(), (b.force[k] - a.force[k]).norm(),
                        k == static_cast<int>(worst) ? "  <- largest" : "");
        if (worst < static_cast<size_t>(a.slide_begin) - 20 ||
            worst >= static_cast<size_t>(a.slide_end + 100))
          std::printf("    largest difference at step %zu (outside the slide): %.4f vs %.4f N\n",
                      worst, a.force[worst].norm(), b.force[worst].norm());
      }
      std::fflush(stdout);
    }
  }
  std::printf(
      "  dF_hold: |F_mr - F_corot| / |F_corot| at the end of each 100-step hold (max over the "
      "holds); dx_hold: max surface-node distance / max surface displacement there; maxdF: over "
      "every step (the full model's viscous force while moving is in it)\n");
}

}  // namespace

int main(int argc, char** argv) {
  bool scene_only = false, multirate = false;
  for (int i = 1; i < argc; ++i) {
    scene_only |= std::string(argv[i]) == "--scene-only";
    multirate |= std::string(argv[i]) == "--multirate";
  }
  if (multirate) {
    int only = -1;  // --case K: only the K-th press (0..3)
    for (int i = 1; i + 1 < argc; ++i)
      if (std::string(argv[i]) == "--case") only = std::stoi(argv[i + 1]);
    bool trace = false;  // --trace: the force of both models along the slide
    for (int i = 1; i < argc; ++i) trace |= std::string(argv[i]) == "--trace";
    multirate_error(prototypes_dir(argc, argv), only, trace);
    return 0;
  }
  if (scene_only) {
    scene_steps(prototypes_dir(argc, argv));
    return 0;
  }
  const mesh::TetMesh m = mesh::generate_model_c();
  const TetMaterials mat = tet_materials(m, mesh::default_materials());
  const long n = m.V.rows();
  std::vector<std::uint8_t> fixed(n, 0);
  for (long i = 0; i < n; ++i) fixed[i] = m.V(i, 2) < 0.01;  // cervix end (z from 0)
  // Operational region: the left ovary and horn (region ids 0 and 2); contact at the ovary
  // vertex farthest out in -x, pressed along +x (inwards).
  std::vector<std::uint8_t> op(m.T.rows(), 0);
  for (long t = 0; t < m.T.rows(); ++t) op[t] = m.regions.id[t] == 0 || m.regions.id[t] == 2;
  const auto vreg = mesh::vertex_regions(m);
  int press = -1;
  for (long i = 0; i < n; ++i)
    if (vreg[i] == 0 && (press < 0 || m.V(i, 0) < m.V(press, 0))) press = static_cast<int>(i);
  std::vector<int> touch;
  for (long i = 0; i < n; ++i)
    if (vreg[i] == 0 && !fixed[i]) touch.push_back(static_cast<int>(i));
  long nfixed = 0;
  for (auto f : fixed) nfixed += f;
  std::printf(
      "Model-C: %ld nodes, %ld tets, %ld pinned nodes, %ld dofs; operational tets %ld; "
      "touchable (ovary) nodes %zu\n",
      n, static_cast<long>(m.T.rows()), nfixed, 3 * n,
      static_cast<long>(std::count(op.begin(), op.end(), 1)), touch.size());
  std::printf("%-46s %6s %12s %12s\n", "item", "reps", "median_ms", "p99_ms");

  FemSystem sys;
  report("fem_precompute (shapes, Ke, pattern, K, M)", 3,
         [&] { sys = fem_precompute(m.V, m.T, mat); });
  SparseMatrixd K = sys.K;
  report("assemble K on the reused pattern", 50, [&] { assemble(sys.pattern, sys.Ke, K); });
  const std::vector<std::uint8_t> fixed_dof = node_to_dof_flags(fixed);
  StaticSolver ss;
  report("static: analyse + factorise K_ff (LDLT)", 3,
         [&] { static_precompute(sys.K, fixed_dof, ss); });
  report("static: numeric factorisation only", 5, [&] { ss.ldlt.factorize(ss.K_ff); });
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n);
  f.segment<3>(3 * press) = Eigen::Vector3d(1.0, 0, 0);
  Eigen::VectorXd u;
  report("static solve (back-substitution)", 100, [&] { u = static_solve(ss, f); });

  Eigen::VectorXd x = flatten(sys.X0) + u;
  std::vector<Matrix12d> ws;
  SparseMatrixd Kt;
  Eigen::VectorXd fint;
  report("corotational forces + exact tangent", 10,
         [&] { corotational_stiffness(sys, x, CorotJacobian::exact, ws, Kt, &fint); });
  report("corotational forces + warped tangent", 10,
         [&] { corotational_stiffness(sys, x, CorotJacobian::warped, ws, Kt, &fint); });
  report("corotational forces only", 10, [&] { corotational_forces(sys, x, fint); });

  CondensedFem cond;
  report("condense: K*, reduced factorisation", 1,
         [&] { condense_precompute(sys.K, m.T, fixed_dof, op, cond); });
  std::printf("  condensed: %zu reduced dofs (%zu operational, %zu interface), %zu condensed\n",
              cond.reduced.size(), cond.dofs_I.size(), cond.dofs_s.size(), cond.dofs_i.size());
  report("condensed static solve, no interior", 100, [&] { u = condensed_solve(cond, f, false); });
  report("condensed static solve + interior recovery", 20,
         [&] { u = condensed_solve(cond, f, true); });

  ContactCompliance cc;
  report("inverse stiffness: compliance of ovary nodes", 1,
         [&] { contact_compliance_precompute(ss, touch, {}, cc); });
  ContactSolution sol;
  const std::vector<ContactConstraint> c1 = {{press, Eigen::Vector3d::UnitX(), 0.002}};
  report("inverse stiffness: contact force (1 direction)", 1000,
         [&] { contact_solve(cc, c1, sol, false); });
  report("inverse stiffness: force + displacement field", 200,
         [&] { contact_solve(cc, c1, sol, true); });

  for (FemFormulation form :
       {FemFormulation::linear, FemFormulation::condensed, FemFormulation::corotational}) {
    FemModelOptions o;
    o.formulation = form;
    if (form == FemFormulation::condensed) o.operational_tet = op;
    FemModel model(m, mat, fixed, o);
    model.contact_node = press;
    model.contact_normal = Eigen::Vector3d(-1, 0, 0);  // outward; the device pushes along +x
    model.contact_point = m.V.row(press).transpose() + Eigen::Vector3d(0.003, 0, 0);
    model.contact_k = 300;
    const int reps = form == FemFormulation::corotational ? 30 : 500;
    model.step(1e-3);  // first step factorises
    std::printf("FemModel %s: %ld dofs, setup+factor %.1f ms, solver: %s\n", to_string(form),
                model.dofs(), model.factor_ms(), model.solver().c_str());
    // The device follows the node so that the contact (and its implicit Jacobian) stays on:
    // 2 mm penetration along the inward normal at every step.
    const auto hold = [&] {
      model.contact_point = model.node_position(press) - 0.002 * model.contact_normal;
    };
    report(std::string("FemModel::step(1 ms) ") + to_string(form) + " +contact", reps, [&] {
      hold();
      model.step(1e-3);
    });
    if (form == FemFormulation::condensed)
      report("FemModel::positions() condensed (recovery)", 50, [&] {
        hold();
        model.step(1e-3);
        model.positions();
      });
    std::printf("  after %d steps: pressed node moved %.4f m\n", reps + 1,
                (model.node_position(press) - m.V.row(press).transpose()).norm());
  }
  // Condensed (Guyan) vs full linear dynamics on the same press: the device holds the pressed
  // node 2 mm deep for 300 ms. The difference is the dropped inertia of the condensed part.
  {
    FemModelOptions ol, oc;
    oc.formulation = FemFormulation::condensed;
    oc.operational_tet = op;
    FemModel full(m, mat, fixed, ol), cnd(m, mat, fixed, oc);
    double max_diff = 0, max_force = 0, max_disp_diff = 0, max_disp = 0;
    for (int i = 0; i < 300; ++i) {
      for (FemModel* p : {&full, &cnd}) {
        p->contact_node = press;
        p->contact_normal = Eigen::Vector3d(-1, 0, 0);
        p->contact_k = 300;
        // Both devices follow the FULL model's node, so the inputs are identical.
        p->contact_point = full.node_position(press) - 0.002 * p->contact_normal;
      }
      const Eigen::Vector3d f_full = full.device_force(), f_cnd = cnd.device_force();
      max_diff = std::max(max_diff, (f_full - f_cnd).norm());
      max_force = std::max(max_force, f_full.norm());
      full.step(1e-3);
      cnd.step(1e-3);
      const Eigen::Vector3d d_full = full.node_position(press) - m.V.row(press).transpose();
      const Eigen::Vector3d d_cnd = cnd.node_position(press) - m.V.row(press).transpose();
      max_disp_diff = std::max(max_disp_diff, (d_full - d_cnd).norm());
      max_disp = std::max(max_disp, d_full.norm());
    }
    std::printf(
        "condensed vs full, 300 ms press: max device-force difference %.4g N (max force "
        "%.4g N), max pressed-node displacement difference %.4g m (max %.4g m)\n",
        max_diff, max_force, max_disp_diff, max_disp);
  }
  scene_steps(prototypes_dir(argc, argv));
  return 0;
}
