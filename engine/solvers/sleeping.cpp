#include "engine/solvers/sleeping.hpp"

#include <algorithm>

namespace palplab::engine {

void sleep_all(const MassSpringSystem& sys, ActiveSet& act) {
  act.nodes.clear();
  act.springs.clear();
  act.is_active.assign(sys.nodes(), 0);
  ++act.version;
}

namespace {
inline bool wake(const MassSpringSystem& sys, ActiveSet& act, int j,
                 const std::vector<std::uint8_t>* allowed) {
  if (act.is_active[j] || (!sys.fixed.empty() && sys.fixed[j])) return false;
  if (allowed && !(*allowed)[j]) return false;
  act.is_active[j] = 1;
  act.nodes.push_back(j);
  return true;
}
void finish(const MassSpringSystem& sys, ActiveSet& act) {
  std::sort(act.nodes.begin(), act.nodes.end());
  rebuild_active_springs(sys, act);
}
}  // namespace

bool wake_around(const MassSpringSystem& sys, ActiveSet& act, int i,
                 const std::vector<std::uint8_t>* allowed) {
  bool grew = wake(sys, act, i, allowed);
  for (int k = sys.adj_start[i]; k < sys.adj_start[i + 1]; ++k) {
    const int s = sys.adj_spring[k];
    grew |= wake(sys, act, sys.springs.E(s, 0) == i ? sys.springs.E(s, 1) : sys.springs.E(s, 0),
                 allowed);
  }
  if (grew) finish(sys, act);
  return grew;
}

bool update_sleeping(MassSpringSystem& sys, ActiveSet& act, const SleepParams& p, int keep_awake,
                     RowMatX3d* dv, std::vector<std::uint8_t>& excited,
                     const std::vector<std::uint8_t>* allowed) {
  if (!p.enabled) return false;
  if (excited.size() != static_cast<size_t>(sys.nodes())) excited.assign(sys.nodes(), 0);
  const double x2 = p.x_tol * p.x_tol, v2 = p.v_tol * p.v_tol;
  for (int i : act.nodes)
    excited[i] = i == keep_awake || (sys.X.row(i) - sys.X_rest.row(i)).squaredNorm() > x2 ||
                 sys.V.row(i).squaredNorm() > v2;
  act.removed.clear();
  // Sleep (decided on the current set): not excited and no excited neighbour.
  size_t w = 0;
  for (size_t k = 0; k < act.nodes.size(); ++k) {
    const int i = act.nodes[k];
    bool quiet = !excited[i];
    for (int q = sys.adj_start[i]; quiet && q < sys.adj_start[i + 1]; ++q) {
      const int s = sys.adj_spring[q];
      const int j = sys.springs.E(s, 0) == i ? sys.springs.E(s, 1) : sys.springs.E(s, 0);
      if (act.is_active[j] && excited[j]) quiet = false;
    }
    if (quiet)
      act.removed.push_back(i);
    else
      act.nodes[w++] = i;
  }
  act.nodes.resize(w);
  // Wake the neighbours of excited nodes.
  bool changed = !act.removed.empty();
  for (size_t k = 0; k < w; ++k) {
    const int i = act.nodes[k];
    if (!excited[i]) continue;
    for (int q = sys.adj_start[i]; q < sys.adj_start[i + 1]; ++q) {
      const int s = sys.adj_spring[q];
      const int j = sys.springs.E(s, 0) == i ? sys.springs.E(s, 1) : sys.springs.E(s, 0);
      if (act.is_active[j] || (!sys.fixed.empty() && sys.fixed[j])) continue;
      if (allowed && !(*allowed)[j]) continue;
      act.is_active[j] = 1;
      act.nodes.push_back(j);
      changed = true;
    }
  }
  for (int i : act.removed) {
    // A removed node is never re-woken in the same call: its neighbours that could wake it are
    // not excited (that is why it was quiet).
    act.is_active[i] = 0;
    sys.X.row(i) = sys.X_rest.row(i);
    sys.V.row(i).setZero();
    if (dv && i < dv->rows()) dv->row(i).setZero();
    excited[i] = 0;
  }
  for (size_t k = 0; k < w; ++k) excited[act.nodes[k]] = 0;
  if (changed) finish(sys, act);
  return changed;
}

}  // namespace palplab::engine
