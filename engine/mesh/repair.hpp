#pragma once
// Safe surface repairs (`palplab mesh repair`): merge duplicate vertices, drop degenerate and
// duplicate faces, orient every component consistently (and outwards when closed), fill small
// holes, drop unused vertices. Non-manifold edges and self-intersections are not repaired (no
// safe automatic fix): `mesh check` still reports them afterwards.
#include <string>
#include <vector>

#include "engine/mesh/surface_mesh.hpp"

namespace palplab::mesh {

struct RepairOptions {
  double merge_tolerance = 1e-9;    // m, as duplicate_vertex in mesh check
  double degenerate_ratio = 1e-10;  // as degenerate_face in mesh check
  int max_hole_edges = 16;          // boundary loops up to this many edges are filled
  bool fill_holes = true;
};

struct RepairLog {
  int merged_vertices = 0;  // vertices merged into an earlier duplicate
  int dropped_degenerate_faces = 0;
  int dropped_duplicate_faces = 0;
  int flipped_faces = 0;  // faces re-oriented
  int filled_holes = 0;
  int added_faces = 0;     // faces added to fill holes
  int added_vertices = 0;  // one centre vertex per filled hole
  int removed_unused_vertices = 0;
  int unfilled_holes = 0;  // loops longer than max_hole_edges
  bool changed() const {
    return merged_vertices || dropped_degenerate_faces || dropped_duplicate_faces ||
           flipped_faces || filled_holes || removed_unused_vertices;
  }
  std::vector<std::string> lines() const;  // human-readable summary, one change per line
};

SurfaceMesh repair(const SurfaceMesh& in, const RepairOptions& opt = {}, RepairLog* log = nullptr);

}  // namespace palplab::mesh
