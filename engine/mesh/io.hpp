#pragma once
// Mesh files. Readers throw palplab::InputError with the file and the line (text formats) or the
// byte offset (binary formats) of the first problem. Formats are chosen by file extension.
//
// Surfaces (SurfaceMesh): .obj, .stl (ASCII or binary, detected), .off, .ply (ASCII, binary
// little or big endian), and .vtu (export, plus a reader for palplab's own VTU files).
// Tet meshes (TetMesh): TetGen .node/.ele (+ .face/.neigh written alongside), .vtu.
//
// Named regions travel with the file:
//   OBJ   `g <name>` groups (a new group line whenever the region changes, so face order is kept)
//   PLY   face property `int region` + header lines `comment region <id> <name>`
//   STL   ASCII only: one `solid <name>` block per run of faces of a region (a file with a single
//         solid has no regions: its name is just the file's name). Binary STL carries none.
//   OFF   none
//   TetGen  .ele attribute 1 = tissue attribute, attribute 2 = region id; the names
//         in the side table BASE.names (`<count>` then `<id> <name>` per line)
//   VTU   cell data `region` (id) and `attribute`; names in a FieldData string array.
// STL stores every triangle with its own corners: identical corners (bitwise) are merged on
// reading, so a round trip through STL keeps the vertices of a watertight mesh.
#include <string>

#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::mesh {

// A double as text that reads back to the same bits (%.17g): every writer uses it, so round
// trips through text formats are exact.
std::string format_exact(double x);

struct MaterialTable;

struct WriteOptions {
  bool binary = false;  // STL, PLY: binary (PLY: little endian, double coordinates)
};

SurfaceMesh read_surface(const std::string& path);
void write_surface(const std::string& path, const SurfaceMesh& m, const WriteOptions& o = {});

SurfaceMesh read_obj(const std::string& path);
void write_obj(const std::string& path, const SurfaceMesh& m);
SurfaceMesh read_stl(const std::string& path);
void write_stl(const std::string& path, const SurfaceMesh& m, bool binary);
SurfaceMesh read_off(const std::string& path);
void write_off(const std::string& path, const SurfaceMesh& m);
SurfaceMesh read_ply(const std::string& path);
void write_ply(const std::string& path, const SurfaceMesh& m, bool binary);

// TetGen files. `base` may be given with or without .node/.ele. write_tetgen writes
// base.node, base.ele, base.face (outer boundary, marker = attribute of the owning tet),
// base.neigh and, when the mesh has named regions, base.names.
TetMesh read_tetgen(const std::string& base);
void write_tetgen(const std::string& base, const TetMesh& m);
// The derived files, for tests and tools: faces (+ markers) and neighbours as written.
Faces read_tetgen_face(const std::string& path, Eigen::VectorXi* markers = nullptr);
Tets read_tetgen_neigh(const std::string& path);
std::string tetgen_base(const std::string& path);  // strips .node/.ele/.face/.neigh

// VTK XML unstructured grid (ASCII), for ParaView. Tet cells carry `attribute`, `region`,
// `volume` and, with a material table, `youngs_modulus`, `poisson_ratio`, `density`: then every
// tet's attribute must be defined by the table (InputError before the file is opened, never a
// NaN cell value).
void write_vtu(const std::string& path, const SurfaceMesh& m);
void write_vtu(const std::string& path, const TetMesh& m, const MaterialTable* materials = nullptr);

// What read_mesh found.
struct AnyMesh {
  bool is_tet = false;
  SurfaceMesh surface;  // when !is_tet
  TetMesh tet;          // when is_tet
};
// Any supported file: surfaces by extension, TetGen by .node/.ele, .vtu (palplab's own).
AnyMesh read_mesh(const std::string& path);
// True when path names a TetGen file set (.node, .ele) rather than a surface.
bool is_tetgen_path(const std::string& path);
std::string extension(const std::string& path);  // lower-case, with the dot; "" if none

}  // namespace palplab::mesh
