// Adaptive area-based refinement vs its baselines (the original work's comparisons):
//  1. new masses (nodes) and springs: area-based vs conventional adaptive subdivision to the same
//     finest level, on the stomach (192 nodes, 372 faces, 564 springs) and on Model-C's surface
//     (published: stomach 81 vs 91 masses, 214 vs 234 springs);
//  2. cost of a refine + simplify event, and of one backward-Euler step of the whole system
//     after adaptive refinement vs after refining the whole model to the same level
//     (published: haptics per loop 0.06 vs 3.97 ms stomach, 0.08 vs 15.45 ms tract).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "bench/refine_models.hpp"
#include "engine/haptics/clock.hpp"
#include "engine/solvers/integrators.hpp"

using namespace palplab;
using namespace palplab::engine;
using Clock = std::chrono::steady_clock;

namespace {

struct Counts {
  double area_nodes = 0, area_springs = 0, conv_nodes = 0, conv_springs = 0;
  int level = 0;
};

// Mean new nodes/springs over the touched nodes, each refined from the coarse mesh: area-based,
// then conventional subdivision to the level area-based reached at that node.
Counts refine_each(AdaptiveMassSpring& m, const std::vector<int>& nodes, double threshold_area) {
  Counts c;
  for (int v : nodes) {
    RefineParams area;
    area.threshold_area = threshold_area;
    area.max_level = 3;
    refine_around(m, v, area);
    const int level = m.level;
    c.area_nodes += m.new_nodes;
    c.area_springs += m.new_springs;
    c.level = std::max(c.level, level);
    simplify(m);
    if (level == 0) continue;
    RefineParams conv;
    conv.policy = RefinePolicy::conventional;
    conv.level = level;
    refine_around(m, v, conv);
    c.conv_nodes += m.new_nodes;
    c.conv_springs += m.new_springs;
    simplify(m);
  }
  const double k = static_cast<double>(nodes.size());
  c.area_nodes /= k;
  c.area_springs /= k;
  c.conv_nodes /= k;
  c.conv_springs /= k;
  return c;
}

double step_cost_us(AdaptiveMassSpring& m) {
  ActiveSet act;
  activate_all(m.sys, act);
  IntegratorWorkspace ws;
  ws.cg_tolerance = 1e-6;
  ws.cg_force_tolerance = 1e-6;
  m.sys.F_ext.row(0) << 0.0, 0.0, -1.0;
  std::vector<double> us;
  for (int k = 0; k < 30; ++k) {
    const auto t0 = Clock::now();
    integrate(m.sys, act, m.h, Integrator::backward_euler, ws);
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  m.sys.F_ext.setZero();
  return engine::median(us);
}

void compare(const char* name, AdaptiveMassSpring m, const std::vector<double>& thresholds) {
  // Touched nodes: every 7th surface node (a spread of face sizes).
  std::vector<int> nodes;
  std::vector<int> on_surface(m.coarse_nodes(), 0);
  for (long f = 0; f < m.F0.rows(); ++f)
    for (int k = 0; k < 3; ++k) on_surface[m.F0(f, k)] = 1;
  for (long i = 0, c = 0; i < m.coarse_nodes(); ++i)
    if (on_surface[i] && c++ % 7 == 0) nodes.push_back(static_cast<int>(i));
  std::printf("\n%s: %ld nodes, %ld springs, %ld surface faces; mean over %zu touched nodes\n",
              name, m.coarse_nodes(), m.coarse_springs(), static_cast<long>(m.F0.rows()),
              nodes.size());
  std::printf("%-12s %6s | %-17s | %-17s | %8s %8s\n", "A_t (m^2)", "max l", "area-based n / s",
              "conventional n / s", "ratio n", "ratio s");
  std::printf(
      "(conventional: every one-neighbourhood face to the level area-based reached there)\n");
  for (double at : thresholds) {
    const Counts c = refine_each(m, nodes, at);
    std::printf("%-12.3g %6d | %7.1f / %7.1f | %7.1f / %7.1f | %8.2f %8.2f\n", at, c.level,
                c.area_nodes, c.area_springs, c.conv_nodes, c.conv_springs,
                c.area_nodes / c.conv_nodes, c.area_springs / c.conv_springs);
  }
  // Event cost and per-step cost: adaptive (A_t = the last threshold) vs whole model refined.
  RefineParams area;
  area.threshold_area = thresholds.back();
  area.max_level = 3;
  std::vector<double> ev;
  for (int v : nodes) {
    const auto t0 = Clock::now();
    refine_around(m, v, area);
    simplify(m);
    ev.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  refine_around(m, nodes[nodes.size() / 2], area);
  const int level = m.level;
  const long adaptive_nodes = m.sys.nodes();
  const double adaptive = step_cost_us(m);
  simplify(m);
  const double coarse = step_cost_us(m);
  const auto t0 = Clock::now();
  refine_whole(m, std::max(1, level));
  const double whole_refine_us =
      std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
  const double whole = step_cost_us(m);
  std::printf("refine+simplify event (area-based): median %.0f us, max %.0f us\n",
              engine::median(ev), *std::max_element(ev.begin(), ev.end()));
  std::printf(
      "one backward-Euler step of the whole system (CG): coarse %.0f us, adaptive "
      "(%ld nodes, level %d) %.0f us, whole model refined (%ld nodes) %.0f us -> %.1fx; "
      "refining the whole model took %.0f us\n",
      coarse, adaptive_nodes, level, adaptive, m.sys.nodes(), whole, whole / adaptive,
      whole_refine_us);
  simplify(m);
}

}  // namespace

int main() {
  compare("stomach", palplab::bench::surface_model(mesh::generate_stomach(0)), {2e-4, 1e-4, 5e-5});
  compare("Model-C (tet model)", palplab::bench::tet_model_c(), {8e-6, 4e-6, 2e-6});
  return 0;
}
