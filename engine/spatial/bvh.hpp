#pragma once
// Bounding-volume hierarchy over axis-aligned boxes (triangles, tets), for broad-phase queries:
// all pairs of overlapping boxes in O(n log n + pairs) instead of O(n^2).
#include <utility>
#include <vector>

#include "engine/mesh/types.hpp"

namespace palplab::spatial {

struct BvhNode {
  Eigen::AlignedBox3d box;
  int left = -1, right = -1;  // children; -1 for a leaf
  int begin = 0, end = 0;     // run of `items` below this node
};

struct Bvh {
  std::vector<BvhNode> nodes;  // nodes[0] is the root
  std::vector<int> items;      // box indices, grouped by leaf
};

// Median split along the longest axis of the box centres; leaves hold <= leaf_size boxes.
Bvh build_bvh(const std::vector<Eigen::AlignedBox3d>& boxes, int leaf_size = 4);

// Every pair (i, j), i < j, of boxes that overlap (touching counts), each pair once.
std::vector<std::pair<int, int>> overlapping_pairs(const Bvh& bvh,
                                                   const std::vector<Eigen::AlignedBox3d>& boxes);

// Boxes of the triangles F of V, enlarged by pad on every side.
std::vector<Eigen::AlignedBox3d> triangle_boxes(const mesh::Positions& V, const mesh::Faces& F,
                                                double pad = 0);

}  // namespace palplab::spatial
