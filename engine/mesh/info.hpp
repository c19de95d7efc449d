#pragma once
// Summary statistics of a mesh (`palplab mesh info`), as JSON. Keys (contract): vertices, faces,
// edges, tets, boundary_faces, boundary_loops, genus (null unless the surface — or a tet mesh's
// boundary — is a closed orientable 2-manifold), bbox [[min],[max]] (m), regions {name: count}
// (faces of a surface, tets of a tet mesh); plus kind, euler_characteristic, closed, area,
// volume, edge_length, face_area, tet_volume, radius_ratio, tissues; for tet meshes also
// dihedral_angle {min,max,mean} (degrees), radius_edge_ratio {min,max,mean}, interior_nodes,
// boundary_nodes, unused_nodes, node_volume {min,max,mean} (m^3, lumped, see TetQuality),
// node_mass_ratio (max/min, null when a node has no tet).
#include <array>
#include <nlohmann/json.hpp>

#include "engine/mesh/materials.hpp"
#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::mesh {

// The six dihedral angles (radians, in [0, pi]) of the tet (a, b, c, d), one per edge in the
// order ab, ac, ad, bc, bd, cd. All acos(1/3) = 70.53 deg for the regular tet; a sliver
// has angles near 0 and near pi. A degenerate tet (zero-area face) gives 0 for the edges of it.
std::array<double, 6> dihedral_angles(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

// Circumradius / shortest edge: sqrt(6)/4 = 0.612 for the regular tet; TetGen's -q bound is on
// this ratio. +inf for a degenerate (flat) tet.
double radius_edge_ratio(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

// Element quality and mass distribution of a tet mesh. Node mass is lumped as a quarter of the
// volume of every incident tet (uniform density: multiply by the density for kg), the lumping the
// mass-spring model uses; its max/min ratio bounds the stable explicit time step spread.
struct TetQuality {
  double min_dihedral_deg = 0, max_dihedral_deg = 0, mean_dihedral_deg = 0;
  double min_radius_edge = 0, max_radius_edge = 0, mean_radius_edge = 0;
  long interior_nodes = 0;  // nodes on no boundary face and in at least one tet
  long boundary_nodes = 0;  // nodes on a boundary face
  long unused_nodes = 0;    // nodes in no tet (their lumped mass is 0)
  double min_node_volume = 0, max_node_volume = 0, mean_node_volume = 0;  // m^3
  double node_mass_ratio = 0;  // max/min lumped node mass over all nodes; +inf if a node is unused
};
TetQuality tet_quality(const TetMesh& m);

nlohmann::ordered_json surface_info(const SurfaceMesh& m);
nlohmann::ordered_json tet_info(const TetMesh& m, const MaterialTable& materials);

}  // namespace palplab::mesh
