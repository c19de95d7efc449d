// The octahedron |x| + |y| + |z| = 1 with unit vertex normals, faces counter-clockwise seen from
// outside: the closed surface of the contact and winding-number tests.
#pragma once

#include "engine/mesh/types.hpp"

namespace palplab::test {

struct Octahedron {
  mesh::Positions V, N;
  mesh::Faces F;
  Octahedron() {
    V.resize(6, 3);
    V << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
    N = V;
    F.resize(8, 3);
    int k = 0;
    for (int sx : {0, 1})
      for (int sy : {2, 3})
        for (int sz : {4, 5}) {
          // ccw seen from outside: the sign of the triple product of the three axes
          const double s = (sx == 0 ? 1 : -1) * (sy == 2 ? 1 : -1) * (sz == 4 ? 1 : -1);
          if (s > 0)
            F.row(k++) << sx, sy, sz;
          else
            F.row(k++) << sx, sz, sy;
        }
  }
};

}  // namespace palplab::test
