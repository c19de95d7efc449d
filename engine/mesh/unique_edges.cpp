#include "engine/mesh/unique_edges.hpp"

#include <algorithm>
#include <array>
#include <vector>

namespace palplab::mesh {

namespace {

// Every vertex pair of every element (a simplex: all pairs are edges), sorted and deduplicated.
template <typename Elements>
Edges edges_of_simplices(const Elements& S) {
  const int n = static_cast<int>(S.cols());
  std::vector<std::array<int, 2>> e;
  e.reserve(static_cast<size_t>(S.rows()) * n * (n - 1) / 2);
  for (long s = 0; s < S.rows(); ++s)
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        const int a = S(s, i), b = S(s, j);
        e.push_back({std::min(a, b), std::max(a, b)});
      }
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  Edges E(static_cast<long>(e.size()), 2);
  for (size_t k = 0; k < e.size(); ++k) E.row(static_cast<long>(k)) << e[k][0], e[k][1];
  return E;
}

}  // namespace

Edges unique_edges(const Faces& F) {
  return edges_of_simplices(F);
}

Edges unique_edges(const Tets& T) {
  return edges_of_simplices(T);
}

}  // namespace palplab::mesh
