#include "engine/models/ring_model.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "engine/models/model.hpp"

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
  return make_ring_model(
      V,
      std::make_shared<const mesh::RingTable>(mesh::compute_rings(static_cast<int>(V.rows()), E)),
      p);
}

RingModel make_ring_model(const RowMatX3d& V, std::shared_ptr<const mesh::RingTable> rings,
                          const RingParams& p) {
  if (!rings || rings->first.offset.size() != static_cast<std::size_t>(V.rows()) + 1 ||
      rings->second.offset.size() != static_cast<std::size_t>(V.rows()) + 1)
    throw std::invalid_argument("make_ring_model: ring tables of another mesh");
  RingModel m;
  m.X_fixed = V;
  m.X = V;
  m.V.setZero(V.rows(), 3);
  m.rings = std::move(rings);
  m.params = p;
  m.is_active.assign(V.rows(), 0);
  m.pressed.assign(V.rows(), 0);
  m.coef.assign(V.rows(), 0.0);
  m.active.reserve(256);
  m.placed.reserve(V.rows());
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
  const int nodes[3] = {node, -1, -1};
  const double w[3] = {1.0, 0.0, 0.0};
  ring_step(m, nodes, w, push, h);
}

void ring_step(RingModel& m, const int nodes[3], const double w[3], const Eigen::Vector3d& push,
               double h) {
  long visited = 0;
  int node = -1;  // the heaviest touched node (the octant of Scope::octant)
  double wmax = 0.0;
  for (int k = 0; k < 3; ++k)
    if (nodes[k] >= 0 && w[k] > wmax) {
      wmax = w[k];
      node = nodes[k];
    }
  // 1. Kinematic placement of the pressed nodes and their two rings (Eq 4.2–4.4), weighted.
  std::vector<int>& placed = m.placed;
  placed.clear();
  if (node >= 0) {
    auto add = [&](int i, double c) {
      if (!m.pressed[i]) {
        m.pressed[i] = 1;
        m.coef[i] = 0.0;
        placed.push_back(i);
      }
      m.coef[i] += c;
    };
    for (int k = 0; k < 3; ++k) {
      if (nodes[k] < 0 || !(w[k] > 0.0)) continue;
      const int p = nodes[k];
      add(p, w[k] * m.params.m1);
      for (int q : m.rings->first.row(p)) add(q, w[k] * m.params.m2);
      for (int r : m.rings->second.row(p)) add(r, w[k] * m.params.m3);
    }
    // The weighted sum of the rings dents the contact point by less than m1 between nodes (the
    // face's vertices are in each other's first ring, m2 < m1): scale it so the point itself is
    // displaced by exactly m1 F, as at a node. The scale is 1 at a node and continuous in w.
    double at_point = 0.0;
    for (int k = 0; k < 3; ++k)
      if (nodes[k] >= 0 && w[k] > 0.0) at_point += w[k] * m.coef[nodes[k]];
    const double scale = at_point > 0.0 ? m.params.m1 / at_point : 1.0;
    for (int i : placed) {
      m.X.row(i) = m.X_fixed.row(i) + scale * m.coef[i] * push.transpose();
      m.V.row(i).setZero();
      activate(m, i);
      ++visited;
    }
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
  for (int i : placed) m.pressed[i] = 0;
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

// ---------------------------------------------------------------- model "ring" of a scene

namespace {

class RingSceneModel final : public SceneModel {
 public:
  RingSceneModel(const SceneConfig& cfg, const SceneMesh& m)
      : mesh_(m),
        k_(cfg.contact.stiffness),
        // The prepared mesh's ring tables (computed once per mesh, or loaded from a .psim).
        model_(m.rings ? make_ring_model(m.V, m.rings, cfg.ring)
                       : make_ring_model(m.V, m.E, cfg.ring)) {
    model_.scope = cfg.scope.rings;
    model_.octree = m.octree.get();
  }
  const char* kind() const override { return "ring"; }
  ModelOutput step(const ContactInput& c, double dt) override {
    // The haptic force is Hooke's law on the penetration, as in prototype A; the rings show the
    // push of the hand (the opposite force).
    // The push is shared by the proxy face's vertices with its barycentric weights, so sliding
    // from node to node moves the dent continuously; the visible deformation is the displacement
    // interpolated at the contact point.
    ModelOutput o;
    if (c.node < 0) {
      ring_step(model_, c.node, Eigen::Vector3d::Zero(), dt);
      return o;
    }
    o.force = k_ * std::max(0.0, c.depth) * c.n;
    int nodes[3] = {c.node, -1, -1};
    double w[3] = {1.0, 0.0, 0.0};
    if (c.face >= 0)
      for (int k = 0; k < 3; ++k) {
        nodes[k] = mesh_.F(c.face, k);
        w[k] = c.w[k];
      }
    ring_step(model_, nodes, w, -o.force, dt);
    Eigen::Vector3d u = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k)
      if (nodes[k] >= 0)
        u += w[k] * (model_.X.row(nodes[k]) - model_.X_fixed.row(nodes[k])).transpose();
    o.deformation = u.norm();
    return o;
  }
  void reset() override { ring_reset(model_); }
  void stats(SceneStats& s) const override {
    s.nodes = s.coarse_nodes = model_.X.rows();
    s.springs = s.coarse_springs = model_.X.rows();  // one home spring per node
    s.max_rest_error = ring_max_displacement(model_);
    s.awake_nodes = model_.last_updated;
  }
  void surface(mesh::Positions& V, mesh::Faces& F) const override {
    V = model_.X;
    F = mesh_.F;
  }

 private:
  const SceneMesh& mesh_;
  double k_;
  RingModel model_;
};

void read_ring(json::Checker& c, const nlohmann::json& m, const std::string& P, SceneConfig& cfg,
               const std::vector<std::string>&) {
  c.keys(m, P, {"kind", "m1", "m2", "m3", "node_mass", "home_stiffness", "home_damping", "scope"});
  RingParams& r = cfg.ring;
  r.m1 = c.number(m, P, "m1", true, 0, 1, "the touched node's step size |m1| (m/N)", true)
             .value_or(r.m1);
  r.m2 = c.number(m, P, "m2", true, 0, 1, "the first ring's step size |m2| (m/N)").value_or(r.m2);
  r.m3 = c.number(m, P, "m3", true, 0, 1, "the second ring's step size |m3| (m/N)").value_or(r.m3);
  if (c.ok() && !(r.m1 > r.m2 && r.m2 > r.m3))
    c.err(P, "expected |m1| > |m2| > |m3| (displacement deepest at the touched node)");
  r.node_mass =
      c.number(m, P, "node_mass", false, 0, 10, "the node mass (kg)", true).value_or(r.node_mass);
  r.home_ks = c.number(m, P, "home_stiffness", false, 0, 1e6, "home-spring stiffness (N/m)", true)
                  .value_or(r.home_ks);
  r.home_kd = c.number(m, P, "home_damping", false, 0, 1e4, "home-spring damping (N s/m)")
                  .value_or(r.home_kd);
  if (auto sc = c.text(m, P, "scope", false, {"rings", "octant", "whole"}))
    cfg.scope.rings = scope_from_string(*sc);
}

void check_ring(json::Checker& c, const SceneConfig& cfg) {
  if (cfg.ring.m1 * cfg.contact.stiffness > 1.0 + 1e-12)
    c.err("$.model.m1", "m1 = " + nlohmann::json(cfg.ring.m1).dump() +
                            " m/N shows the touched node " +
                            nlohmann::json(cfg.ring.m1 * cfg.contact.stiffness).dump() +
                            " times deeper than the penetration it renders (contact stiffness " +
                            nlohmann::json(cfg.contact.stiffness).dump() +
                            " N/m): expected m1 <= 1 / contact stiffness");
}

std::unique_ptr<SceneModel> make_ring(const SceneConfig& cfg, const SceneMesh& m) {
  // The rings must not show more than the penetration the force renders (|m1| k <= 1).
  if (cfg.ring.m1 * cfg.contact.stiffness > 1.0 + 1e-12)
    throw InputError("m1 = " + std::to_string(cfg.ring.m1) + " m/N shows the touched node " +
                         std::to_string(cfg.ring.m1 * cfg.contact.stiffness) +
                         " times deeper than the penetration it renders (contact stiffness " +
                         std::to_string(cfg.contact.stiffness) +
                         " N/m): expected m1 <= 1 / contact stiffness",
                     cfg.source);
  return std::make_unique<RingSceneModel>(cfg, m);
}

}  // namespace

const ModelKind& ring_model_kind() {
  static const ModelKind k{"ring",
                           "vertex-based visio-haptic ring model, force as in A (prototype B)",
                           &read_ring, &check_ring, &make_ring};
  return k;
}

}  // namespace palplab::engine
