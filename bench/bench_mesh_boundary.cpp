// Boundary-face extraction of tet meshes ("triangle reduction"): vertex->tets map
// (O(n)) vs comparing every pair of tets (O(n^2), what took hours in the original work).
// Kuhn-subdivided cube grids and Model-C; medians over repetitions, side by side, and the ratio.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "engine/haptics/clock.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/tet_mesh.hpp"

using namespace palplab::mesh;
using Clock = std::chrono::steady_clock;

namespace {

TetMesh grid(int n) {
  const int m = n + 1;
  Positions V(m * m * m, 3);
  auto id = [m](int i, int j, int k) { return i + m * (j + m * k); };
  for (int k = 0; k < m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) V.row(id(i, j, k)) << i, j, k;
  Tets T(6 * n * n * n, 4);
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  int t = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (auto& p : perms) {
          int c[3] = {i, j, k}, v[4];
          v[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            v[s + 1] = id(c[0], c[1], c[2]);
          }
          T.row(t) << v[0], v[1], v[2], v[3];
          if (signed_volume(V, T, t) < 0) std::swap(T(t, 2), T(t, 3));
          ++t;
        }
  return make_tet_mesh(V, T);
}

template <class F>
double time_ms(F f, int reps) {
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) {
    auto a = Clock::now();
    f();
    t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - a).count());
  }
  return palplab::engine::median(t);
}

}  // namespace

int main() {
  std::printf("%-14s %8s %10s %12s %14s %10s %6s\n", "mesh", "tets", "faces", "linear_ms",
              "brute_ms", "ratio", "check");
  std::vector<std::pair<std::string, TetMesh>> meshes;
  for (int n : {4, 6, 8, 10}) meshes.push_back({"grid " + std::to_string(n) + "^3", grid(n)});
  meshes.push_back({"model-c", generate_model_c()});
  for (auto& [name, m] : meshes) {
    BoundaryFaces a, b;
    const double lin = time_ms([&] { a = boundary_faces(m); }, 11);
    const int reps = m.T.rows() > 5000 ? 3 : 5;
    const double brute = time_ms([&] { b = boundary_faces_brute_force(m); }, reps);
    std::printf("%-14s %8ld %10ld %12.3f %14.1f %10.0f %6s\n", name.c_str(),
                static_cast<long>(m.T.rows()), static_cast<long>(a.F.rows()), lin, brute,
                brute / lin, a.F == b.F ? "same" : "DIFF");
  }
  return 0;
}
