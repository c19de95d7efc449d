#pragma once
// Shared array types of the mesh toolkit (libigl convention, row-major so that a row is one
// vertex/face/tet and the whole array is contiguous).
//   V  #V by 3 positions (m)
//   F  #F by 3 vertex indices of triangles, counter-clockwise seen from outside
//   T  #T by 4 vertex indices of tetrahedra, positively oriented (see tet_mesh.hpp)
//   E  #E by 2 vertex indices of undirected edges, E(e,0) < E(e,1)
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <span>
#include <string>
#include <vector>

namespace palplab::mesh {

using Positions = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Faces = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Tets = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;
using Edges = Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>;
using Vec3 = Eigen::Vector3d;

inline Vec3 row3(const Positions& V, int i) {
  return V.row(i).transpose();
}

// Compressed sparse rows: the items of row i are index[offset[i] .. offset[i+1]).
struct Csr {
  std::vector<int> offset{0};  // #rows+1
  std::vector<int> index;

  int rows() const { return static_cast<int>(offset.size()) - 1; }
  std::span<const int> row(int i) const {
    return {index.data() + offset[i], static_cast<size_t>(offset[i + 1] - offset[i])};
  }
};

// Named regions (ovary_left, body, ...): names[k] is the name of region id k; per element an id
// (or -1 for "no region"). Empty names = the mesh carries no regions.
struct Regions {
  std::vector<std::string> names;
  Eigen::VectorXi id;  // one per face (surfaces) or per tet (tet meshes); size 0 when no names

  bool empty() const { return names.empty(); }
};

}  // namespace palplab::mesh
