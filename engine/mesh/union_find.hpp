#pragma once
// Internal helper of the mesh module: the root of `x` in a union-find forest (`parent[i] == i` at
// a root), halving the path on the way. Not part of the public API.
#include <vector>

namespace palplab::mesh::detail {

inline int find_root(std::vector<int>& parent, int x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

}  // namespace palplab::mesh::detail
