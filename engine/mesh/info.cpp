#include "engine/mesh/info.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "engine/mesh/rings.hpp"

namespace palplab::mesh {

namespace {

struct Stats {
  double min = std::numeric_limits<double>::infinity(), max = -min, sum = 0;
  long n = 0;
  void add(double x) {
    min = std::min(min, x);
    max = std::max(max, x);
    sum += x;
    ++n;
  }
  nlohmann::ordered_json json() const {
    nlohmann::ordered_json j;
    if (n == 0) return nullptr;
    j["min"] = min;
    j["max"] = max;
    j["mean"] = sum / n;
    return j;
  }
};

nlohmann::ordered_json bbox(const Positions& V) {
  if (V.rows() == 0) return nullptr;
  const Eigen::RowVector3d lo = V.colwise().minCoeff(), hi = V.colwise().maxCoeff();
  return {{lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()}};
}

nlohmann::ordered_json region_counts(const Regions& r) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  if (r.empty()) return j;
  std::vector<long> c(r.names.size(), 0);
  long none = 0;
  for (int i = 0; i < r.id.size(); ++i) {
    if (r.id[i] >= 0 && r.id[i] < static_cast<int>(c.size()))
      ++c[r.id[i]];
    else
      ++none;
  }
  for (size_t i = 0; i < c.size(); ++i) j[r.names[i]] = c[i];
  if (none) j["(none)"] = none;
  return j;
}

void surface_part(nlohmann::ordered_json& j, const SurfaceMesh& m) {
  j["boundary_loops"] = boundary_loops(m).size();
  const int g = genus(m);
  j["genus"] = g >= 0 ? nlohmann::ordered_json(g) : nlohmann::ordered_json(nullptr);
  j["euler_characteristic"] = euler_characteristic(m);
  j["closed"] = count_boundary_edges(m) == 0;
  j["manifold"] = m.non_manifold_edges.empty() && m.non_manifold_vertices.empty();
  j["components"] = face_components(m);
}

}  // namespace

nlohmann::ordered_json surface_info(const SurfaceMesh& m) {
  nlohmann::ordered_json j;
  j["kind"] = "surface";
  j["vertices"] = m.V.rows();
  j["faces"] = m.F.rows();
  j["edges"] = m.E.rows();
  j["tets"] = 0;
  j["boundary_faces"] = m.F.rows();  // a surface is all boundary
  surface_part(j, m);
  j["bbox"] = bbox(m.V);
  j["regions"] = region_counts(m.regions);
  const Eigen::VectorXd A = face_areas(m.V, m.F);
  Stats area, len;
  for (int f = 0; f < A.size(); ++f) area.add(A[f]);
  for (int e = 0; e < m.E.rows(); ++e) len.add((m.V.row(m.E(e, 0)) - m.V.row(m.E(e, 1))).norm());
  j["area"] = A.sum();
  j["volume"] = j["closed"].get<bool>() ? nlohmann::ordered_json(enclosed_volume(m.V, m.F))
                                        : nlohmann::ordered_json(nullptr);
  j["edge_length"] = len.json();
  j["face_area"] = area.json();
  return j;
}

nlohmann::ordered_json tet_info(const TetMesh& m, const MaterialTable& materials) {
  nlohmann::ordered_json j;
  const BoundaryFaces b = boundary_faces(m);
  const Edges E = tet_edges(m.T);
  j["kind"] = "tet";
  j["vertices"] = m.V.rows();
  j["faces"] = (4 * m.T.rows() + b.F.rows()) / 2;  // every interior face is shared by two tets
  j["edges"] = E.rows();
  j["tets"] = m.T.rows();
  j["boundary_faces"] = b.F.rows();
  const SurfaceMesh s = make_surface_mesh(m.V, b.F);
  surface_part(j, s);  // loops, genus, ... of the boundary surface
  j["bbox"] = bbox(m.V);
  j["regions"] = region_counts(m.regions);
  Stats vol, rr, len;
  for (int t = 0; t < m.T.rows(); ++t) {
    vol.add(m.volume[t]);
    rr.add(radius_ratio(row3(m.V, m.T(t, 0)), row3(m.V, m.T(t, 1)), row3(m.V, m.T(t, 2)),
                        row3(m.V, m.T(t, 3))));
  }
  for (int e = 0; e < E.rows(); ++e) len.add((m.V.row(E(e, 0)) - m.V.row(E(e, 1))).norm());
  j["area"] = face_areas(m.V, b.F).sum();
  j["volume"] = m.volume.sum();
  j["edge_length"] = len.json();
  j["tet_volume"] = vol.json();
  j["radius_ratio"] = rr.json();
  std::map<int, long> tissue;
  for (int t = 0; t < m.T.rows(); ++t) ++tissue[m.attribute[t]];
  nlohmann::ordered_json tj = nlohmann::ordered_json::object();
  for (auto [a, n] : tissue) {
    const Material* mat = materials.find(a);
    tj[std::to_string(a)] = {{"tissue", mat ? mat->name : "unknown"}, {"tets", n}};
  }
  j["tissues"] = tj;
  return j;
}

}  // namespace palplab::mesh
