#include "engine/spatial/bvh.hpp"

#include <algorithm>

namespace palplab::spatial {

namespace {

int build(Bvh& b, const std::vector<Eigen::AlignedBox3d>& boxes, int begin, int end, int leaf) {
  const int id = static_cast<int>(b.nodes.size());
  b.nodes.emplace_back();
  Eigen::AlignedBox3d box, centres;
  for (int i = begin; i < end; ++i) {
    box.extend(boxes[b.items[i]]);
    centres.extend(boxes[b.items[i]].center());
  }
  b.nodes[id].box = box;
  b.nodes[id].begin = begin;
  b.nodes[id].end = end;
  if (end - begin <= leaf) return id;
  int axis;
  centres.sizes().maxCoeff(&axis);
  const int mid = (begin + end) / 2;
  std::nth_element(b.items.begin() + begin, b.items.begin() + mid, b.items.begin() + end,
                   [&](int x, int y) {
                     const double cx = boxes[x].center()[axis], cy = boxes[y].center()[axis];
                     return cx < cy || (cx == cy && x < y);
                   });
  const int l = build(b, boxes, begin, mid, leaf);
  const int r = build(b, boxes, mid, end, leaf);
  b.nodes[id].left = l;
  b.nodes[id].right = r;
  return id;
}

}  // namespace

Bvh build_bvh(const std::vector<Eigen::AlignedBox3d>& boxes, int leaf_size) {
  Bvh b;
  b.items.resize(boxes.size());
  for (size_t i = 0; i < boxes.size(); ++i) b.items[i] = static_cast<int>(i);
  if (!boxes.empty()) build(b, boxes, 0, static_cast<int>(boxes.size()), std::max(1, leaf_size));
  return b;
}

std::vector<std::pair<int, int>> overlapping_pairs(const Bvh& b,
                                                   const std::vector<Eigen::AlignedBox3d>& boxes) {
  std::vector<std::pair<int, int>> out;
  if (b.nodes.empty()) return out;
  // Simultaneous descent of the tree against itself; (n, n) pairs handle a node's own items.
  std::vector<std::pair<int, int>> stack{{0, 0}};
  while (!stack.empty()) {
    auto [x, y] = stack.back();
    stack.pop_back();
    const BvhNode& a = b.nodes[x];
    const BvhNode& c = b.nodes[y];
    if (x != y && !a.box.intersects(c.box)) continue;
    const bool la = a.left < 0, lc = c.left < 0;
    if (la && lc) {
      for (int i = a.begin; i < a.end; ++i)
        for (int j = (x == y ? i + 1 : c.begin); j < c.end; ++j) {
          const int p = b.items[i], q = b.items[j];
          if (boxes[p].intersects(boxes[q])) out.push_back({std::min(p, q), std::max(p, q)});
        }
    } else if (x == y) {
      stack.push_back({a.left, a.left});
      stack.push_back({a.right, a.right});
      stack.push_back({a.left, a.right});
    } else if (!la && (lc || a.end - a.begin >= c.end - c.begin)) {
      stack.push_back({a.left, y});
      stack.push_back({a.right, y});
    } else {
      stack.push_back({x, c.left});
      stack.push_back({x, c.right});
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Eigen::AlignedBox3d> triangle_boxes(const mesh::Positions& V, const mesh::Faces& F,
                                                double pad) {
  std::vector<Eigen::AlignedBox3d> boxes(F.rows());
  for (int f = 0; f < F.rows(); ++f) {
    Eigen::AlignedBox3d& b = boxes[f];
    for (int k = 0; k < 3; ++k) b.extend(V.row(F(f, k)).transpose());
    b.min().array() -= pad;
    b.max().array() += pad;
  }
  return boxes;
}

}  // namespace palplab::spatial
