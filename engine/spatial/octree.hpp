#pragma once
// Octree over mesh nodes for the touched-node search.
//
// Built once over the rest positions: the root cube is split into octants until a cell holds at
// most max_points_per_leaf nodes or reaches max_depth. Leaves own contiguous runs of `order`.
// Each node also carries a tight bounding box; after nodes move, refit() recomputes the boxes
// bottom-up (membership stays, so the tree stays valid and queries stay exact, only pruning gets
// looser as nodes drift). Queries return the nearest node exactly; ties go to the smaller index,
// like linear_nearest().
#include <span>
#include <vector>

#include "engine/mesh/types.hpp"

namespace palplab::spatial {

using mesh::Positions;
using mesh::Vec3;

inline constexpr int kMaxOctreeDepth = 60;

struct OctreeNode {
  Eigen::AlignedBox3d cell;  // the octant this node subdivides (fixed at build time)
  Eigen::AlignedBox3d box;   // tight box of the nodes below it (updated by refit)
  int child[8] = {-1, -1, -1, -1, -1, -1, -1, -1};  // -1 = empty octant (or leaf)
  int begin = 0, end = 0;                           // run of `order` holding this node's points
  int depth = 0;
  bool leaf = true;
};

struct Octree {
  std::vector<OctreeNode> nodes;  // nodes[0] is the root
  std::vector<int> order;         // point indices, grouped by leaf
  std::vector<int> leaf_of;       // #V: index of the leaf holding each point
  int max_depth = 8;
  int max_points_per_leaf = 8;
};

// V  #V by 3 node positions. 0 <= max_depth <= kMaxOctreeDepth, max_points_per_leaf >= 1 (the
// caller chooses both).
Octree build_octree(const Positions& V, int max_depth, int max_points_per_leaf);
// Recomputes every node's tight box from the current positions V (same #V as at build).
void refit(Octree& tree, const Positions& V);
// Nearest node to q (index), its squared distance in *d2 when given (m^2). -1 (and *d2 = inf)
// for an empty set or a query that is not finite (NaN, +-inf): callers must handle -1. A finite
// but huge query (|q| up to DBL_MAX) still gets its exact nearest node; *d2 is then inf when the
// squared distance overflows.
int nearest(const Octree& tree, const Positions& V, const Vec3& q, double* d2 = nullptr);
// The baseline: one pass over all nodes. Same contract for empty sets and non-finite queries.
int linear_nearest(const Positions& V, const Vec3& q, double* d2 = nullptr);
// The leaf (octant) holding node i and the nodes it holds.
inline int leaf_of(const Octree& tree, int i) {
  return tree.leaf_of[i];
}
std::span<const int> leaf_points(const Octree& tree, int leaf);
// Number of leaves and maximal depth reached (for info/benchmarks).
int count_leaves(const Octree& tree);

}  // namespace palplab::spatial
