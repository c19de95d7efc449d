#include "engine/models/ring_model.hpp"

#include <stdexcept>

namespace palplab::engine {

Scope scope_from_string(const std::string& s) {
  if (s == "rings") return Scope::rings;
  if (s == "octant") return Scope::octant;
  if (s == "whole") return Scope::whole;
  throw std::invalid_argument("unknown scope '" + s + "' (expected rings, octant or whole)");
}
const char* to_string(Scope s) {
  switch (s) {
    case Scope::rings:
      return "rings";
    case Scope::octant:
      return "octant";
    case Scope::whole:
      return "whole";
  }
  return "?";
}

RingModel make_ring_model(const RowMatX3d& V, const mesh::Edges& E, const RingParams& p) {
  RingModel m;
  m.X_fixed = V;
  m.X = V;
  m.V.setZero(V.rows(), 3);
  m.rings = mesh::compute_rings(static_cast<int>(V.rows()), E);
  m.params = p;
  m.is_active.assign(V.rows(), 0);
  m.pressed.assign(V.rows(), 0);
  m.active.reserve(256);
  return m;
}

namespace {

inline void activate(RingModel& m, int i) {
  if (!m.is_active[i]) {
    m.is_active[i] = 1;
    m.active.push_back(i);
  }
}

// Backward Euler of m x'' = ks (x0 - x) - kd x' for one node. Returns true (and puts the node
// exactly home) once it is within rest_tol of home and slower than rest_tol per step.
inline bool home_step(RingModel& m, int i, double h) {
  const RingParams& p = m.params;
  const double denom = p.node_mass + h * p.home_kd + h * h * p.home_ks;
  m.V.row(i) = (p.node_mass * m.V.row(i) + h * p.home_ks * (m.X_fixed.row(i) - m.X.row(i))) / denom;
  m.X.row(i) += h * m.V.row(i);
  const double tol2 = p.rest_tol * p.rest_tol;
  if ((m.X.row(i) - m.X_fixed.row(i)).squaredNorm() < tol2 &&
      m.V.row(i).squaredNorm() * (h * h) < tol2) {
    m.X.row(i) = m.X_fixed.row(i);
    m.V.row(i).setZero();
    return true;
  }
  return false;
}

}  // namespace

void ring_step(RingModel& m, int node, const Eigen::Vector3d& push, double h) {
  long visited = 0;
  // 1. Kinematic placement of the pressed node and its two rings (Eq 4.2–4.4).
  if (node >= 0) {
    auto place = [&](int i, double step) {
      m.X.row(i) = m.X_fixed.row(i) + step * push.transpose();
      m.V.row(i).setZero();
      m.pressed[i] = 1;
      activate(m, i);
      ++visited;
    };
    place(node, m.params.m1);
    for (int q : m.rings.first.row(node)) place(q, m.params.m2);
    for (int r : m.rings.second.row(node)) place(r, m.params.m3);
  }
  // 2. Home springs for every other node in scope.
  if (m.scope == Scope::whole) {
    for (long i = 0; i < m.X.rows(); ++i)
      if (!m.pressed[i]) {
        home_step(m, static_cast<int>(i), h);
        ++visited;
      }
  } else {
    if (m.scope == Scope::octant && node >= 0 && m.octree)
      for (int i : spatial::leaf_points(*m.octree, spatial::leaf_of(*m.octree, node))) {
        if (!m.pressed[i] && !m.is_active[i]) home_step(m, i, h);  // active ones: below
        ++visited;
      }
    size_t w = 0;
    for (size_t k = 0; k < m.active.size(); ++k) {
      const int i = m.active[k];
      if (!m.pressed[i]) {
        ++visited;
        if (home_step(m, i, h)) {  // home: stop updating it
          m.is_active[i] = 0;
          continue;
        }
      }
      m.active[w++] = i;
    }
    m.active.resize(w);
  }
  // 3. Clear the pressed marks (only the nodes just placed).
  if (node >= 0) {
    m.pressed[node] = 0;
    for (int q : m.rings.first.row(node)) m.pressed[q] = 0;
    for (int r : m.rings.second.row(node)) m.pressed[r] = 0;
  }
  m.last_updated = visited;
}

void ring_reset(RingModel& m) {
  m.X = m.X_fixed;
  m.V.setZero();
  for (int i : m.active) m.is_active[i] = 0;
  m.active.clear();
}

double ring_max_displacement(const RingModel& m) {
  return (m.X - m.X_fixed).rowwise().norm().maxCoeff();
}

}  // namespace palplab::engine
