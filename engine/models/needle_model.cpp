// Model "needle" (prototype N, issue 16): the needle-insertion scene with two tools on one tet
// mesh whose tets carry their tissue (the procedural shoulder, generator "shoulder").
//
//  * "finger": palpates the skin surface only (the scene's contact tracking gives the touched
//    skin node). The force is that of a flat fingertip of radius a indenting the soft layers
//    above the first bone along the inward normal (thickness h; Young's modulus E of the layers
//    within 3 a of the skin in series, z / E = sum z_i / E_i, from the material table):
//       k(h) = 2 E a / (1 - nu^2) + E pi a^2 / h        (half-space + layer on a rigid base)
//       F    = k(h) (h / beta) (exp(beta d / h) - 1) + k_bone max(0, d - 0.7 h)
//    d = indentation. The first term has the limits of Hayes et al. 1972 (thick layer: the
//    Boussinesq flat punch; thin layer: uniaxial compression of a bonded layer, ~1/h); the
//    exponential is the strain stiffening of soft tissue (Fung 1993), so the same indentation
//    feels stiffer where bone is near the skin; beyond 70 % compression the finger feels the
//    bone through squeezed tissue. No bone under the node: the half-space term alone.
//  * "needle": engine/models/needle.hpp (per-tissue puncture, cutting, shaft friction) along the
//    stylus axis set by Scene::set_tool, locked at the entry point. Its events become the scene's
//    (tissue_entered/left, bone_contact, target_reached, insertion_start) and the tip's distance
//    to the target is logged as tip_to_target events (every log_resolution of change).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>

#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/models/model.hpp"
#include "engine/models/needle.hpp"

namespace palplab::engine {

namespace {

constexpr double kCompressionLimit = 0.7;  // share of h beyond which the bone is felt
constexpr double kPoisson = 0.45;          // soft tissue (the table's value for fat and muscle)
constexpr double kStressDepth = 3.0;       // finger radii of tissue that set the modulus

class NeedleSceneModel final : public SceneModel {
 public:
  // `stored`: the model's part of a .psim file (save_blob), or nullptr.
  NeedleSceneModel(const SceneConfig& cfg, const SceneMesh& m, const std::string* stored)
      : cfg_(cfg.needle),
        mesh_(m),
        needle_(m.model_V, m.model_T, m.tet_attribute, mesh::default_materials(),
                needle_options(cfg), stored ? stored_needle(*stored) : std::string_view()) {
    finger_h_.assign(m.V.rows(), -1.0);
    finger_E_.assign(m.V.rows(), 0.0);
    if (stored && needle_.restored()) restore_finger(*stored);
    reset();
  }

  // The .psim blob: the needle model's precomputation and the finger's layer table of every
  // skin node (what layer_under computes on first touch), for this finger radius:
  //   u64 n, n bytes NeedleModel::save; f64 finger_radius; u64 #V; #V f64 h; #V f64 E.
  std::string save_blob() {
    for (long v = 0; v < mesh_.V.rows(); ++v) layer_under(static_cast<int>(v));
    const std::string n = needle_.save();
    std::string s;
    auto put = [&](const void* p, std::size_t k) { s.append(static_cast<const char*>(p), k); };
    const std::uint64_t len = n.size(), nv = finger_h_.size();
    put(&len, 8);
    s += n;
    put(&cfg_.finger_radius, 8);
    put(&nv, 8);
    put(finger_h_.data(), 8 * nv);
    put(finger_E_.data(), 8 * nv);
    return s;
  }
  const char* kind() const override { return "needle"; }
  // Rigid bone walls and popping membranes: no divergence watchdog on this model.
  bool deformable() const override { return false; }

  std::shared_ptr<const TissueSurfaces> tissue_surfaces() const override {
    if (!tissues_) tissues_ = build_tissue_surfaces();
    return tissues_;
  }

  std::string tool() const override { return needle_tool_ ? "needle" : "finger"; }
  bool set_tool(const std::string& tool, const Eigen::Vector3d& axis) override {
    if (tool != "finger" && tool != "needle") return false;
    const bool needle = tool == "needle";
    if (needle_tool_ && !needle) end_insertion();  // the needle is put down (taken out)
    needle_tool_ = needle;
    axis_ = axis;
    return true;
  }

