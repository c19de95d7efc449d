#pragma once
// An analytic layered slab for the needle tests: x, y in [-0.01, 0.01] m, layers stacked
// downwards from z = 0, each layer a rectilinear block split into Kuhn tets.
#include <algorithm>
#include <array>
#include <vector>

#include "engine/mesh/tet_mesh.hpp"

namespace palplab::needle_testing {

using mesh::Positions;
using mesh::Tets;

struct SlabLayer {
  double thickness;  // m
  int tissue;
};

// The top of layer i is at z = -(sum of the thicknesses above it).
inline mesh::TetMesh layered_slab(const std::vector<SlabLayer>& layers, int cells_xy = 4,
                                  int cells_per_layer = 2) {
  std::vector<double> xs, zs;
  for (int i = 0; i <= cells_xy; ++i) xs.push_back(-0.01 + 0.02 * i / cells_xy);
  std::vector<int> zt;  // tissue of the cell below zs[k]
  double z = 0;
  zs.push_back(0);
  for (const SlabLayer& l : layers)
    for (int c = 0; c < cells_per_layer; ++c) {
      zs.push_back(z - l.thickness * (c + 1) / cells_per_layer);
      zt.push_back(l.tissue);
      if (c + 1 == cells_per_layer) z -= l.thickness;
    }
  const int nx = static_cast<int>(xs.size()), nz = static_cast<int>(zs.size());
  Positions V(nx * nx * nz, 3);
  auto id = [&](int i, int j, int k) { return i + nx * (j + nx * k); };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < nx; ++j)
      for (int i = 0; i < nx; ++i) V.row(id(i, j, k)) << xs[i], xs[j], zs[k];
  std::vector<std::array<int, 4>> T;
  std::vector<int> A;
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < nx; ++j)
      for (int i = 0; i + 1 < nx; ++i)
        for (auto& p : perms) {
          int c[3] = {i, j, k};
          std::array<int, 4> t;
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          if (mesh::signed_volume(mesh::row3(V, t[0]), mesh::row3(V, t[1]), mesh::row3(V, t[2]),
                                  mesh::row3(V, t[3])) < 0)
            std::swap(t[2], t[3]);
          T.push_back(t);
          A.push_back(zt[k]);
        }
  Tets TT(T.size(), 4);
  Eigen::VectorXi AA(A.size());
  for (size_t t = 0; t < T.size(); ++t) {
    for (int q = 0; q < 4; ++q) TT(t, q) = T[t][q];
    AA[t] = A[t];
  }
  return mesh::make_tet_mesh(std::move(V), std::move(TT), std::move(AA));
}

}  // namespace palplab::needle_testing
