#pragma once
// The one interface between a Scene and the model that makes its force: Scene::step tracks the
// contact on the rest surface, asks the model for one step, then runs the watchdog and the events
// (engine/haptics/scene.cpp). Adding a model kind is one file under engine/models that implements
// SceneModel, plus one line in engine/models/registry.cpp naming its JSON reader and its factory.
#include <Eigen/Core>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "engine/haptics/scene.hpp"
#include "engine/haptics/scene_config.hpp"
#include "engine/mesh/rings.hpp"
#include "engine/mesh/types.hpp"

namespace palplab::json {
class Checker;
}
namespace palplab::spatial {
struct Octree;
}

namespace palplab::engine {

struct FaceIndex;  // engine/haptics/contact.hpp

// The prepared mesh of a scene (cached per MeshSource): the surface the participant sees, with
// its search structures, and the model mesh (the tets of a volume mesh, or the surface itself).
struct SceneMesh {
  mesh::Positions V;                              // #V surface rest positions (m)
  mesh::Positions N;                              // #V unit outward normals
  mesh::Faces F;                                  // #F surface faces (ccw outside)
  mesh::Edges E;                                  // surface edges
  std::vector<int> vertex_region;                 // #V, -1 = unlabelled
  std::vector<std::string> region_names;          //
  Eigen::VectorXd vertex_area;                    // #V lumped surface area (m^2)
  double mean_edge = 0.0;                         // m
  std::shared_ptr<const spatial::Octree> octree;  // over V
  std::shared_ptr<const mesh::RingTable> rings;   // first/second rings of the surface
  std::shared_ptr<const FaceIndex> face_index;    // the contact tracker's search tree over F
  // Model mesh: a tet mesh (tet == true) or the surface again.
  bool tet = false;
  mesh::Positions model_V;            // #M nodes (m)
  mesh::Edges model_E;                // edges of the model
  mesh::Tets model_T;                 // #T tets (tet models)
  Eigen::VectorXi tet_attribute;      // #T tissue attribute
  mesh::Faces model_F;                // boundary faces in model node indices
  Eigen::VectorXi boundary_tet;       // #model_F owning tet (tet models)
  std::vector<int> surface_to_model;  // #V surface node -> model node
  // A model's stored precomputation (loaded from a .psim file, engine/haptics/scene_file.hpp;
  // empty when the mesh was built here): ModelKind::save's bytes for kind model_blob_kind. The
  // model's make uses it only when the inputs it records equal the config's (else recomputes).
  std::string model_blob;
  std::string model_blob_kind;
};

// The prepared mesh of a source, built once per process (thread-safe cache). A bad mesh file
// throws its own located InputError.
std::shared_ptr<const SceneMesh> scene_mesh(const MeshSource& m);
// The same, always built afresh and not cached (what a .psim file saves; benchmarks).
std::shared_ptr<const SceneMesh> build_scene_mesh(const MeshSource& m);
// Puts a prepared mesh (a loaded .psim file) into the cache for m, replacing what is there;
// nullptr removes m from the cache (the next scene_mesh(m) builds it again).
void install_scene_mesh(const MeshSource& m, std::shared_ptr<const SceneMesh> mesh);
// The same by cache key (MeshSource::key(); a .psim file stores it), and what the cache holds for
// a key (nullptr = nothing).
void install_scene_mesh_key(const std::string& key, std::shared_ptr<const SceneMesh> mesh);
std::shared_ptr<const SceneMesh> cached_scene_mesh(const std::string& key);

// One step's input from the contact tracking (engine/haptics/contact.hpp): the god-object proxy
// on the REST surface, its face and barycentric weights, and the device position. Node-based
// models use `node` (the proxy face's vertex of the largest weight); models that interpolate use
// face/w, which change continuously as the contact slides from node to node.
struct ContactInput {
  int node = -1;                                // touched surface node; -1 = no contact
  Eigen::Vector3d x = Eigen::Vector3d::Zero();  // m, device position
  // Shaded outward normal at the proxy: normalize(sum_k w_k N(face_k)); at a node its normal.
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  int face = -1;                                    // surface face of the proxy
  Eigen::Vector3d w = Eigen::Vector3d(1, 0, 0);     // barycentric weights on face (>= 0, sum 1)
  Eigen::Vector3d proxy = Eigen::Vector3d::Zero();  // m, contact point on the rest surface
  double depth = 0.0;  // m, penetration (proxy - x) . n, > 0 in contact
};

// What the model makes of it: the force on the hand (N) and the visible deformation at the
// contact node (m).
struct ModelOutput {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  double deformation = 0.0;
  // Multi-tool models: events of this step (t filled in by the scene; nullptr = none), the tip's
  // distance to the target (m) and the tissue at the tip (-1 = none; shown with transparency).
  const std::vector<Event>* events = nullptr;
  double tip_to_target = -1.0;
  int tip_tissue = -1;
};

class SceneModel {
 public:
  virtual ~SceneModel() = default;
  virtual const char* kind() const = 0;
  // A rigid model cannot diverge and shows no deformation.
  virtual bool deformable() const { return true; }
  // One haptic step of dt seconds.
  virtual ModelOutput step(const ContactInput& c, double dt) = 0;
  // Back to rest (cheap: no precomputation).
  virtual void reset() = 0;
  // The scene is stepped by a real-time loop (true) or in lock-step (false, the default): work
  // beside the haptic loop must then never be waited for (see Scene::set_realtime).
  virtual void set_realtime(bool realtime) { (void)realtime; }
  // Fills the model's counters (nodes, springs, mass, rest error, level, awake nodes).
  virtual void stats(SceneStats& s) const = 0;
  // Current surface for a renderer (#V(now) by 3, faces of the current surface).
  virtual void surface(mesh::Positions& V, mesh::Faces& F) const = 0;
  // Tool selection (Scene::set_tool); single-tool models have the one tool "probe".
  // The tissues' surfaces inside the body (layered tet models that draw them; nullptr = none).
  virtual std::shared_ptr<const TissueSurfaces> tissue_surfaces() const { return nullptr; }
  virtual std::string tool() const { return "probe"; }
  virtual bool set_tool(const std::string& tool, const Eigen::Vector3d& stylus_axis) {
    (void)stylus_axis;
    return tool == "probe";
  }
};

// A registered model kind: its name in prototype files, the reader of its "model" object (every
// key of the object, the "kind" included, into the config; problems go to the checker), an
// optional check of the whole config once every section is read (problems located in the file),
// and its factory (throws InputError for a config it cannot build).
struct ModelKind {
  const char* name;
  const char* summary;  // one line for --help and docs
  void (*read)(json::Checker& c, const nlohmann::json& model, const std::string& path,
               SceneConfig& cfg, const std::vector<std::string>& regions);
  void (*check)(json::Checker& c, const SceneConfig& cfg);  // may be nullptr
  std::unique_ptr<SceneModel> (*make)(const SceneConfig& cfg, const SceneMesh& mesh);
  // Optional (nullptr = the kind stores nothing beyond the mesh): the model's precomputation for
  // a .psim file. make() finds it again in mesh.model_blob and must produce a model that steps
  // bit-identically to one built without it.
  std::string (*save)(const SceneConfig& cfg, const SceneMesh& mesh) = nullptr;
  // Optional: what the kind needs of the prepared mesh (a tet mesh, tets it can use, tissue
  // attributes the material table covers), a located InputError otherwise. `validate` and `run`
  // make it before anything runs (prototypes::inspect_prototype); make() makes it too.
  void (*check_mesh)(const SceneConfig& cfg, const SceneMesh& mesh) = nullptr;
};

// Reads the optional "material" member of a model object into mc (engine/models/material_json.cpp).
void read_material(json::Checker& c, const nlohmann::json& model, const std::string& path,
                   MaterialConfig& mc);

// Reads "support_modulus", "fixed_z_below" and "fixed_region" of a model object into sp.
void read_support(json::Checker& c, const nlohmann::json& model, const std::string& path,
                  SupportConfig& sp, const std::vector<std::string>& regions);

// Every registered kind, in registration order.
const std::vector<ModelKind>& model_kinds();
// nullptr if unknown.
const ModelKind* find_model_kind(const std::string& name);

}  // namespace palplab::engine