  ModelOutput step(const ContactInput& c, double) override {
    fresh_events();
    ModelOutput o;
    o.events = &events_;
    if (needle_tool_) {
      needle_step(c, o);
    } else if (c.node >= 0) {
      const double d = (mesh_.V.row(c.node).transpose() - c.x).dot(c.n);
      if (d > 0) {
        o.force = finger_force(c.node, d) * c.n;
        o.deformation = d;
      }
    }
    delivered_ = true;  // the scene copies them now
    return o;
  }

  void reset() override {
    needle_.reset();
    needle_tool_ = cfg_.tool == "needle";
    axis_ = cfg_.axis.normalized();
    inserted_ = false;
    insertions_ = bone_contacts_ = 0;
    last_logged_ = -1.0;
    events_.clear();
    delivered_ = false;
  }

  void stats(SceneStats& s) const override {
    s.nodes = s.coarse_nodes = mesh_.model_V.rows();
    nlohmann::json info = {{"needle",
                            {{"tool", tool()},
                             {"insertions", insertions_},
                             {"bone_contacts", bone_contacts_},
                             {"target_tissue", cfg_.target_tissue},
                             {"tets", mesh_.model_T.rows()}}}};
    s.model_info = info.dump();
  }
  void surface(mesh::Positions& V, mesh::Faces& F) const override {
    V = mesh_.V;
    F = mesh_.F;
  }

  // Soft-layer thickness h above the first bone along the inward normal of skin node v and the
  // layers' series modulus (m, Pa); h = inf when no bone lies below. Cached per node.
  std::pair<double, double> layer_under(int v) {
    if (finger_h_[v] >= 0) return {finger_h_[v], finger_E_[v]};
    const Vec3 n = mesh_.N.row(v).transpose();
    const Vec3 p = mesh_.V.row(v).transpose();
    const double eps = 1e-6;
    double h = std::numeric_limits<double>::infinity(), compliance = 0.0, soft = 0.0;
    for (const NeedleLayer& l : needle_.layers_along(p + eps * n, -n)) {
      if (l.tissue < 0) {
        if (l.enter > eps) break;  // left the body
        continue;
      }
      const NeedleTissue& t = needle_.tissue(l.tissue);
      if (t.rigid) {
        h = std::max(l.enter - eps, 1e-4);
        break;
      }
      // The modulus is that of the tissue within kStressDepth finger radii of the skin: the
      // stress under a flat punch decays within a few radii (Boussinesq), deeper layers only
      // matter through h.
      const mesh::Material* m = mesh::default_materials().find(l.tissue);
      const double window = kStressDepth * cfg_.finger_radius;
      const double len = std::min(l.exit, window) - std::max(l.enter, 0.0);
      if (len > 0) {
        compliance += len / m->youngs_modulus;
        soft += len;
      }
      if (l.exit >= 0.2) break;  // beyond 20 cm: no bone under this point
    }
    finger_h_[v] = h;
    finger_E_[v] = soft > 0 ? soft / compliance : 1e4;
    return {finger_h_[v], finger_E_[v]};
  }

  double finger_force(int v, double d) {
    const auto [h, E] = layer_under(v);
    const double a = cfg_.finger_radius;
    const double k_half = 2.0 * E * a / (1.0 - kPoisson * kPoisson);
    if (!std::isfinite(h)) return k_half * d;
    const double k = k_half + E * M_PI * a * a / h;
    const double b = cfg_.stiffening;
    const double f = b > 0 ? k * h / b * std::expm1(b * d / h) : k * d;
    return f + cfg_.bone_stiffness * std::max(0.0, d - kCompressionLimit * h);
  }

