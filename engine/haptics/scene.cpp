#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/input_error.hpp"
#include "engine/haptics/contact.hpp"

#include "engine/haptics/scene_config.hpp"
#include "engine/models/model.hpp"
#include "engine/spatial/octree.hpp"

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
    case EventKind::tool_changed:
      return "tool_changed";
    case EventKind::insertion_start:
      return "insertion_start";
    case EventKind::tissue_entered:
      return "tissue_entered";
    case EventKind::tissue_left:
      return "tissue_left";
    case EventKind::bone_contact:
      return "bone_contact";
    case EventKind::target_reached:
      return "target_reached";
    case EventKind::tip_to_target:
      return "tip_to_target";
    case EventKind::contact_inside:
      return "contact_inside";
    case EventKind::device_jump:
      return "device_jump";
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
  if (n == 0)
    throw InputError("region '" + name +
                     "' has no vertex on the surface (a tissue inside the body): it cannot be "
                     "pressed, touched or aimed at");
  return c / static_cast<double>(n);
}

int SceneGeometry::nearest_node(const Eigen::Vector3d& p) const {
  if (octree) return spatial::nearest(*octree, V, p);
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

// --- the scene's state (private: tools and tests use the public API and SceneConfig) ---

struct SceneImpl {
  SceneConfig cfg;
  std::shared_ptr<const SceneMesh> mesh;
  std::unique_ptr<SceneModel> model;
  SceneGeometry geom;
  std::unique_ptr<ContactTracker> tracker;  // god-object proxy on the rest surface
  std::vector<Thresholds> thresholds;       // per region
  Thresholds default_thresholds;            // for unlabelled contacts

  // --- state ---
  long step_index = 0;
  double t = 0.0;
  bool contact = false;  // force is being exchanged
  int node = -1;         // surface node of the contact
  // The logged touch (contact_start .. contact_end): contacts separated by less than
  // kTouchGap are one touch. lift_t >= 0: the contact was lost then, its end not yet logged.
  bool touch = false;
  double lift_t = -1.0;
  int lift_node = -1;
  double peak_force = 0.0;                  // of the touch
  bool reached[3] = {false, false, false};  // ST, MPF, SFT in this touch
  bool limited = false, energy_flagged = false, device_bad = false;
  double energy_out = 0.0;  // J: work of the rendered force on the hand in this contact
  Eigen::Vector3d x_prev = Eigen::Vector3d::Zero(), f_prev = Eigen::Vector3d::Zero();
  double model_depth = 0.0;  // m, depth given to the model last step (0 without contact)
  double model_force = 0.0;  // N, the model's unclamped force last step
  std::vector<Event> events;
  // Rendered::visible_volume (Scene::set_visible_volume): on, the rest area of each surface
  // vertex (a third of its faces'), the value of the last frame and the step of the next.
  bool volume_on = false;
  Eigen::VectorXd rest_area;
  double volume = 0.0;
  long next_frame = 0;
  int pending_tool_event = -1;  // a tool_changed event for the next step (value), -1 = none
  Sample last;
  SceneStats counters;
};

// --- Scene ---

Scene::Scene(std::unique_ptr<SceneImpl> impl) : impl_(std::move(impl)) {
  impl_->events.reserve(16);
  reset();
}
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;
Scene::~Scene() = default;

double Scene::dt() const {
  return impl_->cfg.dt;
}
double Scene::time() const {
  return impl_->t;
}
const SceneGeometry& Scene::geometry() const {
  return impl_->geom;
}
const std::string& Scene::prototype() const {
  return impl_->cfg.id;
}
const char* Scene::model_kind() const {
  return impl_->model->kind();
}
const SceneConfig& Scene::config() const {
  return impl_->cfg;
}
std::string Scene::tool() const {
  return impl_->model->tool();
}
void Scene::set_tool(const std::string& tool, const Eigen::Vector3d& stylus_axis) {
  SceneImpl& s = *impl_;
  const std::string before = s.model->tool();
  if (!stylus_axis.allFinite() || !(stylus_axis.norm() > 0.0))
    throw InputError("set_tool: the stylus axis must be finite and non-zero", s.cfg.source);
  if (!s.model->set_tool(tool, stylus_axis.normalized()))
    throw InputError("model \"" + std::string(s.model->kind()) + "\" has no tool \"" + tool + "\"",
                     s.cfg.source);
  if (tool != before) s.pending_tool_event = tool == "needle" ? 1 : 0;
}
void Scene::set_realtime(bool realtime) {
  impl_->model->set_realtime(realtime);
}
void Scene::set_visible_volume(bool on) {
  SceneImpl& s = *impl_;
  s.volume_on = on;
  if (on && s.rest_area.size() == 0) {
    const SceneGeometry& g = s.geom;
    s.rest_area = Eigen::VectorXd::Zero(g.V.rows());
    for (Eigen::Index f = 0; f < g.F.rows(); ++f) {
      const Eigen::Vector3d a = g.V.row(g.F(f, 0)), b = g.V.row(g.F(f, 1)), c = g.V.row(g.F(f, 2));
      const double third = (b - a).cross(c - a).norm() / 6.0;
      for (int k = 0; k < 3; ++k) s.rest_area[g.F(f, k)] += third;
    }
  }
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
  s.contact = false;
  s.node = -1;
  s.touch = false;
  s.lift_t = -1.0;
  s.lift_node = -1;
  s.tracker->reset();
  s.peak_force = 0.0;
  s.reached[0] = s.reached[1] = s.reached[2] = false;
  s.events.clear();
  s.last = Sample{0.0, s.geom.start_position, Eigen::Vector3d::Zero(), -1};
  s.limited = s.energy_flagged = s.device_bad = false;
  s.energy_out = 0.0;
  s.x_prev = s.geom.start_position;
  s.f_prev.setZero();
  s.model_depth = s.model_force = 0.0;
  s.volume = 0.0;
  s.next_frame = 0;
  s.counters = SceneStats{};
  s.pending_tool_event = -1;
  s.model->reset();
}

Rendered Scene::step(const Eigen::Vector3d& x_in) {
  SceneImpl& s = *impl_;
  s.events.clear();
  ++s.step_index;
  s.t = static_cast<double>(s.step_index) * s.cfg.dt;
  if (s.pending_tool_event >= 0)
    s.events.push_back({s.t, EventKind::tool_changed, -1, -1, double(s.pending_tool_event)});
  s.pending_tool_event = -1;
  const SceneGeometry& g = s.geom;
  // A non-finite or absurd device position (a broken driver, a NaN from a bridge; no device
  // reaches a kilometre) is no contact: the hand is taken to be where it last was valid,
  // disengaged.
  const bool valid = x_in.allFinite() && x_in.cwiseAbs().maxCoeff() <= kMaxDevicePosition;
  if (!valid && !s.device_bad) s.events.push_back({s.t, EventKind::device_invalid, -1, -1, 0.0});
  const bool was_bad = s.device_bad;  // the tracker was reset: a return is no jump
  s.device_bad = !valid;
  const Eigen::Vector3d x = valid ? x_in : s.last.x;

  // --- contact tracking: a god-object proxy on the rest surface (engine/haptics/contact.hpp).
  // The device's path since the last valid step is tested against the surface, so no speed
  // tunnels through it, and the proxy cannot cross it, so depth never jumps to the far side.
  ContactTracker& tr = *s.tracker;
  // A jump (review 2026-12-07: a hand reported 2 m away for 0.5 s caught, on its way back, on
  // the far ovary and was held at the 8.5 N limit in free air until the session ended): the
  // contact is found anew, and the jump does no work in the passivity observer.
  if (const double jump = (x - s.x_prev).norm();
      valid && !was_bad && s.step_index > 1 && jump > kMaxDeviceStep) {
    s.events.push_back({s.t, EventKind::device_jump, -1, -1, jump});
    tr.invalidate();
    s.f_prev.setZero();
  }
  if (valid)
    tr.update(s.x_prev, x);
  else
    tr.invalidate();
  ContactInput ci;
  ci.x = x;
  if (tr.engaged()) {
    ci.node = tr.node();
    ci.n = tr.normal();
    ci.face = tr.proxy().face;
    ci.w = tr.proxy().w;
    ci.proxy = tr.proxy().p;
    ci.depth = tr.depth();
    s.node = ci.node;
    if (tr.started_inside())
      s.events.push_back(
          {s.t, EventKind::contact_inside, g.vertex_region[ci.node], ci.node, tr.depth()});
    // Device saturation: the device renders at most force_limit, so no model is pushed with
    // more than twice that. The tissue's surface under the probe was last step at
    // depth_model - f_model / k (the coupling's stretch); the device position given to the model
    // is held at most 2 force_limit / k below it. A jump of the device deep into the organ then
    // pushes a deformable model with a bounded force instead of a 3 cm step of the coupling (it
    // drove prototype C into an inverted state it never left); the rendered force stays pinned
    // at the limit (force_limited).
    const double k = s.cfg.contact.stiffness, fmax = s.cfg.contact.force_limit;
    const double surface =
        s.model_depth > 0.0 ? std::max(0.0, s.model_depth - s.model_force / k) : 0.0;
    const double cap = surface + 2.0 * fmax / k;
    if (ci.depth > cap) {
      ci.x += (ci.depth - cap) * ci.n;
      ci.depth = cap;
    }
  }
  const int node = ci.node;
  s.model_depth = node >= 0 ? ci.depth : 0.0;

  // --- the model ---
  const ModelOutput out = s.model->step(ci, s.cfg.dt);
  Eigen::Vector3d force = out.force;
  double deformation = out.deformation;
  if (out.events)
    for (Event e : *out.events) {
      e.t = s.t;
      s.events.push_back(e);
    }
  // --- watchdog ---
  const double f_model = force.norm();
  s.model_force = std::isfinite(f_model) ? f_model : 0.0;
  const WatchdogConfig& wd = s.cfg.watchdog;
  if (s.model->deformable() &&
      (!std::isfinite(f_model) || !std::isfinite(deformation) || f_model > wd.divergence_force ||
       deformation > wd.divergence_displacement)) {
    // Numerical blow-up (e.g. symplectic Euler on stiff tissue): a non-finite state, or one far
    // beyond anything physical. Log it and return to rest rather than render it to a hand.
    s.counters.nan_detected = true;
    ++s.counters.divergences;
    s.events.push_back(
        {s.t, EventKind::divergence, -1, node, std::isfinite(f_model) ? f_model : -1.0});
    s.model->reset();
    force.setZero();
    deformation = 0.0;
  } else if (!std::isfinite(f_model)) {
    force.setZero();  // a rigid surface cannot diverge; a non-finite input renders nothing
  }
  const double force_limit = s.cfg.contact.force_limit;
  if (force.norm() > force_limit) {
    // The device cannot render more: clamp (a rigid model keeps its state, nothing is reset).
    if (!s.limited) s.events.push_back({s.t, EventKind::force_limited, -1, node, force.norm()});
    s.limited = true;
    ++s.counters.force_limited;
    force *= force_limit / force.norm();
  }
  const double f = force.norm();
  const bool was_contact = s.contact;
  s.contact = node >= 0 && f > 0.0;
  const int region = s.contact ? g.vertex_region[node] : -1;
  if (s.contact && !was_contact) {
    s.limited = s.energy_flagged = false;
    s.energy_out = 0.0;
    if (!s.touch) {
      s.touch = true;
      s.peak_force = 0.0;
      s.reached[0] = s.reached[1] = s.reached[2] = false;
      s.events.push_back({s.t, EventKind::contact_start, region, node, 0.0});
    }
    s.lift_t = -1.0;  // a contact back within kTouchGap continues the touch
  }
  if (s.contact || was_contact) {
    // Passivity observer (Hannaford & Ryu 2002): the work of the force rendered in the last step
    // on the hand's motion since. A passive tissue returns at most what the hand put in.
    s.energy_out += s.f_prev.dot(x - s.x_prev);
    if (!s.energy_flagged && s.energy_out > wd.energy_threshold) {
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
  if (!s.contact && was_contact) {
    s.lift_t = s.t;
    s.lift_node = s.node;
  }
  // A touch ends when the contact has stayed lost for kTouchGap; the event carries the time of
  // the lift. A hand resting on the surface loses and regains a contact of a few mN step by step
  // (1-3 ms gaps: 9 500 contact events in nine 50 s sessions of exp2, review 2026-12-07).
  // (The lift's step is the first without contact: after kTouchGap / dt such steps the touch
  // has ended, so a contact back after exactly kTouchGap of none is a new touch.)
  if (s.touch && !s.contact && s.lift_t >= 0.0 && s.t - s.lift_t + s.cfg.dt >= kTouchGap - 1e-9) {
    s.events.push_back({s.lift_t, EventKind::contact_end, -1, s.lift_node, s.peak_force});
    s.touch = false;
    s.lift_t = -1.0;
  }

  Rendered r;
  r.t = s.t;
  r.force = s.cfg.cues.haptic ? force : Eigen::Vector3d::Zero();
  r.contact = s.contact;
  r.contact_node = s.contact ? node : -1;
  r.contact_region = region;
  r.visible_deformation =
      (s.cfg.cues.visual_deformation && s.model->deformable() && s.contact) ? deformation : 0.0;
  if (s.volume_on && s.cfg.cues.visual_deformation && s.model->deformable()) {
    if (s.step_index >= s.next_frame) {
      // A frame: the pushed-in volume of the coarse surface (rows in the geometry's order).
      mesh::Positions V;
      mesh::Faces F;
      s.model->surface(V, F);
      const Eigen::Index n = std::min<Eigen::Index>(V.rows(), g.V.rows());
      double vol = 0.0;
      for (Eigen::Index i = 0; i < n; ++i)
        vol += s.rest_area[i] * std::max(0.0, -(V.row(i) - g.V.row(i)).dot(g.N.row(i)));
      s.volume = vol;
      s.next_frame = s.step_index + std::max(1L, std::lround(1.0 / (kVisibleFrameRate * s.cfg.dt)));
    }
    if (r.visible_deformation > 0.0) r.visible_volume = s.volume;
  }
  r.audio =
      s.cfg.cues.audio && s.contact && thresholds(region).st > 0.0 && f >= thresholds(region).st;
  if (s.cfg.cues.transparency) {
    r.visible_tip_to_target = out.tip_to_target;
    r.visible_tip_tissue = out.tip_tissue;
  }
  r.events = std::span<const Event>(s.events.data(), s.events.size());
  s.last = Sample{s.t, x, r.force, r.contact_node};
  s.x_prev = x;
  s.f_prev = force;
  return r;
}

SceneStats Scene::stats() const {
  const SceneImpl& s = *impl_;
  SceneStats st = s.counters;
  s.model->stats(st);
  if (st.surface_coarse_nodes == 0) st.surface_coarse_nodes = st.coarse_nodes;
  return st;
}

void Scene::current_surface(mesh::Positions& V, mesh::Faces& F) const {
  impl_->model->surface(V, F);
}

// --- configuration ---

void apply(SceneConfig& cfg, const SceneOverrides& ov) {
  if (ov.haptic) cfg.cues.haptic = *ov.haptic;
  if (ov.visual_deformation) cfg.cues.visual_deformation = *ov.visual_deformation;
  if (ov.audio) cfg.cues.audio = *ov.audio;
  if (ov.transparency) cfg.cues.transparency = *ov.transparency;
  if (!ov.thresholds.empty()) {
    const auto& regions = mesh_region_names(cfg.mesh);
    for (const auto& [k, v] : ov.thresholds) {
      if (k != "*" && std::find(regions.begin(), regions.end(), k) == regions.end())
        throw InputError(
            "threshold override for unknown region \"" + k + "\" of prototype " + cfg.id,
            cfg.source);
      cfg.thresholds[k] = v;
    }
  }
  if (ov.integrator) {
    try {
      cfg.integrator = integrator_from_string(*ov.integrator);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("integrator override: ") + e.what(), cfg.source);
    }
  }
}

Scene make_scene(const SceneConfig& cfg) {
  const ModelKind* kind = find_model_kind(cfg.model);
  if (!kind) {
    std::string names;
    for (const auto& k : model_kinds()) names += (names.empty() ? "" : ", ") + std::string(k.name);
    throw InputError("unknown model kind \"" + cfg.model + "\" (expected one of: " + names + ")",
                     cfg.source);
  }
  auto impl = std::make_unique<SceneImpl>();
  SceneImpl& sc = *impl;
  sc.cfg = cfg;
  sc.mesh = scene_mesh(cfg.mesh);
  const SceneMesh& m = *sc.mesh;
  // The face index is the mesh's (shared, stored in a .psim file); a mesh made elsewhere without
  // one (tests) gets its own.
  sc.tracker = m.face_index ? std::make_unique<ContactTracker>(m.V, m.N, m.F, m.face_index)
                            : std::make_unique<ContactTracker>(m.V, m.N, m.F);

  SceneGeometry& g = sc.geom;
  g.V = m.V;
  g.N = m.N;
  g.F = m.F;
  g.vertex_region = m.vertex_region;
  g.region_names = m.region_names;
  g.octree = m.octree;
  if (cfg.start_position) {
    g.start_position = *cfg.start_position;
  } else {
    // 5 cm in front (-y) of the organ, at the height of its centre.
    const Eigen::Vector3d lo = g.V.colwise().minCoeff().transpose();
    const Eigen::Vector3d hi = g.V.colwise().maxCoeff().transpose();
    g.start_position = 0.5 * (lo + hi);
    g.start_position.y() = lo.y() - 0.05;
  }
  // Thresholds: per region as configured; "*" (or the config's default) fills the rest.
  const auto star = cfg.thresholds.find("*");
  sc.default_thresholds = star != cfg.thresholds.end() ? star->second : cfg.default_thresholds;
  sc.thresholds.assign(g.region_names.size(), sc.default_thresholds);
  for (size_t r = 0; r < g.region_names.size(); ++r) {
    const auto it = cfg.thresholds.find(g.region_names[r]);
    if (it != cfg.thresholds.end()) sc.thresholds[r] = it->second;
  }
  sc.model = kind->make(cfg, m);
  g.tissues = sc.model->tissue_surfaces();
  return Scene(std::move(impl));
}

}  // namespace palplab::engine
