#pragma once
// The probe face as a disc of quadrature points on the surface: a pad that does not depend on
// the mesh (issue 9).
//
// The probe's face is a flat disc of radius R (contact.patch_radius) centred on the contact
// point c of the rest surface, perpendicular to the contact normal n. Its quadrature points
// x_q (rings of equal area, weights w_q summing to 1) are projected along n onto the rest surface
// (a walk across faces), giving the surface point y_q = sum_i b_qi X_rest_i of face f_q with
// barycentric weights b_qi. Each point loads its face's three nodes by those weights: entry
// (node i, weight w_q b_qi). Because barycentric interpolation reproduces linear functions,
// the pad's total weight (1), its centroid (c) and its polar moment (R^2/2) are those of the
// disc on any flat mesh, at any resolution; and refinement splits faces at edge midpoints (the
// refined surface is the coarse one), so the same disc loads the coarse and the refined mesh
// alike. A point whose projection leaves the surface (an edge of an open surface, or beyond the
// silhouette) carries no load: the probe overhangs there.
//
// Penetration of entry k (node i of point q) under the probe plane through p (the device):
//   d_k = (X_i - p) . n - o_k,   o_k = (X_rest_i - y_q) . n + max(0, (y_q - c) . n),
// so sum_i b_qi d_k = (y_q(X) - p) . n - max(0, (y_q - c) . n) is the point's own penetration
// (its face moved with the nodes), and the face yields to points above the centre's rest tangent
// plane (a concave spot) as the vertex pads did. Each entry is clamped at 0 on its own (a
// lumped penalty: diagonal Jacobian blocks -k w_q b_qi n n^T, as MassSpringSystem holds them).
#include <vector>

#include <Eigen/Core>

#include "engine/models/mass_spring.hpp"  // RowMatX3d, RowMatX3i

namespace palplab::engine {

// The surface the pad walks on: faces, their neighbours across each edge, faces per node.
struct PadSurface {
  RowMatX3i F;                  // #F by 3 node indices
  RowMatX3i across;             // #F by 3: face across the edge opposite vertex k, -1 = none
  std::vector<int> node_start;  // CSR: faces of node i are node_faces[node_start[i] ..
  std::vector<int> node_faces;  //   node_start[i+1])
  long nodes = 0;               // node count it was built for
};
// F: #F by 3 (ccw from outside); nodes: node count (indices in F are < nodes).
void build_pad_surface(const RowMatX3i& F, long nodes, PadSurface& out);

struct PadPoint {
  int node;       // surface node loaded
  double w;       // its share w_q b_qi (the entries of a pad sum to <= 1)
  double offset;  // o_k (m), see above
};

// Disc quadrature: `rings` rings of equal area (ring j at radius R sqrt((j + 1/2) / rings),
// 6 (j + 1) points), so weights sum to 1, the centroid is the centre and the polar moment is
// R^2 / 2 exactly.
constexpr int kPadRings = 4;

// The pad of the disc of radius `radius` (m) centred at `centre` (a point on the rest surface X,
// in face `start` or near it) with normal n (unit, outward); entries appended to `out` (cleared
// first). Returns the face found under the centre (a start for the next call), -1 if none.
int disc_pad(const PadSurface& s, const RowMatX3d& X, const Eigen::Vector3d& centre,
             const Eigen::Vector3d& n, double radius, int start, std::vector<PadPoint>& out,
             int rings = kPadRings);

}  // namespace palplab::engine