 private:
  // Each tissue's closed surface with its own vertices (shared within the tissue, so the
  // renderer's vertex normals are smooth), labelled with the tissue's region.
  std::shared_ptr<const TissueSurfaces> build_tissue_surfaces() const {
    auto out = std::make_shared<TissueSurfaces>();
    const auto& tf = needle_.tissue_faces();
    std::vector<int> tissues;
    for (const auto& f : tf) tissues.push_back(f.tissue);
    std::sort(tissues.begin(), tissues.end());
    tissues.erase(std::unique(tissues.begin(), tissues.end()), tissues.end());
    const long nn = mesh_.model_V.rows();
    std::vector<int> vertex(tissues.size() * nn, -1);  // (tissue, mesh node) -> vertex
    std::vector<std::array<int, 3>> faces;
    std::vector<int> node;
    faces.reserve(tf.size());
    for (const NeedleModel::TissueFace& f : tf) {
      const long ti = std::lower_bound(tissues.begin(), tissues.end(), f.tissue) - tissues.begin();
      std::array<int, 3> g{};
      for (int k = 0; k < 3; ++k) {
        int& v = vertex[ti * nn + f.v[k]];
        if (v < 0) {
          v = static_cast<int>(node.size());
          node.push_back(f.v[k]);
          out->vertex_region.push_back(region_of(f.tissue));
        }
        g[k] = v;
      }
      faces.push_back(g);
    }
    for (int t : tissues) {
      const int r = region_of(t);
      if (r >= 0 && !needle_.tissue(t).rigid && t != cfg_.target_tissue &&
          std::find(out->soft_regions.begin(), out->soft_regions.end(), r) ==
              out->soft_regions.end())
        out->soft_regions.push_back(r);
    }
    out->V.resize(static_cast<long>(node.size()), 3);
    for (std::size_t i = 0; i < node.size(); ++i) out->V.row(i) = mesh_.model_V.row(node[i]);
    out->F.resize(static_cast<long>(faces.size()), 3);
    for (std::size_t i = 0; i < faces.size(); ++i)
      for (int k = 0; k < 3; ++k) out->F(i, k) = faces[i][k];
    return out;
  }

  // The NeedleModel part of a stored blob (empty when malformed: the model then recomputes).
  static std::string_view stored_needle(const std::string& b) {
    std::uint64_t n = 0;
    if (b.size() >= 8) std::memcpy(&n, b.data(), 8);
    return b.size() >= 8 && n <= b.size() - 8 ? std::string_view(b).substr(8, n)
                                              : std::string_view();
  }
  // The finger table of a stored blob when it was made for this mesh and finger radius.
  void restore_finger(const std::string& b) {
    std::uint64_t n = 0, nv = 0;
    std::memcpy(&n, b.data(), 8);
    std::size_t at = 8 + n;
    double radius = 0;
    if (b.size() - at < 16) return;
    std::memcpy(&radius, b.data() + at, 8);
    std::memcpy(&nv, b.data() + at + 8, 8);
    at += 16;
    if (radius != cfg_.finger_radius || nv != finger_h_.size() || (b.size() - at) != 16 * nv)
      return;
    std::memcpy(finger_h_.data(), b.data() + at, 8 * nv);
    std::memcpy(finger_E_.data(), b.data() + at + 8 * nv, 8 * nv);
  }

  static NeedleOptions needle_options(const SceneConfig& cfg) {
    NeedleOptions o;
    o.target_tissue = cfg.needle.target_tissue;
    return o;
  }

  int region_of(int tissue) const {
    if (tissue < 0) return -1;
    const std::string& name = needle_.tissue(tissue).name;
    for (size_t r = 0; r < mesh_.region_names.size(); ++r)
      if (mesh_.region_names[r] == name) return static_cast<int>(r);
    return -1;
  }

  // Events made between two steps (set_tool taking the needle out) wait for the next step.
  void fresh_events() {
    if (delivered_) events_.clear();
    delivered_ = false;
  }

  void log_distance(double d) {
    fresh_events();
    events_.push_back({0.0, EventKind::tip_to_target, -1, -1, d});
    last_logged_ = d;
  }

  void end_insertion() {
    if (inserted_) log_distance(needle_.distance_to_target(tip_));
    needle_.reset();
    inserted_ = false;
  }

  void needle_step(const ContactInput& c, ModelOutput& o) {
    const NeedleStep s = needle_.step(c.x, axis_);
    if (s.inserted && !inserted_) {
      ++insertions_;
      events_.push_back({0.0, EventKind::insertion_start, -1, -1, double(insertions_)});
      last_logged_ = -1.0;
    }
    for (const NeedleEvent& e : s.events) {
      EventKind k = EventKind::tissue_entered;
      switch (e.kind) {
        case NeedleEvent::Kind::tissue_entered:
          k = EventKind::tissue_entered;
          break;
        case NeedleEvent::Kind::tissue_left:
          k = EventKind::tissue_left;
          break;
        case NeedleEvent::Kind::bone_contact:
          k = EventKind::bone_contact;
          ++bone_contacts_;
          break;
        case NeedleEvent::Kind::target_reached:
          k = EventKind::target_reached;
          break;
      }
      events_.push_back({0.0, k, region_of(e.tissue), -1, double(e.tissue)});
    }
    if (s.inserted) {
      if (last_logged_ < 0 || std::abs(s.tip_to_target - last_logged_) >= cfg_.log_resolution ||
          (s.tip_to_target == 0.0 && last_logged_ != 0.0))
        log_distance(s.tip_to_target);
    } else if (inserted_) {
      log_distance(s.tip_to_target);  // pulled out: the last distance of the insertion
    }
    inserted_ = s.inserted;
    tip_ = s.tip;
    o.force = s.force;
    o.deformation = 0.0;
    o.tip_to_target = s.tip_to_target;
    o.tip_tissue = s.tissue;
  }

