// `palplab bench refinement`: adaptive area-based refinement (SPEC §3) vs its two baselines —
// conventional adaptive subdivision (every one-neighbourhood face to the level area-based
// reached there) and the whole mesh refined to that level — on the stomach (192-node surface),
// the tract surface (Model-A, 1500 vertices, surface mass-spring) and Model-C (tet model, only
// boundary faces refined). Measured: new nodes and springs (mean over touched nodes, each
// refined from the coarse mesh), the refine + simplify event, one haptic step (backward Euler
// with CG over the whole system) and one graphics step (vertex normals of the current
// surface, what a renderer recomputes per frame) after adaptive vs whole refinement.
// Published (SPEC §3, Pentium IV): new masses 81 vs 91, springs 214 vs 234 (stomach); per loop,
// stomach graphics 3.43 vs 29.40 ms, haptics 0.06 vs 3.97 ms; tract graphics 5.40 vs 110.6 ms,
// haptics 0.08 vs 15.45 ms.
#include <chrono>

#include "app/bench.hpp"
#include "app/bench_scene.hpp"
#include "bench/refine_models.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/rings.hpp"
#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/models/mass_spring_material.hpp"
#include "engine/models/refinement.hpp"
#include "engine/solvers/integrators.hpp"

namespace {
using namespace palplab;
using namespace palplab::engine;
using palplab::app::BenchOptions;
using palplab::app::BenchResult;
using Clock = std::chrono::steady_clock;
using palplab::bench::surface_model;

// Wall time of `steps` backward-Euler steps of the whole current system, per step (s).
double haptic_step_s(AdaptiveMassSpring& m, int steps) {
  ActiveSet act;
  activate_all(m.sys, act);
  IntegratorWorkspace ws;
  ws.cg_tolerance = 1e-6;
  ws.cg_force_tolerance = 1e-6;
  m.sys.F_ext.setZero(m.sys.nodes(), 3);
  m.sys.F_ext.row(0) << 0.0, 0.0, -1.0;
  const auto t0 = Clock::now();
  for (int k = 0; k < steps; ++k) integrate(m.sys, act, m.h, Integrator::backward_euler, ws);
  const double s = std::chrono::duration<double>(Clock::now() - t0).count() / steps;
  m.sys.F_ext.setZero();
  m.sys.X = m.sys.X_rest;
  m.sys.V.setZero();
  return s;
}

double graphics_step_s(const AdaptiveMassSpring& m, int frames) {
  const auto t0 = Clock::now();
  double sink = 0;
  for (int k = 0; k < frames; ++k) sink += mesh::vertex_normals(m.sys.X, m.F)(0, 0);
  const double s = std::chrono::duration<double>(Clock::now() - t0).count() / frames;
  return sink == 12345.678 ? 0 : s;
}

void compare(const std::string& name, const std::string& what, AdaptiveMassSpring m,
             double threshold_area, const BenchOptions& o, std::vector<BenchResult>& out) {
  const int reps = o.quick ? 5 : 9;
  // Touched nodes: spread over the surface (every k-th surface node).
  std::vector<int> on_surface(m.coarse_nodes(), 0), nodes;
  for (long f = 0; f < m.F0.rows(); ++f)
    for (int k = 0; k < 3; ++k) on_surface[m.F0(f, k)] = 1;
  long count = std::count(on_surface.begin(), on_surface.end(), 1);
  const long stride = std::max<long>(1, count / (o.quick ? 8 : 40));
  for (long i = 0, c = 0; i < m.coarse_nodes(); ++i)
    if (on_surface[i] && c++ % stride == 0) nodes.push_back(static_cast<int>(i));
  // 1. Counts, and the refine + simplify event time per touched node (area-based).
  RefineParams area;
  area.threshold_area = threshold_area;
  area.max_level = 3;
  double an = 0, as = 0, cn = 0, cs = 0;
  int level_max = 0;
  std::vector<double> event_s;
  for (int v : nodes) {
    const auto t0 = Clock::now();
    refine_around(m, v, area);
    const int level = m.level;
    const long nn = m.new_nodes, ns = m.new_springs;
    simplify(m);
    event_s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    an += nn, as += ns;
    level_max = std::max(level_max, level);
    if (level == 0) continue;
    RefineParams conv;
    conv.policy = RefinePolicy::conventional;
    conv.level = level;
    refine_around(m, v, conv);
    cn += m.new_nodes, cs += m.new_springs;
    simplify(m);
  }
  const double k = static_cast<double>(nodes.size());
  BenchResult ev = app::result_from_samples(
      name + "_refine_event",
      what + ": area-based refine + simplify event, A_t " + std::to_string(threshold_area) +
          " m^2, mean new nodes/springs vs conventional over " + std::to_string(nodes.size()) +
          " touched nodes (s per event)",
      event_s);
  ev.metrics = {{"area_new_nodes", an / k},       {"area_new_springs", as / k},
                {"conv_new_nodes", cn / k},       {"conv_new_springs", cs / k},
                {"nodes_ratio", an / cn},         {"springs_ratio", as / cs},
                {"max_level", double(level_max)}, {"coarse_nodes", double(m.coarse_nodes())}};
  out.push_back(ev);
  // 2. Haptic and graphics step after adaptive refinement (at the middle touched node) vs
  // after refining the whole mesh to the same level, in alternation.
  const int v = nodes[nodes.size() / 2];
  AdaptiveMassSpring whole = m;
  refine_around(m, v, area);
  const int level = std::max(1, m.level);
  refine_whole(whole, level);
  const int steps = o.quick ? 3 : 10, frames = o.quick ? 5 : 20;
  std::vector<double> ha, hw, ga, gw;
  double cold[4] = {0, 0, 0, 0};
  for (int rep = 0; rep <= reps; ++rep) {
    double x[4] = {haptic_step_s(m, steps), haptic_step_s(whole, steps), graphics_step_s(m, frames),
                   graphics_step_s(whole, frames)};
    if (rep == 0) {
      std::copy(x, x + 4, cold);
      continue;
    }
    ha.push_back(x[0]), hw.push_back(x[1]), ga.push_back(x[2]), gw.push_back(x[3]);
  }
  const double hr = engine::median(hw) / engine::median(ha);
  const double gr = engine::median(gw) / engine::median(ga);
  auto add = [&](const std::string& id, const std::string& desc, std::vector<double>& s, double c,
                 const AdaptiveMassSpring& sys, double ratio) {
    BenchResult r = app::result_from_samples(name + "_" + id, what + ": " + desc, s, c);
    r.metrics = {{"nodes", double(sys.sys.nodes())},
                 {"springs", double(sys.sys.springs.size())},
                 {"level", double(level)},
                 {"whole_over_adaptive", ratio}};
    out.push_back(r);
  };
  add("haptic_adaptive", "haptic step (BE + CG, whole system) after adaptive refinement", ha,
      cold[0], m, hr);
  add("haptic_whole", "haptic step after refining the whole mesh", hw, cold[1], whole, hr);
  add("graphics_adaptive", "graphics step (vertex normals) after adaptive refinement", ga, cold[2],
      m, gr);
  add("graphics_whole", "graphics step after refining the whole mesh", gw, cold[3], whole, gr);
}

std::vector<BenchResult> run_refinement(const BenchOptions& o) {
  std::vector<BenchResult> out;
  compare("stomach", "stomach surface (SPEC: 81 vs 91 masses, 214 vs 234 springs)",
          surface_model(mesh::generate_stomach(0)), 5e-5, o, out);
  compare("tract_surface", "tract surface, Model-A", surface_model(mesh::generate_tract({1500, 0})),
          4e-6, o, out);
  if (!o.quick)
    compare("tract_tet", "Model-C tet model", palplab::bench::tet_model_c(), 4e-6, o, out);
  return out;
}

palplab::app::BenchSectionRegistration section_refinement{
    "refinement",
    "area-based vs conventional adaptive vs whole-mesh refinement: new nodes/springs, haptic "
    "and graphics step",
    run_refinement};
}  // namespace
