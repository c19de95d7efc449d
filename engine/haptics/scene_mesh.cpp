// The prepared meshes of scenes, cached per process and mesh source: generating Model-C or
// reading a mesh file, normals, regions, lumped areas, the octree, the ring tables and the
// contact tracker's face index are done once; every scene built from the same source shares them
// (they are immutable).
#include <algorithm>
#include <map>
#include <mutex>

#include "common/format.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/contact.hpp"
#include "engine/haptics/scene_config.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/io.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/mesh/tetrahedralize.hpp"
#include "engine/mesh/unique_edges.hpp"
#include "engine/models/model.hpp"
#include "engine/spatial/octree.hpp"

namespace palplab::engine {

std::string MeshSource::key() const {
  if (!file.empty()) return "file:" + file;
  return generator + "/" + std::to_string(vertices) + "/" + std::to_string(seed);
}

namespace {

// A tet mesh: the surface the participant sees is its boundary (compact surface node indices);
// the model keeps every node.
void build_tet(SceneMesh& c, mesh::SurfaceMesh& sm, const mesh::TetMesh& tm) {
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
  sm = mesh::make_surface_mesh(std::move(Vs), std::move(Fs), std::move(reg));
  c.tet = true;
  c.model_V = tm.V;
  c.model_E = mesh::unique_edges(tm.T);
  c.model_F = bf.F;
  c.model_T = tm.T;
  c.tet_attribute = tm.attribute;
  if (c.tet_attribute.size() != tm.T.rows()) c.tet_attribute.setZero(tm.T.rows());
  c.boundary_tet = bf.tet;
}

// The needle scene's shoulder (prototype N): the procedural surfaces tetrahedralized with their
// tissue seeds; the tets' regions are their tissues by name (so needle events name them), and the
// surface the participant sees is the skin.
mesh::TetMesh shoulder_tets(int layer_vertices) {
  const mesh::Shoulder sh = mesh::generate_shoulder({layer_vertices});
  mesh::TetOptions to;
  to.seeds = sh.seeds;
  mesh::TetMesh tm = mesh::tetrahedralize(sh.surface, to);
  std::vector<int> tissues(tm.attribute.data(), tm.attribute.data() + tm.attribute.size());
  std::sort(tissues.begin(), tissues.end());
  tissues.erase(std::unique(tissues.begin(), tissues.end()), tissues.end());
  // One region per tissue name: the humerus (200) and the scapula (201) are both "bone" (a
  // second region of the same name was listed twice and never used: regions are found by name).
  tm.regions.names.clear();
  std::vector<int> region_of_tissue;
  for (int a : tissues) {
    const mesh::Material* mat = mesh::default_materials().find(a);
    const std::string name = mat ? mat->name : "tissue " + std::to_string(a);
    const auto it = std::find(tm.regions.names.begin(), tm.regions.names.end(), name);
    region_of_tissue.push_back(static_cast<int>(it - tm.regions.names.begin()));
    if (it == tm.regions.names.end()) tm.regions.names.push_back(name);
  }
  tm.regions.id.resize(tm.T.rows());
  for (long t = 0; t < tm.T.rows(); ++t)
    tm.regions.id[t] =
        region_of_tissue[std::lower_bound(tissues.begin(), tissues.end(), tm.attribute[t]) -
                         tissues.begin()];
  return tm;
}

// A prototype's mesh file is a piece of tissue in metres: one far outside that (a mesh in
// millimetres is 1000x too large; 1e150 overflowed the contact search into an internal error)
// is refused where it is named, before anything is built from it.
constexpr double kMinMeshExtent = 1e-4, kMaxMeshExtent = 10.0;  // m
void check_mesh_extent(const mesh::Positions& V, const std::string& file) {
  if (V.rows() == 0) return;  // the readers refuse an empty mesh
  const double extent = (V.colwise().maxCoeff() - V.colwise().minCoeff()).maxCoeff();
  if (!V.allFinite())
    throw InputError("a vertex has a coordinate that is not a finite number (NaN or inf)", file);
  if (!(extent >= kMinMeshExtent && extent <= kMaxMeshExtent))
    throw InputError(
        "the mesh is " + format_g(extent) + " m across, expected a piece of tissue in metres (" +
            format_g(kMinMeshExtent) + " to " + format_g(kMaxMeshExtent) + " m" +
            (extent > kMaxMeshExtent ? "; a mesh in millimetres is 1000 times too large)"
                                     : "; a mesh in kilometres is 1000 times too small)"),
        file);
}

std::shared_ptr<const SceneMesh> prepare(const MeshSource& m) {
  auto c = std::make_shared<SceneMesh>();
  mesh::SurfaceMesh sm;
  if (!m.file.empty()) {
    mesh::AnyMesh am = mesh::read_mesh(m.file);
    check_mesh_extent(am.is_tet ? am.tet.V : am.surface.V, m.file);
    if (am.is_tet)
      build_tet(*c, sm, am.tet);
    else
      sm = std::move(am.surface);
  } else if (m.generator == "tract") {
    sm = mesh::generate_tract({m.vertices, m.seed});
  } else if (m.generator == "stomach") {
    sm = mesh::generate_stomach(m.seed);
  } else if (m.generator == "sphere") {
    sm = mesh::generate_sphere(m.vertices);
  } else if (m.generator == "model_c") {
    build_tet(*c, sm, mesh::generate_model_c(m.seed, m.vertices));
  } else if (m.generator == "shoulder") {
    build_tet(*c, sm, shoulder_tets(m.vertices));
  } else {
    throw InputError("unknown mesh generator \"" + m.generator +
                     "\" (expected tract, model_c, stomach, sphere or shoulder)");
  }
  c->V = sm.V;
  c->F = sm.F;
  c->E = sm.E;
  c->region_names = sm.regions.names;
  c->N = mesh::vertex_normals(sm.V, sm.F);
  const Eigen::VectorXi vr = mesh::vertex_regions(sm);
  c->vertex_region.assign(sm.V.rows(), -1);
  for (long i = 0; i < vr.size(); ++i) c->vertex_region[i] = vr[i];
  // A contact is in the region of the touched vertex: a named region of a surface mesh none of
  // whose vertices is its own could never be touched, pressed or aimed at (review 2026-12-06,
  // second: an internal error, exit 3, when a study's feature was such a region). A tet mesh's
  // inner tissues have no surface vertices by nature (SceneGeometry::region_centroid says so).
  std::vector<char> has_vertex(c->tet ? 0 : sm.regions.names.size(), 0);
  for (long i = 0; i < vr.size(); ++i)
    if (vr[i] >= 0 && vr[i] < static_cast<long>(has_vertex.size())) has_vertex[vr[i]] = 1;
  for (std::size_t r = 0; r < has_vertex.size(); ++r)
    if (!has_vertex[r] && !sm.regions.names[r].empty()) {
      const std::string why =
          "region \"" + sm.regions.names[r] +
          "\" has no vertex of its own (a vertex belongs to the first region, in file order, of "
          "the faces around it, and every vertex of this region's faces belongs to another): "
          "it could never be touched; give it vertices of its own or merge it into its "
          "neighbour";
      if (!m.file.empty()) throw InputError(why, m.file);
      throw InputError("mesh " + m.key() + ": " + why);
    }
  const Eigen::VectorXd fa = mesh::face_areas(sm.V, sm.F);
  c->vertex_area.setZero(sm.V.rows());
  for (long f = 0; f < sm.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) c->vertex_area[sm.F(f, k)] += fa[f] / 3.0;
  double sum = 0.0;
  for (long e = 0; e < sm.E.rows(); ++e)
    sum += (sm.V.row(sm.E(e, 0)) - sm.V.row(sm.E(e, 1))).norm();
  c->mean_edge = sm.E.rows() ? sum / sm.E.rows() : 0.01;
  c->octree = std::make_shared<const spatial::Octree>(spatial::build_octree(sm.V, 12, 8));
  c->rings = std::make_shared<const mesh::RingTable>(
      mesh::compute_rings(static_cast<int>(sm.V.rows()), sm.E));
  c->face_index = std::make_shared<const FaceIndex>(build_face_index(c->V, c->F));
  if (!c->tet) {
    c->model_V = sm.V;
    c->model_E = sm.E;
    c->model_F = sm.F;
    c->surface_to_model.resize(sm.V.rows());
    for (long i = 0; i < sm.V.rows(); ++i) c->surface_to_model[i] = static_cast<int>(i);
  }
  return c;
}

}  // namespace

namespace {
struct Cache {
  std::mutex mu;
  std::map<std::string, std::shared_ptr<const SceneMesh>> meshes;
};
Cache& cache() {
  static Cache c;
  return c;
}
}  // namespace

std::shared_ptr<const SceneMesh> scene_mesh(const MeshSource& m) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mu);
  auto it = c.meshes.find(m.key());
  if (it != c.meshes.end()) return it->second;
  auto p = prepare(m);
  c.meshes.emplace(m.key(), p);
  return p;
}