  NeedleSceneConfig cfg_;
  const SceneMesh& mesh_;  // owned by the scene (shared cache entry)
  NeedleModel needle_;
  bool needle_tool_ = false;
  Eigen::Vector3d axis_ = Eigen::Vector3d::UnitY();
  bool inserted_ = false;
  Vec3 tip_ = Vec3::Zero();
  int insertions_ = 0, bone_contacts_ = 0;
  double last_logged_ = -1.0;
  std::vector<Event> events_;
  bool delivered_ = false;                   // events_ went to the scene with the last step
  std::vector<double> finger_h_, finger_E_;  // per skin node, -1 = not computed yet
  mutable std::shared_ptr<const TissueSurfaces> tissues_;  // built on first request
};

// The "model" object of a needle prototype (docs/FORMATS.md "Needle").
void read_needle(json::Checker& c, const nlohmann::json& m, const std::string& P, SceneConfig& cfg,
                 const std::vector<std::string>&) {
  c.keys(m, P,
         {"kind", "tool", "axis", "target_tissue", "finger_radius", "stiffening", "bone_stiffness",
          "log_resolution"});
  NeedleSceneConfig& n = cfg.needle;
  if (auto t = c.text(m, P, "tool", false, {"finger", "needle"})) n.tool = *t;
  if (auto a = c.vec3(m, P, "axis", false, -1e3, 1e3, "the stylus axis at the start")) {
    const Eigen::Vector3d v((*a)[0], (*a)[1], (*a)[2]);
    if (v.norm() < 1e-9)
      c.err(P + ".axis", "expected a non-zero direction [x, y, z]");
    else
      n.axis = v.normalized();
  }
  n.target_tissue = static_cast<int>(
      c.integer(m, P, "target_tissue", false, 0, 999, "the target's tissue attribute")
          .value_or(n.target_tissue));
  n.finger_radius =
      c.number(m, P, "finger_radius", false, 0, 0.05, "the fingertip contact radius (m)", true)
          .value_or(n.finger_radius);
  n.stiffening = c.number(m, P, "stiffening", false, 0, 20, "the soft tissue's strain stiffening")
                     .value_or(n.stiffening);
  n.bone_stiffness =
      c.number(m, P, "bone_stiffness", false, 0, 1e7, "the finger-on-bone stiffness (N/m)", true)
          .value_or(n.bone_stiffness);
  n.log_resolution =
      c.number(m, P, "log_resolution", false, 0, 0.01, "the tip_to_target log resolution (m)")
          .value_or(n.log_resolution);
}

std::unique_ptr<SceneModel> make_needle(const SceneConfig& cfg, const SceneMesh& cm) {
  if (!cm.tet)
    throw InputError(
        "model \"needle\" needs a tetrahedral mesh with tissue attributes (generator "
        "shoulder or a tet mesh file); mesh " +
            cfg.mesh.key() + " is a surface",
        cfg.source);
  const bool stored = cm.model_blob_kind == "needle" && !cm.model_blob.empty();
  return std::make_unique<NeedleSceneModel>(cfg, cm, stored ? &cm.model_blob : nullptr);
}

std::string save(const SceneConfig& cfg, const SceneMesh& cm) {
  if (!cm.tet) return {};
  NeedleSceneModel m(cfg, cm, nullptr);
  return m.save_blob();
}

}  // namespace

const ModelKind& needle_model_kind() {
  static const ModelKind k{"needle",
                           "needle insertion through tissue layers with a palpating finger "
                           "(prototype N)",
                           &read_needle,
                           nullptr,
                           &make_needle,
                           &save};
  return k;
}

}  // namespace palplab::engine
