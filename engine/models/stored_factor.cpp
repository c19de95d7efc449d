#include "engine/models/stored_factor.hpp"

#include <cstring>

#include "engine/models/fem_model.hpp"
#include "results/sha256.hpp"

namespace palplab::engine {

namespace {

constexpr char kFactorTag[8] = {'F', 'E', 'M', 'L', 'D', 'L', 'T', '2'};

void put(std::string& s, const void* p, std::size_t n) {
  s.append(static_cast<const char*>(p), n);
}
template <class T>
void put_vec(std::string& s, const T* p, std::int64_t n) {
  put(s, &n, sizeof n);
  put(s, p, static_cast<std::size_t>(n) * sizeof(T));
}

struct In {
  const std::string& b;
  std::size_t at = 0;
  bool ok = true;
  template <class T>
  T get() {
    T v{};
    if (b.size() - at < sizeof v) {
      ok = false;
      return v;
    }
    std::memcpy(&v, b.data() + at, sizeof v);
    at += sizeof v;
    return v;
  }
  template <class T>
  std::int64_t vec(T* out, std::int64_t expect) {  // out == nullptr: only the count
    const auto n = get<std::int64_t>();
    if (!ok || n < 0 || (expect >= 0 && n != expect) ||
        static_cast<std::uint64_t>(n) > (b.size() - at) / sizeof(T)) {
      ok = false;
      return 0;
    }
    if (out) std::memcpy(out, b.data() + at, static_cast<std::size_t>(n) * sizeof(T));
    at += static_cast<std::size_t>(n) * sizeof(T);
    return n;
  }
};

}  // namespace

FemInputsDigest fem_inputs_digest(const mesh::TetMesh& mesh, const TetMaterials& mat,
                                  const std::vector<std::uint8_t>& fixed,
                                  const FemModelOptions& o) {
  results::Sha256 h;
  auto add = [&](const void* p, std::size_t n) {
    const std::uint64_t len = n;
    h.update(&len, sizeof len);  // lengths keep the fields apart
    h.update(p, n);
  };
  add(mesh.V.data(), sizeof(double) * mesh.V.size());
  add(mesh.T.data(), sizeof(int) * mesh.T.size());
  add(mat.youngs_modulus.data(), sizeof(double) * mat.youngs_modulus.size());
  add(mat.poisson_ratio.data(), sizeof(double) * mat.poisson_ratio.size());
  add(mat.density.data(), sizeof(double) * mat.density.size());
  add(mat.rigid.data(), mat.rigid.size());
  add(fixed.data(), fixed.size());
  const int f = static_cast<int>(o.formulation), j = static_cast<int>(o.jacobian);
  const std::uint8_t lumped = o.lumped_mass;
  add(&f, sizeof f);
  add(&j, sizeof j);
  add(&lumped, 1);
  add(&o.rayleigh_alpha, sizeof(double));
  add(&o.rayleigh_beta, sizeof(double));
  add(o.operational_tet.data(), o.operational_tet.size());
  add(o.support_stiffness.data(), sizeof(double) * o.support_stiffness.size());
  return h.digest();
}

namespace {

void put_sparse(std::string& s, const SparseMatrixd& M) {
  const std::int64_t r = M.rows(), c = M.cols();
  put(s, &r, sizeof r);
  put(s, &c, sizeof c);
  put_vec(s, M.outerIndexPtr(), c + 1);
  put_vec(s, M.innerIndexPtr(), static_cast<std::int64_t>(M.nonZeros()));
  put_vec(s, M.valuePtr(), static_cast<std::int64_t>(M.nonZeros()));
}

// A compressed column matrix with valid, ascending-per-column row indices, or false.
bool get_sparse(In& in, std::int64_t rows, SparseMatrixd& M) {
  const auto r = in.get<std::int64_t>(), c = in.get<std::int64_t>();
  if (!in.ok || r != rows || c < 0 || c > (1 << 30)) return false;
  std::vector<int> outer(c + 1);
  in.vec(outer.data(), c + 1);
  if (!in.ok || outer[0] != 0) return false;
  for (std::int64_t j = 0; j < c; ++j)
    if (outer[j + 1] < outer[j]) return false;
  const std::int64_t nnz = outer[c];
  if (static_cast<std::uint64_t>(nnz) > in.b.size()) return false;
  SparseMatrixd A(r, c);
  A.resizeNonZeros(nnz);
  std::memcpy(A.outerIndexPtr(), outer.data(), sizeof(int) * (c + 1));
  in.vec(A.innerIndexPtr(), nnz);
  in.vec(A.valuePtr(), nnz);
  if (!in.ok) return false;
  for (std::int64_t j = 0; j < c; ++j)
    for (int q = outer[j]; q < outer[j + 1]; ++q) {
      const int i = A.innerIndexPtr()[q];
      if (i < 0 || i >= r || (q > outer[j] && i <= A.innerIndexPtr()[q - 1])) return false;
    }
  M.swap(A);  // Eigen 3.4's SparseMatrix has no move assignment: = std::move(A) copies
  return true;
}

}  // namespace

std::string save_linear_fem(const FemInputsDigest& d, const std::vector<int>& act,
                            const SparseMatrixd& K_c, const Eigen::VectorXd& m_lumped,
                            const LdltFactor& factor, double h) {
  if (!factor.L.isCompressed() || factor.size() != static_cast<long>(act.size())) return {};
  SparseMatrixd K = K_c;
  K.makeCompressed();  // the same entries in the same order
  std::string s;
  put(s, kFactorTag, 8);
  put(s, d.data(), d.size());
  put(s, &h, sizeof h);
  put_vec(s, act.data(), static_cast<std::int64_t>(act.size()));
  put_sparse(s, K);
  put_vec(s, m_lumped.data(), m_lumped.size());
  put_ldlt_factor(s, factor);
  return s;
}

bool load_linear_fem(const std::string& blob, const FemInputsDigest& d, long total_dofs,
                     StoredLinearFem& out, LdltFactor& factor) {
  if (blob.size() < 8 + 32 + 8 || std::memcmp(blob.data(), kFactorTag, 8) != 0 ||
      std::memcmp(blob.data() + 8, d.data(), 32) != 0)
    return false;
  In in{blob, 40};
  StoredLinearFem st;
  st.h = in.get<double>();
  const auto n = in.get<std::int64_t>();  // the count of act, read again below
  if (!in.ok || !(st.h > 0) || n < 0 || n > total_dofs) return false;
  in.at -= sizeof n;
  st.act.resize(n);
  in.vec(st.act.data(), n);
  for (std::int64_t k = 0; k < n; ++k)
    if (st.act[k] < 0 || st.act[k] >= total_dofs || (k && st.act[k] <= st.act[k - 1])) return false;
  if (!get_sparse(in, n, st.K_c) || st.K_c.cols() != n) return false;
  st.m_lumped.resize(total_dofs);
  in.vec(st.m_lumped.data(), total_dofs);
  if (!in.ok) return false;
  std::size_t at = in.at;
  LdltFactor f;
  if (!get_ldlt_factor(blob, at, n, f) || at != blob.size()) return false;
  // Member by member: the implicit moves would copy the sparse matrices (no Eigen move).
  factor.L.swap(f.L);
  factor.D = std::move(f.D);
  factor.P.indices().swap(f.P.indices());
  factor.Pinv.indices().swap(f.Pinv.indices());
  out.act = std::move(st.act);
  out.K_c.swap(st.K_c);
  out.m_lumped = std::move(st.m_lumped);
  out.h = st.h;
  return true;
}

void put_ldlt_factor(std::string& s, const LdltFactor& f) {
  put_sparse(s, f.L);
  put_vec(s, f.D.data(), f.D.size());
  put_vec(s, f.P.indices().data(), f.P.indices().size());
  put_vec(s, f.Pinv.indices().data(), f.Pinv.indices().size());
}

bool get_ldlt_factor(const std::string& blob, std::size_t& at, long n, LdltFactor& factor) {
  if (at > blob.size() || n < 0) return false;
  In in{blob, at};
  SparseMatrixd L;
  if (!get_sparse(in, n, L) || L.cols() != n) return false;
  Eigen::VectorXd D(n);
  in.vec(D.data(), n);
  Eigen::VectorXi P(n), Pinv(n);
  in.vec(P.data(), n);
  in.vec(Pinv.data(), n);
  if (!in.ok) return false;
  for (std::int64_t i = 0; i < n; ++i)
    if (P[i] < 0 || P[i] >= n || Pinv[i] < 0 || Pinv[i] >= n || Pinv[P[i]] != i) return false;
  for (std::int64_t j = 0; j < n; ++j)  // L: strictly lower entries only, D nonzero
    if (!(D[j] != 0) || (L.outerIndexPtr()[j] < L.outerIndexPtr()[j + 1] &&
                         L.innerIndexPtr()[L.outerIndexPtr()[j]] <= j))
      return false;
  factor.L.swap(L);
  factor.D = std::move(D);
  factor.P.indices() = std::move(P);
  factor.Pinv.indices() = std::move(Pinv);
  at = in.at;
  return true;
}

}  // namespace palplab::engine