std::shared_ptr<const SceneMesh> build_scene_mesh(const MeshSource& m) {
  return prepare(m);
}

void install_scene_mesh(const MeshSource& m, std::shared_ptr<const SceneMesh> mesh) {
  install_scene_mesh_key(m.key(), std::move(mesh));
}

void install_scene_mesh_key(const std::string& key, std::shared_ptr<const SceneMesh> mesh) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mu);
  if (mesh)
    c.meshes[key] = std::move(mesh);
  else
    c.meshes.erase(key);
}

std::shared_ptr<const SceneMesh> cached_scene_mesh(const std::string& key) {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mu);
  auto it = c.meshes.find(key);
  return it == c.meshes.end() ? nullptr : it->second;
}

const std::vector<std::string>& mesh_region_names(const MeshSource& m) {
  static const std::vector<std::string> none;
  if (m.file.empty() && m.generator == "shoulder") return scene_mesh(m)->region_names;
  if (m.file.empty())
    return m.generator == "tract" || m.generator == "model_c" ? mesh::tract_region_names() : none;
  return scene_mesh(m)->region_names;
}

std::vector<std::string> mesh_inner_region_names(const MeshSource& m) {
  if (m.file.empty() && m.generator != "shoulder") return {};
  const auto sm = scene_mesh(m);
  std::vector<char> on_surface(sm->region_names.size(), 0);
  for (int r : sm->vertex_region)
    if (r >= 0 && r < static_cast<int>(on_surface.size())) on_surface[r] = 1;
  std::vector<std::string> inner;
  for (std::size_t r = 0; r < on_surface.size(); ++r)
    if (!on_surface[r]) inner.push_back(sm->region_names[r]);
  return inner;
}

}  // namespace palplab::engine
