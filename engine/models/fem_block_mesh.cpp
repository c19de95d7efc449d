#include "engine/models/fem_block_mesh.hpp"

#include <algorithm>
#include <random>
#include <stdexcept>
#include <utility>

namespace palplab::engine {

mesh::TetMesh fem_block_mesh(int nx, int ny, int nz, const Eigen::Vector3d& size, int attribute,
                             double jitter, std::uint64_t seed) {
  if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("fem_block_mesh: n < 1");
  auto id = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  const Eigen::Vector3d h(size.x() / nx, size.y() / ny, size.z() / nz);
  mesh::Positions V((nx + 1) * (ny + 1) * (nz + 1), 3);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        Eigen::Vector3d p(i * h.x(), j * h.y(), k * h.z());
        const bool interior = i > 0 && i < nx && j > 0 && j < ny && k > 0 && k < nz;
        if (jitter > 0 && interior)
          for (int a = 0; a < 3; ++a) p[a] += jitter * h[a] * U(rng);
        V.row(id(i, j, k)) = p.transpose();
      }
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  mesh::Tets T(6 * nx * ny * nz, 4);
  long t = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        for (const auto& p : perms) {
          int c[3] = {0, 0, 0};
          int v[4];
          v[0] = id(i, j, k);
          for (int s = 0; s < 3; ++s) {
            c[p[s]] = 1;
            v[s + 1] = id(i + c[0], j + c[1], k + c[2]);
          }
          if (mesh::signed_volume(mesh::row3(V, v[0]), mesh::row3(V, v[1]), mesh::row3(V, v[2]),
                                  mesh::row3(V, v[3])) < 0)
            std::swap(v[2], v[3]);
          T.row(t++) << v[0], v[1], v[2], v[3];
        }
  return mesh::make_tet_mesh(std::move(V), std::move(T),
                             Eigen::VectorXi::Constant(6 * nx * ny * nz, attribute));
}

}  // namespace palplab::engine
