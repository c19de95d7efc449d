#pragma once
// Small meshes built in code for the mesh tests.
#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::mesh::testing {

// nx by ny grid of vertices in the z = 0 plane (spacing 1), each quad split along a->d:
// vertex id = i + nx*j; quad (a, b=a+1, c=a+nx, d=a+nx+1) -> triangles (a,b,d), (a,d,c).
inline SurfaceMesh grid(int nx, int ny) {
  Positions V(nx * ny, 3);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) V.row(i + nx * j) << i, j, 0;
  Faces F(2 * (nx - 1) * (ny - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      int a = i + nx * j, b = a + 1, c = a + nx, d = a + nx + 1;
      F.row(f++) << a, b, d;
      F.row(f++) << a, d, c;
    }
  return make_surface_mesh(V, F);
}

// Unit cube surface, 8 vertices, 12 outward triangles.
inline SurfaceMesh cube() {
  Positions V(8, 3);
  for (int i = 0; i < 8; ++i) V.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  Faces F(12, 3);
  F << 0, 2, 1, 1, 2, 3,  // z = 0 (normal -z)
      4, 5, 6, 5, 7, 6,   // z = 1
      0, 1, 4, 1, 5, 4,   // y = 0
      2, 6, 3, 3, 6, 7,   // y = 1
      0, 4, 2, 2, 4, 6,   // x = 0
      1, 3, 5, 3, 7, 5;   // x = 1
  return make_surface_mesh(V, F);
}

// n^3 cubes of side 1/n, each split into 6 positively oriented tets (Kuhn subdivision).
// attribute(cube centre) gives each tet's attribute.
template <class Attr>
TetMesh kuhn_grid(int n, Attr attribute) {
  const int m = n + 1;
  Positions V(m * m * m, 3);
  auto id = [m](int i, int j, int k) { return i + m * (j + m * k); };
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) V.row(id(i, j, k)) << double(i) / n, double(j) / n, double(k) / n;
  Tets T(6 * n * n * n, 4);
  Eigen::VectorXi A(T.rows());
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  int t = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (auto& p : perms) {
          int c[3] = {i, j, k};
          int tet[4];
          tet[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            tet[s + 1] = id(c[0], c[1], c[2]);
          }
          T.row(t) << tet[0], tet[1], tet[2], tet[3];
          if (signed_volume(V, T, t) < 0) std::swap(T(t, 2), T(t, 3));
          A[t] = attribute((i + 0.5) / n, (j + 0.5) / n, (k + 0.5) / n);
          ++t;
        }
  return make_tet_mesh(V, T, A);
}

}  // namespace palplab::mesh::testing
