#include "engine/spatial/octree.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace palplab::spatial {

namespace {

int octant_of(const Eigen::AlignedBox3d& cell, const double* p) {
  const Vec3 c = cell.center();
  return (p[0] >= c.x() ? 1 : 0) | (p[1] >= c.y() ? 2 : 0) | (p[2] >= c.z() ? 4 : 0);
}

Eigen::AlignedBox3d octant_cell(const Eigen::AlignedBox3d& cell, int o) {
  const Vec3 c = cell.center();
  Vec3 lo = cell.min(), hi = cell.max();
  for (int a = 0; a < 3; ++a) {
    if (o & (1 << a))
      lo[a] = c[a];
    else
      hi[a] = c[a];
  }
  return {lo, hi};
}

void split(Octree& t, const Positions& V, int n, std::vector<int>& scratch) {
  OctreeNode node = t.nodes[n];
  const int count = node.end - node.begin;
  if (count <= t.max_points_per_leaf || node.depth >= t.max_depth) return;
  // Counting sort of the run by octant (stable, so the layout is deterministic).
  std::array<int, 9> start{};
  for (int i = node.begin; i < node.end; ++i)
    ++start[octant_of(node.cell, V.row(t.order[i]).data()) + 1];
  for (int o = 0; o < 8; ++o) start[o + 1] += start[o];
  std::array<int, 8> fill;
  for (int o = 0; o < 8; ++o) fill[o] = start[o];
  scratch.resize(count);
  for (int i = node.begin; i < node.end; ++i)
    scratch[fill[octant_of(node.cell, V.row(t.order[i]).data())]++] = t.order[i];
  std::copy(scratch.begin(), scratch.begin() + count, t.order.begin() + node.begin);
  t.nodes[n].leaf = false;
  for (int o = 0; o < 8; ++o) {
    if (start[o + 1] == start[o]) continue;
    OctreeNode c;
    c.cell = octant_cell(node.cell, o);
    c.begin = node.begin + start[o];
    c.end = node.begin + start[o + 1];
    c.depth = node.depth + 1;
    const int id = static_cast<int>(t.nodes.size());
    t.nodes.push_back(c);
    t.nodes[n].child[o] = id;
    split(t, V, id, scratch);
  }
}

// Tight boxes bottom-up; children always have larger indices than their parent.
void fit_boxes(Octree& t, const Positions& V) {
  for (int n = static_cast<int>(t.nodes.size()) - 1; n >= 0; --n) {
    OctreeNode& node = t.nodes[n];
    node.box.setEmpty();
    if (node.leaf) {
      for (int i = node.begin; i < node.end; ++i) node.box.extend(V.row(t.order[i]).transpose());
    } else {
      for (int c : node.child)
        if (c >= 0) node.box.extend(t.nodes[c].box);
    }
  }
}

}  // namespace

Octree build_octree(const Positions& V, int max_depth, int max_points_per_leaf) {
  // The query stack is a fixed array sized for kMaxOctreeDepth levels.
  if (max_depth < 0 || max_depth > kMaxOctreeDepth || max_points_per_leaf < 1)
    throw std::invalid_argument("octree: max_depth must be in [0, " +
                                std::to_string(kMaxOctreeDepth) + "] and max_points_per_leaf >= 1");
  Octree t;
  t.max_depth = max_depth;
  t.max_points_per_leaf = max_points_per_leaf;
  const int nv = static_cast<int>(V.rows());
  t.order.resize(nv);
  for (int i = 0; i < nv; ++i) t.order[i] = i;
  OctreeNode root;
  if (nv > 0) {
    // A cube around the points, slightly enlarged so no point sits on the far faces.
    Eigen::AlignedBox3d b;
    for (int i = 0; i < nv; ++i) b.extend(V.row(i).transpose());
    const double half = 0.5 * b.sizes().maxCoeff() * (1 + 1e-9) + 1e-12;
    root.cell =
        Eigen::AlignedBox3d(b.center() - Vec3::Constant(half), b.center() + Vec3::Constant(half));
  }
  root.begin = 0;
  root.end = nv;
  t.nodes.push_back(root);
  std::vector<int> scratch;
  split(t, V, 0, scratch);
  t.leaf_of.assign(nv, -1);
  for (int n = 0; n < static_cast<int>(t.nodes.size()); ++n)
    if (t.nodes[n].leaf)
      for (int i = t.nodes[n].begin; i < t.nodes[n].end; ++i) t.leaf_of[t.order[i]] = n;
  fit_boxes(t, V);
  return t;
}

void refit(Octree& tree, const Positions& V) {
  if (static_cast<size_t>(V.rows()) != tree.leaf_of.size())
    throw std::invalid_argument("octree refit: node count changed since build");
  fit_boxes(tree, V);
}

