#pragma once
// "Model only what the scene needs": nodes at rest far from the contact are not integrated.
// A node is EXCITED when it is off its rest position by more than x_tol or moves faster than
// v_tol. Excited nodes wake their spring neighbours; an awake node that is not excited and has
// no excited neighbour falls asleep and is put exactly at rest (x = x_rest, v = 0) — the error
// this costs is bounded by x_tol per node and measured in bench_engine_sleep.
#include "engine/solvers/integrators.hpp"

namespace palplab::engine {

struct SleepParams {
  bool enabled = true;
  double x_tol = 1e-6;  // m
  double v_tol = 1e-5;  // m/s
};

// Puts every node to sleep (empty active set) — the state of a model at rest.
void sleep_all(const MassSpringSystem& sys, ActiveSet& act);
// Wakes node i and its spring neighbours (no-op for fixed nodes). Returns true if the set grew.
// `allowed` (#V, optional): only nodes with allowed[j] != 0 may wake (the integration scope).
bool wake_around(const MassSpringSystem& sys, ActiveSet& act, int i,
                 const std::vector<std::uint8_t>* allowed = nullptr);
// After a step: wake neighbours of excited nodes, put quiet nodes to sleep (except keep_awake),
// rebuild the active springs when the set changed. `dv` (may be null) is the backward-Euler warm
// start, cleared for nodes that fall asleep. Returns true when the set changed.
bool update_sleeping(MassSpringSystem& sys, ActiveSet& act, const SleepParams& p, int keep_awake,
                     RowMatX3d* dv, std::vector<std::uint8_t>& scratch,
                     const std::vector<std::uint8_t>* allowed = nullptr);

}  // namespace palplab::engine
