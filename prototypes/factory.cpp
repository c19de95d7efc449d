#include "prototypes/factory.hpp"

#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>

#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "common/json_locate.hpp"
#include "engine/haptics/scene_impl.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/io.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/models/mass_spring_material.hpp"

namespace palplab::prototypes {

using nlohmann::json;
namespace pj = palplab::json;
using namespace palplab::engine;

namespace {

// Located validation: the one checker shared with study files (common/json_check.hpp).
using palplab::json::Checker;

// ---------------------------------------------------------------- the parsed prototype

struct MeshSpec {
  std::string generator = "tract";
  int vertices = 1500;
  std::uint64_t seed = 0;
  std::string file;  // absolute path of a mesh file (instead of a generator)
  std::string key() const {
    if (!file.empty()) return "file:" + file;
    return generator + "/" + std::to_string(vertices) + "/" + std::to_string(seed);
  }
};

struct CachedMesh;
std::shared_ptr<const CachedMesh> cached_mesh(const MeshSpec& m);
const std::vector<std::string>& mesh_regions(const MeshSpec& m);

struct Spec {
  std::string id, scene, description;
  MeshSpec mesh;
  ModelKind kind = ModelKind::penalty;
  // ring
  RingParams ring;
  Scope scope = Scope::rings;
  // mass-spring
  // Material: a tissue of the table (by name) or explicit values; thickness for surface models.
  std::string tissue;  // empty: the mesh's own tissue attribute (tet meshes) or "soft tissue"
  std::optional<double> youngs_modulus, density;
  double thickness = 0.005;      // m, membrane thickness of a surface model
  double rayleigh_beta = 0.002;  // s, kd = beta ks
  double support_modulus = 0.0;  // N/m^3, elastic foundation under the surface
  double support_damping = 0.0;  // N s/m^3
  SpringJacobian jacobian = SpringJacobian::definite;
  std::string fixed_region;
  double scope_radius = 0.0, fixed_z_below = 0.0;
  int scope_max_nodes = 1 << 30;
  double cg_tolerance = 1e-6;
  Integrator integrator = Integrator::backward_euler;
  LinearSolver solver = LinearSolver::cg;
  SleepParams sleep;
  bool refine = false;
  RefineParams refine_params;
  double refine_force = 1.0;
  bool substep = true;
  // scene
  double contact_k = 500.0, contact_radius = 0.0;
  double patch_radius = 0.01;  // m, radius of the probe face (mass-spring models)
  double force_limit = 8.5;    // N, the device's peak force (a common desktop device)
  Cues cues;
  double dt = 1e-3;
  std::map<std::string, Thresholds> thresholds;
  std::optional<Eigen::Vector3d> start;
};

const std::vector<std::string>& generator_regions(const std::string& gen) {
  static const std::vector<std::string> none;
  if (gen == "tract" || gen == "model_c") return mesh::tract_region_names();
  return none;
}

Thresholds read_thresholds(Checker& c, const json& o, const std::string& p) {
  c.keys(o, p, {"st", "mpf", "sft"});
  Thresholds t;
  const double inf = 1e6;
  t.st = c.number(o, p, "st", true, 0, inf, "the sound threshold ST (N)").value_or(0);
  t.mpf = c.number(o, p, "mpf", true, 0, inf, "the maximum palpation force MPF (N)").value_or(0);
  t.sft = c.number(o, p, "sft", true, 0, inf, "the stopping force threshold SFT (N)").value_or(0);
  if (c.ok() && !(t.st < t.sft)) c.err(p, "expected ST < SFT (the sound comes before the stop)");
  if (c.ok() && !(t.mpf <= t.sft)) c.err(p, "expected MPF <= SFT");
  return t;
}

Spec parse(const std::string& path) {
  std::string text;
  const json root = pj::parse_file_located(path, &text);
  Checker c(path, text);
  Spec s;
  const std::string R = "$";
  if (!root.is_object()) {
    c.err(R, "expected a JSON object describing a prototype");
    c.throw_if_any();
  }
  c.keys(root, R,
         {"format", "id", "scene", "description", "mesh", "model", "contact", "cues", "haptic_step",
          "thresholds", "start_position"});
  if (auto f = c.text(root, R, "format", true)) {
    if (*f != "palplab-prototype/1")
      c.err("$.format", "unsupported format \"" + *f + "\" (expected \"palplab-prototype/1\")");
  }
  s.id = c.text(root, R, "id", true).value_or("");
  s.scene = c.text(root, R, "scene", false).value_or("");
  s.description = c.text(root, R, "description", false).value_or("");
  s.dt = c.number(root, R, "haptic_step", false, 1e-5, 0.01, "the haptic step (s)", false)
             .value_or(1e-3);

  bool mesh_ok = false;
  if (const json* m = c.object(root, R, "mesh", true)) {
    const std::string P = "$.mesh";
    c.keys(*m, P, {"generator", "vertices", "seed", "file"});
    const bool has_file = m->contains("file"), has_gen = m->contains("generator");
    if (has_file == has_gen) {
      c.err(P, has_file ? "give either \"generator\" or \"file\", not both"
                        : "missing \"generator\" (tract, model_c, stomach, sphere) or \"file\" "
                          "(a mesh file)");
    } else if (has_file) {
      if (auto f = c.text(*m, P, "file", true)) {
        namespace fs = std::filesystem;
        fs::path fp(*f);
        if (fp.is_relative()) fp = fs::path(path).parent_path() / fp;
        std::error_code ec;
        if (!fs::is_regular_file(fp, ec) &&
            !fs::is_regular_file(fs::path(fp).replace_extension(".node"), ec))
          c.err("$.mesh.file", "no such mesh file: " + fp.string() +
                                   " (expected .obj, .stl, .off, .ply, .vtu or TetGen .node/.ele, "
                                   "relative to the prototype file)");
        else
          s.mesh.file = fs::absolute(fp).lexically_normal().string();
      }
      for (const char* k : {"vertices", "seed"})
        if (m->contains(k))
          c.err(pj::path_key(P, k), std::string("\"") + k + "\" applies to generators only", true);
    } else {
      s.mesh.generator = c.text(*m, P, "generator", true, {"tract", "model_c", "stomach", "sphere"})
                             .value_or("tract");
      s.mesh.vertices = static_cast<int>(
          c.integer(*m, P, "vertices", false, 12, 200000, "the vertex count").value_or(1500));
      s.mesh.seed = static_cast<std::uint64_t>(
          c.integer(*m, P, "seed", false, 0, 1L << 40, "the shape seed (0 = reference)")
              .value_or(0));
    }
    mesh_ok = c.ok();
  }
  // Region names: fixed for generators; a mesh file is read (and cached) to learn them. A bad
  // mesh file throws its own located InputError (file, line or byte).
  static const std::vector<std::string> no_regions;
  const auto& regions = mesh_ok ? mesh_regions(s.mesh) : no_regions;
  auto known_region = [&](const std::string& r) {
    return std::find(regions.begin(), regions.end(), r) != regions.end();
  };

  if (const json* m = c.object(root, R, "model", true)) {
    const std::string P = "$.model";
    const auto kind = c.text(*m, P, "kind", true, {"penalty", "ring", "mass_spring"});
    if (kind == "penalty") {
      s.kind = ModelKind::penalty;
      c.keys(*m, P, {"kind"});
    } else if (kind == "ring") {
      s.kind = ModelKind::ring;
      c.keys(*m, P,
             {"kind", "m1", "m2", "m3", "node_mass", "home_stiffness", "home_damping", "scope"});
      s.ring.m1 = c.number(*m, P, "m1", true, 0, 1, "the touched node's step size |m1| (m/N)", true)
                      .value_or(0);
      s.ring.m2 =
          c.number(*m, P, "m2", true, 0, 1, "the first ring's step size |m2| (m/N)").value_or(0);
      s.ring.m3 =
          c.number(*m, P, "m3", true, 0, 1, "the second ring's step size |m3| (m/N)").value_or(0);
      if (c.ok() && !(s.ring.m1 > s.ring.m2 && s.ring.m2 > s.ring.m3))
        c.err(P, "expected |m1| > |m2| > |m3| (displacement deepest at the touched node)");
      s.ring.node_mass =
          c.number(*m, P, "node_mass", false, 0, 10, "the node mass (kg)", true).value_or(1e-3);
      s.ring.home_ks =
          c.number(*m, P, "home_stiffness", false, 0, 1e6, "home-spring stiffness (N/m)", true)
              .value_or(20);
      s.ring.home_kd = c.number(*m, P, "home_damping", false, 0, 1e4, "home-spring damping (N s/m)")
                           .value_or(0.2);
      if (auto sc = c.text(*m, P, "scope", false, {"rings", "octant", "whole"}))
        s.scope = scope_from_string(*sc);
    } else if (kind == "mass_spring") {
      s.kind = ModelKind::mass_spring;
      c.keys(
          *m, P,
          {"kind", "material", "thickness", "rayleigh_beta", "support_modulus", "support_damping",
           "jacobian", "fixed_region", "integrator", "linear_solver", "sleeping", "refinement",
           "scope_radius", "scope_max_nodes", "cg_tolerance", "fixed_z_below"});
      if (const json* mat = c.member(*m, P, "material", false, "a tissue name or an object")) {
        const std::string Q = "$.model.material";
        if (mat->is_string()) {
          s.tissue = mat->get<std::string>();
        } else if (mat->is_object()) {
          c.keys(*mat, Q, {"tissue", "youngs_modulus", "density"});
          s.tissue = c.text(*mat, Q, "tissue", false).value_or("");
          s.youngs_modulus =
              c.number(*mat, Q, "youngs_modulus", false, 0, 1e11, "Young's modulus E (Pa)", true);
          s.density = c.number(*mat, Q, "density", false, 0, 1e5, "the density (kg/m^3)", true);
        } else {
          c.err(Q, std::string("expected a tissue name or an object, got ") + mat->type_name());
        }
        if (!s.tissue.empty()) {
          std::string names;
          bool known = false;
          for (const auto& e : mesh::default_materials().materials) {
            known |= e.name == s.tissue;
            names += (names.empty() ? "" : ", ") + e.name;
          }
          if (!known)
            c.err(Q, "unknown tissue \"" + s.tissue + "\" (expected one of: " + names + ")");
        }
      }
      s.thickness = c.number(*m, P, "thickness", false, 0, 1,
                             "the membrane thickness of a surface model (m)", true)
                        .value_or(0.005);
      s.rayleigh_beta = c.number(*m, P, "rayleigh_beta", false, 0, 10,
                                 "the stiffness-proportional damping kd/ks (s)")
                            .value_or(0.002);
      s.support_modulus = c.number(*m, P, "support_modulus", false, 0, 1e9,
                                   "the elastic foundation under the surface (N/m^3)")
                              .value_or(0.0);
      s.support_damping = c.number(*m, P, "support_damping", false, 0, 1e9,
                                   "the damping of the foundation (N s/m^3)")
                              .value_or(0.0);
      if (auto jc = c.text(*m, P, "jacobian", false, {"definite", "exact"}))
        s.jacobian = *jc == "exact" ? SpringJacobian::exact : SpringJacobian::definite;
      s.scope_radius = c.number(*m, P, "scope_radius", false, 0, 10,
                                "the integration scope radius around the contact (m, 0 = whole)")
                           .value_or(0.0);
      s.cg_tolerance = c.number(*m, P, "cg_tolerance", false, 0, 0.1,
                                "the relative residual of the CG solve", true)
                           .value_or(1e-6);
      s.scope_max_nodes = static_cast<int>(
          c.integer(*m, P, "scope_max_nodes", false, 1, 1L << 30, "the most nodes in the scope")
              .value_or(1L << 30));
      s.fixed_z_below = c.number(*m, P, "fixed_z_below", false, 0, 10,
                                 "the height above the mesh's lowest point below which nodes "
                                 "are pinned (m)")
                            .value_or(0.0);
      if (auto fr = c.text(*m, P, "fixed_region", false)) {
        if (!known_region(*fr))
          c.err("$.model.fixed_region",
                "unknown region \"" + *fr + "\" of mesh generator \"" + s.mesh.generator + "\"");
        else
          s.fixed_region = *fr;
      }
      if (auto in =
              c.text(*m, P, "integrator", false, {"symplectic_euler", "backward_euler", "rk4"}))
        s.integrator = integrator_from_string(*in);
      if (auto ls = c.text(*m, P, "linear_solver", false, {"cg", "ldlt_refactor", "ldlt_frozen"}))
        s.solver = linear_solver_from_string(*ls);
      if (const json* sl = c.object(*m, P, "sleeping", false)) {
        const std::string Q = "$.model.sleeping";
        c.keys(*sl, Q, {"enabled", "position_tolerance", "velocity_tolerance"});
        s.sleep.enabled = c.boolean(*sl, Q, "enabled", false).value_or(true);
        s.sleep.x_tol =
            c.number(*sl, Q, "position_tolerance", false, 0, 0.01, "the rest tolerance (m)", true)
                .value_or(1e-6);
        s.sleep.v_tol = c.number(*sl, Q, "velocity_tolerance", false, 0, 1,
                                 "the rest velocity tolerance (m/s)", true)
                            .value_or(1e-5);
      }
      if (const json* rf = c.object(*m, P, "refinement", false)) {
        const std::string Q = "$.model.refinement";
        c.keys(*rf, Q,
               {"enabled", "policy", "threshold_area", "threshold_force", "level", "max_level",
                "substep"});
        s.refine = c.boolean(*rf, Q, "enabled", false).value_or(true);
        if (auto po = c.text(*rf, Q, "policy", false, {"area_based", "conventional", "whole"}))
          s.refine_params.policy = *po == "area_based"     ? RefinePolicy::area_based
                                   : *po == "conventional" ? RefinePolicy::conventional
                                                           : RefinePolicy::whole;
        s.refine_params.threshold_area =
            c.number(*rf, Q, "threshold_area",
                     s.refine_params.policy == RefinePolicy::area_based && s.refine, 0, 1,
                     "the threshold area A_t (m^2)", true)
                .value_or(1e-4);
        s.refine_force = c.number(*rf, Q, "threshold_force", false, 0, 1e3,
                                  "the force that triggers refinement (N)")
                             .value_or(1.0);
        s.refine_params.level = static_cast<int>(
            c.integer(*rf, Q, "level", false, 1, 5, "the fixed level of the baselines")
                .value_or(1));
        s.refine_params.max_level = static_cast<int>(
            c.integer(*rf, Q, "max_level", false, 1, 5, "the deepest level").value_or(3));
        s.substep = c.boolean(*rf, Q, "substep", false).value_or(true);
      }
    }
  }
  if (const json* ct = c.object(root, R, "contact", false)) {
    const std::string P = "$.contact";
    c.keys(*ct, P, {"stiffness", "radius", "patch_radius", "force_limit"});
    s.force_limit =
        c.number(*ct, P, "force_limit", false, 0, 1000, "the device's peak force (N)", true)
            .value_or(8.5);
    s.patch_radius =
        c.number(*ct, P, "patch_radius", false, 0, 0.1, "the radius of the probe face (m)")
            .value_or(0.01);
    s.contact_k = c.number(*ct, P, "stiffness", false, 0, 1e6, "the contact stiffness (N/m)", true)
                      .value_or(500);
    s.contact_radius =
        c.number(*ct, P, "radius", false, 0, 1, "the contact capture radius (m)", true).value_or(0);
  }
  if (s.kind == ModelKind::ring && c.ok() && s.ring.m1 * s.contact_k > 1.0 + 1e-12)
    c.err("$.model.m1", "m1 = " + json(s.ring.m1).dump() + " m/N shows the touched node " +
                            json(s.ring.m1 * s.contact_k).dump() +
                            " times deeper than the penetration it renders (contact stiffness " +
                            json(s.contact_k).dump() +
                            " N/m): expected m1 <= 1 / contact stiffness");
  if (const json* cu = c.object(root, R, "cues", false)) {
    const std::string P = "$.cues";
    c.keys(*cu, P, {"haptic", "visual_deformation", "audio"});
    s.cues.haptic = c.boolean(*cu, P, "haptic", false).value_or(true);
    s.cues.visual_deformation = c.boolean(*cu, P, "visual_deformation", false).value_or(true);
    s.cues.audio = c.boolean(*cu, P, "audio", false).value_or(false);
  }
  if (const json* th = c.object(root, R, "thresholds", false)) {
    for (auto it = th->begin(); it != th->end(); ++it) {
      const std::string P = pj::path_key("$.thresholds", it.key());
      if (it.key() != "*" && !known_region(it.key())) {
        c.err(P, "unknown region \"" + it.key() + "\" (expected \"*\" or a region of the mesh)",
              true);
        continue;
      }
      if (!it.value().is_object()) {
        c.err(P, "expected an object {\"st\", \"mpf\", \"sft\"} in N");
        continue;
      }
      s.thresholds[it.key()] = read_thresholds(c, it.value(), P);
    }
  }
  if (auto sp = c.vec3(root, R, "start_position", false, -10, 10, "the device start position (m)"))
    s.start = Eigen::Vector3d((*sp)[0], (*sp)[1], (*sp)[2]);
  c.throw_if_any();
  return s;
}

// ---------------------------------------------------------------- cached meshes

struct CachedMesh {
  mesh::SurfaceMesh sm;  // the surface the participant sees (compact surface node indices)
  RowMatX3d N;
  std::vector<int> vertex_region;
  Eigen::VectorXd vertex_area;  // lumped (m^2)
  double mean_edge = 0.0;
  std::shared_ptr<const spatial::Octree> octree;
  std::shared_ptr<const mesh::RingTable> rings;
  // Tetrahedral model (generator model_c): all nodes, springs on tet edges, lumped volumes.
  bool tet = false;
  RowMatX3d model_V;
  mesh::Edges model_E;
  Eigen::VectorXd node_volume;  // m^3
  RowMatX3i model_F;            // boundary faces in model node indices
  std::vector<int> surface_to_model;
  RowMatX4i model_T;              // #T tets (tet model)
  Eigen::VectorXi tet_attribute;  // #T tissue attribute
  Eigen::VectorXi boundary_tet;   // #model_F owning tet
};

void build_tet(CachedMesh& c, const mesh::TetMesh& tm) {
  const mesh::BoundaryFaces bf = mesh::boundary_faces(tm);
  const long n = tm.V.rows();
  std::vector<int> m2s(n, -1);
  for (long f = 0; f < bf.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = bf.F(f, k);
      if (m2s[v] < 0) {
        m2s[v] = static_cast<int>(c.surface_to_model.size());
        c.surface_to_model.push_back(v);
      }
    }
  mesh::Positions Vs(c.surface_to_model.size(), 3);
  for (size_t i = 0; i < c.surface_to_model.size(); ++i)
    Vs.row(i) = tm.V.row(c.surface_to_model[i]);
  mesh::Faces Fs(bf.F.rows(), 3);
  for (long f = 0; f < bf.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) Fs(f, k) = m2s[bf.F(f, k)];
  mesh::Regions reg;
  if (!tm.regions.empty()) {
    reg.names = tm.regions.names;
    reg.id.resize(bf.F.rows());
    for (long f = 0; f < bf.F.rows(); ++f) reg.id[f] = tm.regions.id[bf.tet[f]];
  }
  c.sm = mesh::make_surface_mesh(std::move(Vs), std::move(Fs), std::move(reg));
  c.tet = true;
  c.model_V = tm.V;
  c.model_E = mesh::tet_edges(tm.T);
  c.model_F = bf.F;
  c.model_T = tm.T;
  c.tet_attribute = tm.attribute;
  if (c.tet_attribute.size() != tm.T.rows()) c.tet_attribute.setZero(tm.T.rows());
  c.boundary_tet = bf.tet;
  c.node_volume.setZero(n);
  for (long t = 0; t < tm.T.rows(); ++t)
    for (int k = 0; k < 4; ++k) c.node_volume[tm.T(t, k)] += tm.volume[t] / 4.0;
}

std::shared_ptr<const CachedMesh> cached_mesh(const MeshSpec& m) {
  static std::mutex mu;
  static std::map<std::string, std::shared_ptr<const CachedMesh>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto it = cache.find(m.key());
  if (it != cache.end()) return it->second;
  auto c = std::make_shared<CachedMesh>();
  if (!m.file.empty()) {
    mesh::AnyMesh am = mesh::read_mesh(m.file);
    if (am.is_tet)
      build_tet(*c, am.tet);
    else
      c->sm = std::move(am.surface);
  } else if (m.generator == "tract") {
    c->sm = mesh::generate_tract({m.vertices, m.seed});
  } else if (m.generator == "stomach") {
    c->sm = mesh::generate_stomach(m.seed);
  } else if (m.generator == "sphere") {
    c->sm = mesh::generate_sphere(m.vertices);
  } else {
    build_tet(*c, mesh::generate_model_c(m.seed, m.vertices));
  }
  const auto& V = c->sm.V;
  const auto& F = c->sm.F;
  c->N = mesh::vertex_normals(V, F);
  const Eigen::VectorXi vr = mesh::vertex_regions(c->sm);
  c->vertex_region.assign(V.rows(), -1);
  for (long i = 0; i < vr.size(); ++i) c->vertex_region[i] = vr[i];
  const Eigen::VectorXd fa = mesh::face_areas(V, F);
  c->vertex_area.setZero(V.rows());
  for (long f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) c->vertex_area[F(f, k)] += fa[f] / 3.0;
  double sum = 0.0;
  for (long e = 0; e < c->sm.E.rows(); ++e)
    sum += (V.row(c->sm.E(e, 0)) - V.row(c->sm.E(e, 1))).norm();
  c->mean_edge = c->sm.E.rows() ? sum / c->sm.E.rows() : 0.01;
  c->octree = std::make_shared<const spatial::Octree>(spatial::build_octree(V, 12, 8));
  c->rings = std::make_shared<const mesh::RingTable>(
      mesh::compute_rings(static_cast<int>(V.rows()), c->sm.E));
  if (!c->tet) {
    c->model_V = V;
    c->model_E = c->sm.E;
    c->model_F = F;
    c->surface_to_model.resize(V.rows());
    for (long i = 0; i < V.rows(); ++i) c->surface_to_model[i] = static_cast<int>(i);
  }
  cache.emplace(m.key(), c);
  return c;
}

const std::vector<std::string>& mesh_regions(const MeshSpec& m) {
  if (m.file.empty()) return generator_regions(m.generator);
  return cached_mesh(m)->sm.regions.names;
}

}  // namespace

PrototypeSummary inspect_prototype(const std::string& path) {
  const Spec s = parse(path);
  return {s.id, s.scene, to_string(s.kind), mesh_regions(s.mesh)};
}

engine::Scene build_scene(const std::string& path, const SceneOverrides& ov) {
  Spec s = parse(path);
  const auto cm = cached_mesh(s.mesh);
  auto impl = std::make_unique<SceneImpl>();
  SceneImpl& sc = *impl;
  sc.prototype = s.id;
  sc.kind = s.kind;
  sc.dt = s.dt;
  sc.cues = s.cues;
  if (ov.haptic) sc.cues.haptic = *ov.haptic;
  if (ov.visual_deformation) sc.cues.visual_deformation = *ov.visual_deformation;
  if (ov.audio) sc.cues.audio = *ov.audio;
  sc.contact_k = s.contact_k;
  sc.force_limit = s.force_limit;
  sc.contact_radius = s.contact_radius > 0 ? s.contact_radius : 1.5 * cm->mean_edge;

  SceneGeometry& g = sc.geom;
  g.V = cm->sm.V;
  g.N = cm->N;
  g.F = cm->sm.F;
  g.vertex_region = cm->vertex_region;
  g.region_names = cm->sm.regions.names;
  g.search_index = cm->octree;
  sc.octree = cm->octree;
  sc.surface_rings = cm->rings;
  if (s.start) {
    g.start_position = *s.start;
  } else {
    // 5 cm in front (-y) of the organ, at the height of its centre.
    const Eigen::Vector3d lo = g.V.colwise().minCoeff().transpose();
    const Eigen::Vector3d hi = g.V.colwise().maxCoeff().transpose();
    g.start_position = 0.5 * (lo + hi);
    g.start_position.y() = lo.y() - 0.05;
  }

  // Thresholds: per region from the file, then the study's overrides; "*" fills the rest.
  std::map<std::string, Thresholds> th = s.thresholds;
  for (const auto& [k, v] : ov.thresholds) {
    if (k != "*" &&
        std::find(g.region_names.begin(), g.region_names.end(), k) == g.region_names.end())
      throw InputError("threshold override for unknown region \"" + k + "\" of prototype " + s.id,
                       path);
    th[k] = v;
  }
  Thresholds star{2.0, 2.5, 3.0};
  if (th.count("*")) star = th["*"];
  sc.default_thresholds = star;
  sc.thresholds.assign(g.region_names.size(), star);
  for (size_t r = 0; r < g.region_names.size(); ++r)
    if (th.count(g.region_names[r])) sc.thresholds[r] = th[g.region_names[r]];

  const long n = g.V.rows();
  if (s.kind == ModelKind::ring) {
    sc.ring = make_ring_model(g.V, cm->sm.E, s.ring);
    sc.ring.scope = s.scope;
    sc.ring.octree = cm->octree.get();
  } else if (s.kind == ModelKind::mass_spring) {
    // Every stiffness, mass and support from the material and the rest geometry
    // (engine/models/mass_spring_material.hpp): nothing per vertex.
    const long nm = cm->model_V.rows();
    const mesh::MaterialTable& table = mesh::default_materials();
    auto material_of = [&](int attribute) {
      mesh::Material mat;
      const mesh::Material* named = nullptr;
      for (const auto& e : table.materials)
        if (!s.tissue.empty() && e.name == s.tissue) named = &e;
      if (!named) named = table.find(s.tissue.empty() ? attribute : 101);
      if (named) mat = *named;
      if (s.youngs_modulus) mat.youngs_modulus = *s.youngs_modulus;
      if (s.density) mat.density = *s.density;
      return mat;
    };
    MassSpringSystem sys;
    sys.X_rest = cm->model_V;
    sys.X = cm->model_V;
    sys.V.setZero(nm, 3);
    sys.F_ext.setZero(nm, 3);
    Eigen::VectorXd face_membrane;
    if (cm->tet) {
      const long nt = cm->model_T.rows();
      Eigen::VectorXd E(nt), rho(nt);
      for (long t = 0; t < nt; ++t) {
        const mesh::Material mat = material_of(cm->tet_attribute[t]);
        E[t] = mat.youngs_modulus;
        rho[t] = mat.density;
      }
      sys.springs = tet_springs(cm->model_V, cm->model_T, E, s.rayleigh_beta);
      sys.mass = tet_lumped_mass(cm->model_V, cm->model_T, rho);
      face_membrane = boundary_membrane(cm->model_V, cm->model_T, cm->model_F, cm->boundary_tet, E);
    } else {
      const mesh::Material mat = material_of(101);
      face_membrane =
          Eigen::VectorXd::Constant(cm->model_F.rows(), mat.youngs_modulus * s.thickness);
      sys.springs = membrane_springs(cm->model_V, cm->model_F, face_membrane, s.rayleigh_beta);
      sys.mass = lumped_area(cm->model_V, cm->model_F) * (mat.density * s.thickness);
    }
    // The support: an elastic foundation per unit area of the surface it holds.
    const Eigen::VectorXd area = lumped_area(cm->model_V, cm->model_F);
    sys.home_ks = s.support_modulus * area;
    sys.home_kd = s.support_damping * area;
    sys.fixed.assign(nm, 0);
    if (!s.fixed_region.empty()) {
      const int r = g.region_index(s.fixed_region);
      for (long i = 0; i < n; ++i)
        if (g.vertex_region[i] == r) sys.fixed[cm->surface_to_model[i]] = 1;
    }
    if (s.fixed_z_below > 0.0) {
      const double z0 = cm->model_V.col(2).minCoeff();
      for (long i = 0; i < nm; ++i)
        if (cm->model_V(i, 2) < z0 + s.fixed_z_below) sys.fixed[i] = 1;
    }
    MassSpringScene& ms = sc.ms;
    ms.model = make_adaptive(std::move(sys), cm->model_F, face_membrane, s.rayleigh_beta, s.dt);
    ms.ws.jacobian = s.jacobian;
    ms.patch_radius = s.patch_radius;
    ms.integrator = s.integrator;
    if (ov.integrator) {
      try {
        ms.integrator = integrator_from_string(*ov.integrator);
      } catch (const std::invalid_argument& e) {
        throw InputError(std::string("integrator override: ") + e.what(), path);
      }
    }
    ms.ws.solver = s.solver;
    ms.ws.cg_tolerance = s.cg_tolerance;
    ms.ws.cg_force_tolerance = 1e-6;  // N
    ms.sleep = s.sleep;
    ms.refine = s.refine;
    ms.refine_params = s.refine_params;
    ms.refine_force = s.refine_force;
    ms.substep = s.substep;
    ms.scope_radius = s.scope_radius;
    ms.scope_max_nodes = s.scope_max_nodes;
    ms.surface_to_model = cm->surface_to_model;
  }
  return Scene(std::move(impl));
}

}  // namespace palplab::prototypes
