#include "engine/solvers/fem_assembly.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "common/input_error.hpp"

namespace palplab::engine {

TetMaterials tet_materials(const mesh::TetMesh& m, const mesh::MaterialTable& table) {
  const long n = m.T.rows();
  TetMaterials mat = uniform_materials(n, 1, 0, 0);
  for (long t = 0; t < n; ++t) {
    const int a = m.attribute.size() ? m.attribute[t] : 0;
    const mesh::Material* e = table.find(a);
    if (!e)
      throw InputError("tet " + std::to_string(t) + " has attribute " + std::to_string(a) +
                       " (tissue type) which the material table does not cover");
    mat.youngs_modulus[t] = e->youngs_modulus;
    mat.poisson_ratio[t] = e->poisson_ratio;
    mat.density[t] = e->density;
    mat.rigid[t] = e->rigid ? 1 : 0;
  }
  return mat;
}

TetMaterials uniform_materials(long tets, double E, double nu, double rho) {
  TetMaterials mat;
  mat.youngs_modulus = Eigen::VectorXd::Constant(tets, E);
  mat.poisson_ratio = Eigen::VectorXd::Constant(tets, nu);
  mat.density = Eigen::VectorXd::Constant(tets, rho);
  mat.rigid.assign(tets, 0);
  return mat;
}

std::vector<std::uint8_t> rigid_nodes(const mesh::TetMesh& m, const TetMaterials& mat) {
  std::vector<std::uint8_t> fixed(m.V.rows(), 0);
  for (long t = 0; t < m.T.rows(); ++t)
    if (mat.rigid[t])
      for (int k = 0; k < 4; ++k) fixed[m.T(t, k)] = 1;
  return fixed;
}

FemPattern build_pattern(const mesh::Tets& T, long nodes) {
  FemPattern p;
  const long n = 3 * nodes;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(T.rows() * 144);
  for (long t = 0; t < T.rows(); ++t)
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 12; ++i)
        trip.emplace_back(3 * T(t, i / 3) + i % 3, 3 * T(t, j / 3) + j % 3, 0.0);
  p.matrix.resize(n, n);
  p.matrix.setFromTriplets(trip.begin(), trip.end());
  p.matrix.makeCompressed();
  p.slot.resize(T.rows() * 144);
  const int* outer = p.matrix.outerIndexPtr();
  const int* inner = p.matrix.innerIndexPtr();
  for (long t = 0; t < T.rows(); ++t)
    for (int j = 0; j < 12; ++j) {
      const int col = 3 * T(t, j / 3) + j % 3;
      for (int i = 0; i < 12; ++i) {
        const int row = 3 * T(t, i / 3) + i % 3;
        const int* b = inner + outer[col];
        const int* e = inner + outer[col + 1];
        p.slot[144 * t + 12 * j + i] = static_cast<int>(std::lower_bound(b, e, row) - inner);
      }
    }
  return p;
}

void assemble(const FemPattern& p, const std::vector<Matrix12d>& Ke, SparseMatrixd& out) {
  if (out.rows() != p.matrix.rows() || out.nonZeros() != p.matrix.nonZeros()) out = p.matrix;
  double* v = out.valuePtr();
  std::fill(v, v + out.nonZeros(), 0.0);
  const long nt = static_cast<long>(Ke.size());
  for (long t = 0; t < nt; ++t) {
    const double* k = Ke[t].data();  // column-major: k[12 j + i] = (i, j)
    const int* s = p.slot.data() + 144 * t;
    for (int q = 0; q < 144; ++q) v[s[q]] += k[q];
  }
}

FemSystem fem_precompute(const mesh::Positions& X0, const mesh::Tets& T, const TetMaterials& mat) {
  if (mat.size() != T.rows())
    throw InputError("fem: " + std::to_string(mat.size()) + " materials for " +
                     std::to_string(T.rows()) + " tets");
  FemSystem s;
  s.X0 = X0;
  s.T = T;
  s.material = mat;
  const long nt = T.rows();
  s.shape.resize(nt);
  s.Ke.resize(nt);
  std::vector<Matrix12d> Me(nt);
  s.m_lumped = Eigen::VectorXd::Zero(3 * X0.rows());
  for (long t = 0; t < nt; ++t) {
    try {
      s.shape[t] = tet_shape(mesh::row3(X0, T(t, 0)), mesh::row3(X0, T(t, 1)),
                             mesh::row3(X0, T(t, 2)), mesh::row3(X0, T(t, 3)));
      if (s.shape[t].volume < 0) throw std::invalid_argument("inverted tetrahedron");
      s.Ke[t] = element_stiffness(s.shape[t], mat.youngs_modulus[t], mat.poisson_ratio[t]);
    } catch (const std::invalid_argument& e) {
      throw InputError("fem: tet " + std::to_string(t) + ": " + e.what());
    }
    if (!(mat.density[t] >= 0))
      throw InputError("fem: tet " + std::to_string(t) + ": negative density");
    Me[t] = element_mass_consistent(s.shape[t], mat.density[t]);
    const double ml = element_mass_lumped(s.shape[t], mat.density[t]);
    for (int k = 0; k < 4; ++k) s.m_lumped.segment<3>(3 * T(t, k)).array() += ml;
  }
  s.pattern = build_pattern(T, X0.rows());
  assemble(s.pattern, s.Ke, s.K);
  assemble(s.pattern, Me, s.M);
  return s;
}

SparseMatrixd rayleigh_damping(const SparseMatrixd& M, const SparseMatrixd& K, double alpha,
                               double beta) {
  SparseMatrixd C = alpha * M + beta * K;
  C.makeCompressed();
  return C;
}

SparseMatrixd diagonal_matrix(const Eigen::VectorXd& d) {
  SparseMatrixd D(d.size(), d.size());
  std::vector<Eigen::Triplet<double>> trip;
  for (long i = 0; i < d.size(); ++i) trip.emplace_back(i, i, d[i]);
  D.setFromTriplets(trip.begin(), trip.end());
  return D;
}

std::vector<std::uint8_t> node_to_dof_flags(const std::vector<std::uint8_t>& node_flags) {
  std::vector<std::uint8_t> d(3 * node_flags.size());
  for (size_t i = 0; i < node_flags.size(); ++i)
    d[3 * i] = d[3 * i + 1] = d[3 * i + 2] = node_flags[i];
  return d;
}

Eigen::VectorXd flatten(const mesh::Positions& X) {
  return Eigen::Map<const Eigen::VectorXd>(X.data(), X.size());  // row-major: node-major
}

mesh::Positions unflatten(const Eigen::VectorXd& x) {
  return Eigen::Map<const mesh::Positions>(x.data(), x.size() / 3, 3);
}

}  // namespace palplab::engine
