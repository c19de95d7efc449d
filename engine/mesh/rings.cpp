#include "engine/mesh/rings.hpp"

#include <algorithm>
#include <array>

namespace palplab::mesh {

RingTable compute_rings(int nV, const Edges& E) {
  RingTable r;
  // First ring: counting sort of both directions of every edge.
  r.first.offset.assign(nV + 1, 0);
  for (int e = 0; e < E.rows(); ++e) {
    ++r.first.offset[E(e, 0) + 1];
    ++r.first.offset[E(e, 1) + 1];
  }
  for (int v = 0; v < nV; ++v) r.first.offset[v + 1] += r.first.offset[v];
  r.first.index.resize(r.first.offset[nV]);
  std::vector<int> fill(r.first.offset.begin(), r.first.offset.end() - 1);
  for (int e = 0; e < E.rows(); ++e) {
    r.first.index[fill[E(e, 0)]++] = E(e, 1);
    r.first.index[fill[E(e, 1)]++] = E(e, 0);
  }
  for (int v = 0; v < nV; ++v)
    std::sort(r.first.index.begin() + r.first.offset[v],
              r.first.index.begin() + r.first.offset[v + 1]);
  // Second ring: mark v and its first ring with a stamp, collect unmarked neighbours-of-
  // neighbours. O(sum of valence^2), no per-vertex allocation.
  std::vector<int> stamp(nV, -1);
  std::vector<int> tmp;
  r.second.offset.assign(1, 0);
  r.second.offset.reserve(nV + 1);
  for (int v = 0; v < nV; ++v) {
    stamp[v] = v;
    for (int q : r.first.row(v)) stamp[q] = v;
    tmp.clear();
    for (int q : r.first.row(v))
      for (int s : r.first.row(q))
        if (stamp[s] != v) {
          stamp[s] = v;
          tmp.push_back(s);
        }
    std::sort(tmp.begin(), tmp.end());
    r.second.index.insert(r.second.index.end(), tmp.begin(), tmp.end());
    r.second.offset.push_back(static_cast<int>(r.second.index.size()));
  }
  return r;
}

}  // namespace palplab::mesh
