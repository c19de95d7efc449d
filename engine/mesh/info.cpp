#include "engine/mesh/info.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>

#include "engine/mesh/unique_edges.hpp"

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

std::array<double, 6> dihedral_angles(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const std::array<const Vec3*, 4> p{&a, &b, &c, &d};
  // Edge (i, j) with the two other corners (k, l): the angle between k and l seen along the edge,
  // i.e. between their offsets from the edge line projected onto the plane normal to it.
  static constexpr int kEdge[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                      {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  std::array<double, 6> out{};
  for (int e = 0; e < 6; ++e) {
    const Vec3& o = *p[kEdge[e][0]];
    const Vec3 t = *p[kEdge[e][1]] - o;
    const double tt = t.squaredNorm();
    if (tt <= 0) continue;
    Vec3 u = *p[kEdge[e][2]] - o, w = *p[kEdge[e][3]] - o;
    u -= (u.dot(t) / tt) * t;
    w -= (w.dot(t) / tt) * t;
    if (u.squaredNorm() <= 0 || w.squaredNorm() <= 0) continue;
    out[e] = std::atan2(u.cross(w).norm(), u.dot(w));
  }
  return out;
}

double radius_edge_ratio(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const double vol = std::abs(signed_volume(a, b, c, d));
  if (vol <= 0) return std::numeric_limits<double>::infinity();
  // Circumradius: |u²(v×w) + v²(w×u) + w²(u×v)| / (12 V) with u,v,w the edges from a.
  const Vec3 u = b - a, v = c - a, w = d - a;
  const Vec3 num =
      u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u) + w.squaredNorm() * u.cross(v);
  const double shortest =
      std::sqrt(std::min({u.squaredNorm(), v.squaredNorm(), w.squaredNorm(), (c - b).squaredNorm(),
                          (d - b).squaredNorm(), (d - c).squaredNorm()}));
  return num.norm() / (12 * vol) / shortest;
}

TetQuality tet_quality(const TetMesh& m) {
  TetQuality q;
  constexpr double kDeg = 180.0 / std::numbers::pi;
  Stats dih, re;
  const int nv = static_cast<int>(m.V.rows());
  Eigen::VectorXd node(nv);
  node.setZero();
  for (int t = 0; t < m.T.rows(); ++t) {
    const Vec3 a = row3(m.V, m.T(t, 0)), b = row3(m.V, m.T(t, 1)), c = row3(m.V, m.T(t, 2)),
               d = row3(m.V, m.T(t, 3));
    for (double x : dihedral_angles(a, b, c, d)) dih.add(x * kDeg);
    re.add(radius_edge_ratio(a, b, c, d));
    for (int k = 0; k < 4; ++k) node[m.T(t, k)] += m.volume[t] / 4;
  }
  if (dih.n) {
    q.min_dihedral_deg = dih.min;
    q.max_dihedral_deg = dih.max;
    q.mean_dihedral_deg = dih.sum / dih.n;
    q.min_radius_edge = re.min;
    q.max_radius_edge = re.max;
    q.mean_radius_edge = re.sum / re.n;
  }
  std::vector<char> on_boundary(nv, 0);
  const BoundaryFaces b = boundary_faces(m);
  for (int f = 0; f < b.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) on_boundary[b.F(f, k)] = 1;
  for (int v = 0; v < nv; ++v) {
    if (m.vertex_tets.row(v).empty())
      ++q.unused_nodes;
    else if (on_boundary[v])
      ++q.boundary_nodes;
    else
      ++q.interior_nodes;
  }
  if (nv > 0) {
    q.min_node_volume = node.minCoeff();
    q.max_node_volume = node.maxCoeff();
    q.mean_node_volume = node.mean();
    q.node_mass_ratio = q.min_node_volume > 0 ? q.max_node_volume / q.min_node_volume
                                              : std::numeric_limits<double>::infinity();
  }
  return q;
}

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
  const Edges E = unique_edges(m.T);
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
  const TetQuality q = tet_quality(m);
  auto finite = [](double x) {
    return std::isfinite(x) ? nlohmann::ordered_json(x) : nlohmann::ordered_json(nullptr);
  };
  if (m.T.rows() > 0) {
    j["dihedral_angle"] = {
        {"min", q.min_dihedral_deg}, {"max", q.max_dihedral_deg}, {"mean", q.mean_dihedral_deg}};
    j["radius_edge_ratio"] = {{"min", finite(q.min_radius_edge)},
                              {"max", finite(q.max_radius_edge)},
                              {"mean", finite(q.mean_radius_edge)}};
  } else {
    j["dihedral_angle"] = nullptr;
    j["radius_edge_ratio"] = nullptr;
  }
  j["interior_nodes"] = q.interior_nodes;
  j["boundary_nodes"] = q.boundary_nodes;
  j["unused_nodes"] = q.unused_nodes;
  j["node_volume"] = {
      {"min", q.min_node_volume}, {"max", q.max_node_volume}, {"mean", q.mean_node_volume}};
  j["node_mass_ratio"] = finite(q.node_mass_ratio);
  return j;
}

}  // namespace palplab::mesh
