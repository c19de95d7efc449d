#include "engine/models/mass_spring_material.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "engine/models/refinement.hpp"

namespace palplab::engine {

namespace {

double tet_volume(const RowMatX3d& X, const RowMatX4i& T, long t) {
  const Eigen::Vector3d a = X.row(T(t, 0)).transpose(), b = X.row(T(t, 1)).transpose(),
                        c = X.row(T(t, 2)).transpose(), d = X.row(T(t, 3)).transpose();
  return std::abs((d - a).dot((d - b).cross(d - c))) / 6.0;
}

inline std::uint64_t key(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) |
         static_cast<std::uint32_t>(b);
}

// Springs on `edges` (sorted unique, as unique_edges gives) with k_e = sum of contributions.
// `given`: edges the caller had (not computed here from the contributions' elements); they are
// used only if they are exactly those edges -- rows i < j strictly ascending, every contribution
// on one of them, every one of them contributed to -- else false (out untouched).
bool from_contributions(const RowMatX3d& X, const RowMatX2i& edges,
                        const std::vector<std::pair<std::uint64_t, double>>& contrib, double beta,
                        bool given, Springs& out) {
  Springs s;
  s.rest.resize(edges.rows());
  s.ks.setZero(edges.rows());
  // edges are sorted lexicographically (i < j): binary search on the packed key
  std::vector<std::uint64_t> keys(edges.rows());
  for (long e = 0; e < edges.rows(); ++e) {
    if (given && !(edges(e, 0) >= 0 && edges(e, 0) < edges(e, 1) && edges(e, 1) < X.rows()))
      return false;
    keys[e] = key(edges(e, 0), edges(e, 1));
    if (given && e > 0 && keys[e] <= keys[e - 1]) return false;
  }
  std::vector<std::uint8_t> hit(given ? edges.rows() : 0, 0);
  for (const auto& [k, w] : contrib) {
    const auto it = std::lower_bound(keys.begin(), keys.end(), k);
    if (given) {
      if (it == keys.end() || *it != k) return false;
      hit[it - keys.begin()] = 1;
    }
    s.ks[it - keys.begin()] += w;
  }
  if (given && std::find(hit.begin(), hit.end(), 0) != hit.end()) return false;
  for (long e = 0; e < edges.rows(); ++e)
    s.rest[e] = (X.row(edges(e, 0)) - X.row(edges(e, 1))).norm();
  for (long e = 0; e < edges.rows(); ++e) s.ks[e] /= s.rest[e] * s.rest[e];
  s.kd = beta * s.ks;
  s.E = edges;
  out = std::move(s);
  return true;
}

Springs from_contributions(const RowMatX3d& X, const RowMatX2i& edges,
                           const std::vector<std::pair<std::uint64_t, double>>& contrib,
                           double beta) {
  Springs s;
  from_contributions(X, edges, contrib, beta, false, s);
  return s;
}

}  // namespace

Springs tet_springs(const RowMatX3d& X, const RowMatX4i& T, const Eigen::VectorXd& E_tet,
                    double beta, const RowMatX2i* edges) {
  std::vector<std::pair<std::uint64_t, double>> c;
  c.reserve(T.rows() * 6);
  for (long t = 0; t < T.rows(); ++t) {
    const double w = E_tet[t] * tet_volume(X, T, t);
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) c.emplace_back(key(T(t, i), T(t, j)), w);
  }
  Springs s;
  if (edges && from_contributions(X, *edges, c, beta, true, s)) return s;
  return from_contributions(X, unique_edges(T), c, beta);
}

Springs membrane_springs(const RowMatX3d& X, const RowMatX3i& F, const Eigen::VectorXd& c_face,
                         double beta) {
  const Eigen::VectorXd A = mesh_face_areas(X, F);
  std::vector<std::pair<std::uint64_t, double>> c;
  c.reserve(F.rows() * 3);
  for (long f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) c.emplace_back(key(F(f, k), F(f, (k + 1) % 3)), c_face[f] * A[f]);
  return from_contributions(X, unique_edges(F), c, beta);
}

Eigen::VectorXd tet_lumped_mass(const RowMatX3d& X, const RowMatX4i& T,
                                const Eigen::VectorXd& density_tet) {
  Eigen::VectorXd m = Eigen::VectorXd::Zero(X.rows());
  for (long t = 0; t < T.rows(); ++t) {
    const double q = density_tet[t] * tet_volume(X, T, t) / 4.0;
    for (int k = 0; k < 4; ++k) m[T(t, k)] += q;
  }
  return m;
}

Eigen::VectorXd lumped_area(const RowMatX3d& X, const RowMatX3i& F) {
  const Eigen::VectorXd A = mesh_face_areas(X, F);
  Eigen::VectorXd a = Eigen::VectorXd::Zero(X.rows());
  for (long f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) a[F(f, k)] += A[f] / 3.0;
  return a;
}

Eigen::VectorXd boundary_membrane(const RowMatX3d& X, const RowMatX4i& T, const RowMatX3i& F,
                                  const Eigen::VectorXi& tet_of, const Eigen::VectorXd& E_tet) {
  const Eigen::VectorXd A = mesh_face_areas(X, F);
  // A tet with several boundary faces is shared between them (each refines its part of it).
  std::unordered_map<int, int> faces_of_tet;
  for (long f = 0; f < F.rows(); ++f) ++faces_of_tet[tet_of[f]];
  Eigen::VectorXd c(F.rows());
  for (long f = 0; f < F.rows(); ++f)
    c[f] = A[f] > 0.0
               ? E_tet[tet_of[f]] * tet_volume(X, T, tet_of[f]) / (A[f] * faces_of_tet[tet_of[f]])
               : 0.0;
  return c;
}

}  // namespace palplab::engine