int nearest(const Octree& t, const Positions& V, const Vec3& q, double* d2) {
  int best = -1;
  double bd = std::numeric_limits<double>::infinity();
  if (d2) *d2 = bd;
  if (t.order.empty()) return -1;
  // A NaN or infinite query has no nearest node (device glitches produce them); every distance
  // would compare false and the descent below would have no child to follow.
  if (!q.allFinite()) return -1;
  // A finite query so far away that squared distances overflow to inf (|q| ~ 1e155 and beyond):
  // answer exactly with a scaled linear pass instead of a tree walk that cannot prune.
  if (q.cwiseAbs().maxCoeff() > 1e150) return linear_nearest(V, q, d2);
  // Depth-first, nearer children first, pruning boxes farther than the best so far. Boxes at
  // exactly the best distance are still visited so ties resolve to the smallest index.
  struct Item {
    int node;
    double d;
  };
  // A first bound from the leaf whose cell holds q (or the nearest cell on the way down), so
  // that the traversal below prunes from the start.
  {
    int n = 0;
    while (!t.nodes[n].leaf) {
      const OctreeNode& node = t.nodes[n];
      int next = node.child[octant_of(node.cell, q.data())];
      if (next < 0) {  // empty octant: the child with the nearest box
        double dn = std::numeric_limits<double>::infinity();
        for (int c : node.child)
          if (c >= 0) {
            const double d = t.nodes[c].box.squaredExteriorDistance(q);
            if (d < dn) {
              dn = d;
              next = c;
            }
          }
      }
      if (next < 0)  // every box at distance inf or NaN (node positions not finite)
        for (int c : node.child)
          if (c >= 0) {
            next = c;
            break;
          }
      n = next;
    }
    for (int i = t.nodes[n].begin; i < t.nodes[n].end; ++i) {
      const int p = t.order[i];
      const double d = (V.row(p).transpose() - q).squaredNorm();
      if (d < bd || (d == bd && p < best)) {
        bd = d;
        best = p;
      }
    }
  }
  Item stack[7 * kMaxOctreeDepth + 8];
  int top = 0;
  stack[top++] = {0, t.nodes[0].box.squaredExteriorDistance(q)};
  while (top > 0) {
    const Item it = stack[--top];
    if (it.d > bd) continue;
    const OctreeNode& n = t.nodes[it.node];
    if (n.leaf) {
      for (int i = n.begin; i < n.end; ++i) {
        const int p = t.order[i];
        const double d = (V.row(p).transpose() - q).squaredNorm();
        if (d < bd || (d == bd && p < best)) {
          bd = d;
          best = p;
        }
      }
      continue;
    }
    Item kids[8];
    int nk = 0;
    for (int c : n.child)
      if (c >= 0) {
        const double d = t.nodes[c].box.squaredExteriorDistance(q);
        if (d <= bd) kids[nk++] = {c, d};
      }
    // Push farthest first so the nearest is popped first.
    // Insertion sort: at most 8 items.
    for (int a = 1; a < nk; ++a)
      for (int b = a; b > 0 && kids[b - 1].d < kids[b].d; --b) std::swap(kids[b - 1], kids[b]);
    for (int k = 0; k < nk; ++k) stack[top++] = kids[k];
  }
  if (d2) *d2 = bd;
  return best;
}

int linear_nearest(const Positions& V, const Vec3& q, double* d2) {
  int best = -1;
  double bd = std::numeric_limits<double>::infinity();
  if (d2) *d2 = bd;
  if (!q.allFinite()) return -1;
  const double m = q.cwiseAbs().maxCoeff();
  if (m > 1e150) {
    // A far query: |V_i - q|^2 = |q|^2 + (|V_i|^2 - 2 V_i.q) overflows, but the bracket orders
    // the nodes the same way; it is compared scaled by 1/m so that nothing overflows.
    const Vec3 qs = q / m;
    for (int p = 0; p < V.rows(); ++p) {
      const Vec3 v = V.row(p).transpose();
      const double k = v.squaredNorm() / m - 2.0 * v.dot(qs);
      if (k < bd) {
        bd = k;
        best = p;
      }
    }
    if (d2 && best >= 0) *d2 = (V.row(best).transpose() - q).squaredNorm();  // inf if > DBL_MAX
    return best;
  }
  for (int p = 0; p < V.rows(); ++p) {
    const double d = (V.row(p).transpose() - q).squaredNorm();
    if (d < bd) {
      bd = d;
      best = p;
    }
  }
  if (d2) *d2 = bd;
  return best;
}

std::span<const int> leaf_points(const Octree& t, int leaf) {
  const OctreeNode& n = t.nodes[leaf];
  return {t.order.data() + n.begin, static_cast<size_t>(n.end - n.begin)};
}

int count_leaves(const Octree& t) {
  return static_cast<int>(
      std::count_if(t.nodes.begin(), t.nodes.end(), [](const OctreeNode& n) { return n.leaf; }));
}

}  // namespace palplab::spatial
