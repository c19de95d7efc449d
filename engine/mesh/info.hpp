#pragma once
// Summary statistics of a mesh (`palplab mesh info`), as JSON. Keys (contract): vertices, faces,
// edges, tets, boundary_faces, boundary_loops, genus (null unless the surface — or a tet mesh's
// boundary — is a closed orientable 2-manifold), bbox [[min],[max]] (m), regions {name: count}
// (faces of a surface, tets of a tet mesh); plus kind, euler_characteristic, closed, area,
// volume, edge_length, face_area, tet_volume, radius_ratio, tissues.
#include <nlohmann/json.hpp>

#include "engine/mesh/materials.hpp"
#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::mesh {

nlohmann::ordered_json surface_info(const SurfaceMesh& m);
nlohmann::ordered_json tet_info(const TetMesh& m, const MaterialTable& materials);

}  // namespace palplab::mesh
