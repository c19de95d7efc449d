#include <cmath>
#include <stdexcept>

#include "engine/haptics/scene_impl.hpp"

namespace palplab::engine {

const char* to_string(EventKind k) {
  switch (k) {
    case EventKind::contact_start:
      return "contact_start";
    case EventKind::contact_end:
      return "contact_end";
    case EventKind::st_reached:
      return "st_reached";
    case EventKind::mpf_reached:
      return "mpf_reached";
    case EventKind::sft_reached:
      return "sft_reached";
    case EventKind::force_limited:
      return "force_limited";
    case EventKind::divergence:
      return "divergence";
    case EventKind::energy_injected:
      return "energy_injected";
    case EventKind::device_invalid:
      return "device_invalid";
  }
  return "?";
}

const char* to_string(ModelKind k) {
  switch (k) {
    case ModelKind::penalty:
      return "penalty";
    case ModelKind::ring:
      return "ring";
    case ModelKind::mass_spring:
      return "mass_spring";
  }
  return "?";
}

// --- SceneGeometry ---

int SceneGeometry::region_index(const std::string& name) const {
  for (size_t k = 0; k < region_names.size(); ++k)
    if (region_names[k] == name) return static_cast<int>(k);
  return -1;
}

Eigen::Vector3d SceneGeometry::region_centroid(const std::string& name) const {
  const int r = region_index(name);
  if (r < 0) throw std::out_of_range("unknown region '" + name + "'");
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  long n = 0;
  for (size_t i = 0; i < vertex_region.size(); ++i)
    if (vertex_region[i] == r) {
      c += V.row(i).transpose();
      ++n;
    }
  if (n == 0) throw std::out_of_range("region '" + name + "' has no vertices");
  return c / static_cast<double>(n);
}

int SceneGeometry::nearest_node(const Eigen::Vector3d& p) const {
  if (search_index)
    return spatial::nearest(*std::static_pointer_cast<const spatial::Octree>(search_index), V, p);
  return spatial::linear_nearest(V, p);
}

int SceneGeometry::region_node(const std::string& name) const {
  const int r = region_index(name);
  const Eigen::Vector3d c = region_centroid(name);
  int best = -1;
  double bd = 0.0;
  for (size_t i = 0; i < vertex_region.size(); ++i)
    if (vertex_region[i] == r) {
      const double d = (V.row(i).transpose() - c).squaredNorm();
      if (best < 0 || d < bd) {
        best = static_cast<int>(i);
        bd = d;
      }
    }
  return best;
}

// --- Scene ---

Scene::Scene(std::unique_ptr<SceneImpl> impl) : impl_(std::move(impl)) {
  impl_->events.reserve(16);
  reset();
}
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;
Scene::~Scene() = default;

double Scene::dt() const {
  return impl_->dt;
}
double Scene::time() const {
  return impl_->t;
}
const SceneGeometry& Scene::geometry() const {
  return impl_->geom;
}
const std::string& Scene::prototype() const {
  return impl_->prototype;
}
const char* Scene::model_kind() const {
  return to_string(impl_->kind);
}
Sample Scene::last_sample() const {
  return impl_->last;
}

Thresholds Scene::thresholds(int region) const {
  if (region >= 0 && region < static_cast<int>(impl_->thresholds.size()))
    return impl_->thresholds[region];
  return impl_->default_thresholds;
}

namespace {

// Marks the nodes within scope_radius of `center` (rest positions, breadth-first through springs
// so that the scope never jumps across a gap to another part of the organ), nearest rings first,
// at most scope_max_nodes of them (a fine region such as an ovary would otherwise hold hundreds).
void compute_scope(MassSpringScene& ms, int center) {
  const MassSpringSystem& s = ms.model.sys;
  const long n = s.nodes();
  if (static_cast<long>(ms.in_scope.size()) != n) {
    ms.in_scope.assign(n, 0);
  } else {
    for (int i : ms.scope_nodes) ms.in_scope[i] = 0;
  }
  ms.scope_nodes.clear();
  ms.scope_center = center;
  if (center < 0) return;
  const Eigen::Vector3d c = s.X_rest.row(center).transpose();
  const double r2 = ms.scope_radius * ms.scope_radius;
  ms.in_scope[center] = 1;
  ms.scope_nodes.push_back(center);
  for (size_t q = 0; q < ms.scope_nodes.size(); ++q) {
    const int i = ms.scope_nodes[q];
    for (int k = s.adj_start[i]; k < s.adj_start[i + 1]; ++k) {
      const int e = s.adj_spring[k];
      const int j = s.springs.E(e, 0) == i ? s.springs.E(e, 1) : s.springs.E(e, 0);
      if (ms.in_scope[j] || (s.X_rest.row(j).transpose() - c).squaredNorm() > r2) continue;
      if (static_cast<int>(ms.scope_nodes.size()) >= ms.scope_max_nodes) return;
      ms.in_scope[j] = 1;
      ms.scope_nodes.push_back(j);
    }
  }
}

// The contact patch: surface nodes within patch_radius (rest distance, reached through surface
// springs from the centre) with their share of the probe face (lumped surface area).
void compute_patch(MassSpringScene& ms, int center) {
  MassSpringSystem& s = ms.model.sys;
  const Eigen::VectorXd& area = ms.model.surface_area;
  s.contact_nodes.clear();
  s.contact_weights.clear();
  ms.patch_center = center;
  ms.patch_nodes_version = s.nodes();
  const Eigen::Vector3d c = s.X_rest.row(center).transpose();
  const double r2 = ms.patch_radius * ms.patch_radius;
  s.contact_nodes.push_back(center);
  if (static_cast<long>(ms.patch_mark.size()) != s.nodes()) ms.patch_mark.assign(s.nodes(), 0);
  ms.patch_mark[center] = 1;
  for (size_t q = 0; q < s.contact_nodes.size(); ++q) {
    const int i = s.contact_nodes[q];
    for (int k = s.adj_start[i]; k < s.adj_start[i + 1]; ++k) {
      const int e = s.adj_spring[k];
      const int j = s.springs.E(e, 0) == i ? s.springs.E(e, 1) : s.springs.E(e, 0);
      if (ms.patch_mark[j] || !(area[j] > 0.0) ||
          (s.X_rest.row(j).transpose() - c).squaredNorm() > r2)
        continue;
      ms.patch_mark[j] = 1;
      s.contact_nodes.push_back(j);
    }
  }
  double sum = 0.0;
  for (int i : s.contact_nodes) sum += area[i];
  for (int i : s.contact_nodes) s.contact_weights.push_back(sum > 0 ? area[i] / sum : 1.0);
  for (int i : s.contact_nodes) ms.patch_mark[i] = 0;
}

const std::vector<std::uint8_t>* scope_mask(const MassSpringScene& ms) {
  return ms.scope_radius > 0.0 ? &ms.in_scope : nullptr;
}

void reset_mass_spring(MassSpringScene& ms) {
  simplify(ms.model);
  MassSpringSystem& s = ms.model.sys;
  s.X = s.X_rest;
  s.V.setZero();
  s.F_ext.setZero();
  s.contact_node = -1;
  ms.ws.DV.setZero(s.nodes(), 3);
  ms.refined_node = -1;
  ms.in_scope.assign(s.nodes(), 0);
  ms.scope_nodes.clear();
  ms.scope_center = -1;
  ms.patch_center = -1;
  s.contact_nodes.clear();
  s.contact_weights.clear();
  if (ms.sleep.enabled)
    sleep_all(s, ms.act);
  else
    activate_all(s, ms.act);
}

// After the node count changed (refine/simplify): resize the active set, keep who was awake,
// wake every new node.
void resync_active(MassSpringScene& ms) {
  const MassSpringSystem& s = ms.model.sys;
  const long n = s.nodes();
  if (!ms.sleep.enabled) {
    activate_all(s, ms.act);
    return;
  }
  // Keep the backward-Euler warm start of the coarse nodes; new nodes start from 0.
  const long dv_rows = ms.ws.DV.rows();
  ms.ws.DV.conservativeResize(n, 3);
  if (n > dv_rows) ms.ws.DV.bottomRows(n - dv_rows).setZero();
  if (ms.scope_radius > 0.0) {
    ms.scope_nodes.clear();  // the node count changed: rebuild the marks from scratch
    ms.in_scope.assign(n, 0);
    compute_scope(ms, ms.scope_center < n ? ms.scope_center : -1);
  }
  // New nodes start awake, but only inside the integration scope (the scope's cap holds after
  // refinement too).
  const long old = static_cast<long>(ms.act.is_active.size());
  ms.act.is_active.resize(n, 0);
  for (long i = old; i < n; ++i) ms.act.is_active[i] = ms.scope_radius > 0.0 ? ms.in_scope[i] : 1;
  ms.act.nodes.clear();
  for (long i = 0; i < n; ++i)
    if (ms.act.is_active[i] && (s.fixed.empty() || !s.fixed[i]))
      ms.act.nodes.push_back(static_cast<int>(i));
    else
      ms.act.is_active[i] = 0;
  rebuild_active_springs(s, ms.act);
  ms.scratch.assign(n, 0);
}

// A threshold event fires once per contact, at the first step whose force reaches the limit.
void check_threshold(SceneImpl& s, int which, double limit, double f, EventKind kind, int region) {
  if (!s.reached[which] && limit > 0.0 && f >= limit) {
    s.reached[which] = true;
    s.events.push_back({s.t, kind, region, s.node, f});
  }
}

}  // namespace

void Scene::reset() {
  SceneImpl& s = *impl_;
  s.step_index = 0;
  s.t = 0.0;
  s.engaged = s.contact = false;
  s.node = -1;
  s.peak_force = 0.0;
  s.reached[0] = s.reached[1] = s.reached[2] = false;
  s.events.clear();
  s.last = Sample{0.0, s.geom.start_position, Eigen::Vector3d::Zero(), -1};
  s.limited = s.energy_flagged = s.device_bad = false;
  s.energy_out = 0.0;
  s.x_prev = s.geom.start_position;
  s.f_prev.setZero();
  s.counters = SceneStats{};
  if (s.kind == ModelKind::ring) ring_reset(s.ring);
  if (s.kind == ModelKind::mass_spring) reset_mass_spring(s.ms);
}

Rendered Scene::step(const Eigen::Vector3d& x_in) {
  SceneImpl& s = *impl_;
  s.events.clear();
  ++s.step_index;
  s.t = static_cast<double>(s.step_index) * s.dt;
  const SceneGeometry& g = s.geom;
  // A non-finite or absurd device position (a broken driver, a NaN from a bridge; no device
  // reaches a kilometre) is no contact: the hand is taken to be where it last was valid,
  // disengaged.
  const bool valid = x_in.allFinite() && x_in.cwiseAbs().maxCoeff() < 1e3;
  if (!valid && !s.device_bad) s.events.push_back({s.t, EventKind::device_invalid, -1, -1, 0.0});
  s.device_bad = !valid;
  if (!valid) s.engaged = false;
  const Eigen::Vector3d x = valid ? x_in : s.last.x;

  // --- contact tracking on the rest surface (a god-object proxy walks over the surface from
  // the last contact node, so pushing through a thin part cannot jump to its far side) ---
  if (!valid) {
    // stay disengaged
  } else if (!s.engaged) {
    const int p = g.nearest_node(x);
    if (p >= 0) {
      const Eigen::Vector3d vp = g.V.row(p).transpose();
      const double pen = (vp - x).dot(g.N.row(p).transpose());
      if (pen > 0.0 && (x - vp).norm() < s.contact_radius) {
        s.engaged = true;
        s.node = p;
      }
    }
  } else {
    // The proxy follows the device's TANGENTIAL motion only: among the node and its first ring,
    // take the node with the smallest lateral offset of the device from its normal line. A
    // straight push keeps the node; sliding moves it; depth never makes it jump.
    auto lateral = [&](int q) {
      const Eigen::Vector3d d = x - g.V.row(q).transpose();
      const Eigen::Vector3d nq = g.N.row(q).transpose();
      return (d - d.dot(nq) * nq).squaredNorm();
    };
    for (int it = 0; it < 16; ++it) {
      int best = s.node;
      double bd = lateral(s.node);
      for (int q : s.surface_rings->first.row(s.node)) {
        const double d = lateral(q);
        if (d < bd) {
          bd = d;
          best = q;
        }
      }
      if (best == s.node) break;
      s.node = best;
    }
    const double pen = (g.V.row(s.node).transpose() - x).dot(g.N.row(s.node).transpose());
    if (!(pen > 0.0)) s.engaged = false;
  }
  const int node = s.engaged ? s.node : -1;
  const Eigen::Vector3d n =
      node >= 0 ? Eigen::Vector3d(g.N.row(node).transpose()) : Eigen::Vector3d::UnitZ();

  // --- the model ---
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  double deformation = 0.0;
  switch (s.kind) {
    case ModelKind::penalty: {
      if (node >= 0) force = s.contact_k * (g.V.row(node).transpose() - x).dot(n) * n;
      break;
    }
    case ModelKind::ring: {
      if (node >= 0) force = s.contact_k * (g.V.row(node).transpose() - x).dot(n) * n;
      ring_step(s.ring, node, -force, s.dt);
      if (node >= 0) deformation = (s.ring.X.row(node) - s.ring.X_fixed.row(node)).norm();
      s.counters.awake_nodes = s.ring.last_updated;
      break;
    }
    case ModelKind::mass_spring: {
      MassSpringScene& ms = s.ms;
      MassSpringSystem& sys = ms.model.sys;
      const int mnode = node >= 0 ? ms.surface_to_model[node] : -1;
      if (mnode >= 0) {
        sys.contact_node = mnode;
        sys.contact_point = x;
        sys.contact_normal = n;
        sys.contact_k = s.contact_k;
        if (ms.scope_radius > 0.0 && mnode != ms.scope_center) compute_scope(ms, mnode);
        if (mnode != ms.patch_center || ms.patch_nodes_version != sys.nodes())
          compute_patch(ms, mnode);
        if (ms.sleep.enabled)
          for (size_t q = 0; q < sys.contact_nodes.size(); ++q) {
            const int i = sys.contact_nodes[q];
            if (!ms.act.is_active[i] && (i == mnode || contact_node_penetration(sys, sys.X, q) > 0))
              wake_around(sys, ms.act, i, scope_mask(ms));
          }
      } else {
        sys.contact_node = -1;
        if (ms.model.refined() && ms.refine) {
          simplify(ms.model);
          ms.refined_node = -1;
          resync_active(ms);
        }
      }
      const int sub = ms.substep ? (1 << ms.model.level) : 1;
      const double h = s.dt / sub;
      for (int k = 0; k < sub; ++k) {
        integrate(sys, ms.act, h, ms.integrator, ms.ws);
        update_sleeping(sys, ms.act, ms.sleep, mnode, &ms.ws.DV, ms.scratch, scope_mask(ms));
      }
      if (mnode >= 0) {
        force = s.contact_k * contact_penetration(sys, sys.X) * n;
        deformation = (sys.X.row(mnode) - sys.X_rest.row(mnode)).norm();
        if (ms.refine && mnode != ms.refined_node && force.norm() >= ms.refine_force) {
          if (refine_around(ms.model, mnode, ms.refine_params)) resync_active(ms);
          ms.refined_node = mnode;
          s.counters.new_nodes_max = std::max(s.counters.new_nodes_max, ms.model.new_nodes);
          s.counters.new_springs_max = std::max(s.counters.new_springs_max, ms.model.new_springs);
        }
      }
      s.counters.awake_nodes = static_cast<long>(ms.act.nodes.size());
      break;
    }
  }
  // --- watchdog ---
  const double f_model = force.norm();
  if (s.kind != ModelKind::penalty &&
      (!std::isfinite(f_model) || !std::isfinite(deformation) || f_model > s.divergence_force ||
       deformation > s.divergence_displacement)) {
    // Numerical blow-up (e.g. symplectic Euler on stiff tissue): a non-finite state, or one far
    // beyond anything physical. Log it and return to rest rather than render it to a hand.
    s.counters.nan_detected = true;
    ++s.counters.divergences;
    s.events.push_back(
        {s.t, EventKind::divergence, -1, node, std::isfinite(f_model) ? f_model : -1.0});
    if (s.kind == ModelKind::mass_spring) reset_mass_spring(s.ms);
    if (s.kind == ModelKind::ring) ring_reset(s.ring);
    force.setZero();
    deformation = 0.0;
  } else if (!std::isfinite(f_model)) {
    force.setZero();  // a rigid surface cannot diverge; a non-finite input renders nothing
  }
  if (force.norm() > s.force_limit) {
    // The device cannot render more: clamp (a rigid model keeps its state, nothing is reset).
    if (!s.limited) s.events.push_back({s.t, EventKind::force_limited, -1, node, force.norm()});
    s.limited = true;
    ++s.counters.force_limited;
    force *= s.force_limit / force.norm();
  }
  const double f = force.norm();
  const bool was_contact = s.contact;
  s.contact = node >= 0 && f > 0.0;
  const int region = s.contact ? g.vertex_region[node] : -1;
  if (s.contact && !was_contact) {
    s.peak_force = 0.0;
    s.reached[0] = s.reached[1] = s.reached[2] = false;
    s.limited = s.energy_flagged = false;
    s.energy_out = 0.0;
    s.events.push_back({s.t, EventKind::contact_start, region, node, 0.0});
  }
  if (s.contact || was_contact) {
    // Passivity observer (Hannaford & Ryu 2002): the work of the force rendered in the last step
    // on the hand's motion since. A passive tissue returns at most what the hand put in.
    s.energy_out += s.f_prev.dot(x - s.x_prev);
    if (!s.energy_flagged && s.energy_out > s.energy_threshold) {
      s.energy_flagged = true;
      s.events.push_back({s.t, EventKind::energy_injected, region, node, s.energy_out});
    }
  }
  if (s.contact) {
    s.peak_force = std::max(s.peak_force, f);
    const Thresholds th = thresholds(region);
    check_threshold(s, 0, th.st, f, EventKind::st_reached, region);
    check_threshold(s, 1, th.mpf, f, EventKind::mpf_reached, region);
    check_threshold(s, 2, th.sft, f, EventKind::sft_reached, region);
  }
  if (!s.contact && was_contact)
    s.events.push_back({s.t, EventKind::contact_end, -1, s.node, s.peak_force});

  Rendered r;
  r.t = s.t;
  r.force = s.cues.haptic ? force : Eigen::Vector3d::Zero();
  r.contact = s.contact;
  r.contact_node = s.contact ? node : -1;
  r.contact_region = region;
  r.visible_deformation =
      (s.cues.visual_deformation && s.kind != ModelKind::penalty && s.contact) ? deformation : 0.0;
  r.audio = s.cues.audio && s.contact && thresholds(region).st > 0.0 && f >= thresholds(region).st;
  r.events = std::span<const Event>(s.events.data(), s.events.size());
  s.last = Sample{s.t, x, r.force, r.contact_node};
  s.x_prev = x;
  s.f_prev = force;
  return r;
}

SceneStats Scene::stats() const {
  const SceneImpl& s = *impl_;
  SceneStats st = s.counters;
  switch (s.kind) {
    case ModelKind::penalty:
      st.nodes = st.coarse_nodes = s.geom.V.rows();
      break;
    case ModelKind::ring:
      st.nodes = st.coarse_nodes = s.ring.X.rows();
      st.springs = st.coarse_springs = s.ring.X.rows();  // one home spring per node
      st.max_rest_error = ring_max_displacement(s.ring);
      break;
    case ModelKind::mass_spring: {
      const MassSpringSystem& sys = s.ms.model.sys;
      st.nodes = sys.nodes();
      st.springs = sys.springs.size();
      st.coarse_nodes = s.ms.model.coarse_nodes();
      st.coarse_springs = s.ms.model.coarse_springs();
      st.total_mass = sys.mass.sum();
      st.max_rest_error = (sys.X - sys.X_rest).rowwise().norm().maxCoeff();
      st.level = s.ms.model.level;
      break;
    }
  }
  return st;
}

void Scene::current_surface(RowMatX3d& V, RowMatX3i& F) const {
  const SceneImpl& s = *impl_;
  switch (s.kind) {
    case ModelKind::penalty:
      V = s.geom.V;
      F = s.geom.F;
      break;
    case ModelKind::ring:
      V = s.ring.X;
      F = s.geom.F;
      break;
    case ModelKind::mass_spring:
      V = s.ms.model.sys.X;
      F = s.ms.model.F;
      break;
  }
}

}  // namespace palplab::engine
