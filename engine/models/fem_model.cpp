#include "engine/models/fem_model.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "common/input_error.hpp"
#include "engine/solvers/fem_condensation.hpp"
#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

FemFormulation fem_formulation_from_string(const std::string& s) {
  if (s == "linear") return FemFormulation::linear;
  if (s == "corotational") return FemFormulation::corotational;
  if (s == "condensed") return FemFormulation::condensed;
  throw InputError("unknown FEM formulation '" + s +
                   "' (expected linear, corotational or condensed)");
}

const char* to_string(FemFormulation f) {
  switch (f) {
    case FemFormulation::linear:
      return "linear";
    case FemFormulation::corotational:
      return "corotational";
    case FemFormulation::condensed:
      return "condensed";
  }
  return "?";
}

struct FemModel::Impl {
  FemSystem sys;
  std::vector<std::uint8_t> fixed_dof;
  Eigen::VectorXd u, v;  // 3#V displacement (m), velocity (m/s)
  mesh::Positions X;
  bool positions_valid = false;

  // linear / condensed: constant matrices on the solved dofs `act`.
  std::vector<int> act;
  std::vector<int> local;  // 3#V -> index in act or -1
  SparseMatrixd K_c;
  Eigen::VectorXd m_c;
  SparseMatrixd M_c;  // consistent mass on act (empty when lumped)
  // K_c u kept up to date without a product per step (see step()); re-synchronised with an
  // exact product every kResync steps; age -1 = stale.
  Eigen::VectorXd Ku;
  int Ku_age = -1;
  static constexpr int kResync = 256;
  SparseLdlt ldlt;
  double h_factored = -1;
  int cached_node = -1;
  Eigen::Matrix<double, Eigen::Dynamic, 3> Z;  // A^-1 E_p
  CondensedFem cond;

  // corotational: full-size system with identity rows on fixed dofs.
  std::vector<Matrix12d> Ke_t;
  SparseMatrixd K_t, A;
  Eigen::VectorXd f_int;
  std::vector<int> diag_slot, zero_slot, fixed_diag_slot;
  bool analysed = false;
};

FemModel::FemModel(const mesh::TetMesh& mesh, const TetMaterials& materials,
                   std::vector<std::uint8_t> fixed_node, FemModelOptions options)
    : impl_(std::make_unique<Impl>()),
      opt_(std::move(options)),
      fixed_node_(std::move(fixed_node)) {
  const long n = mesh.V.rows();
  if (fixed_node_.empty()) fixed_node_.assign(n, 0);
  if (static_cast<long>(fixed_node_.size()) != n)
    throw InputError("fem: " + std::to_string(fixed_node_.size()) + " fixed-node flags for " +
                     std::to_string(n) + " nodes");
  if (!(opt_.rayleigh_alpha >= 0) || !(opt_.rayleigh_beta >= 0))
    throw InputError("fem: Rayleigh damping coefficients must be >= 0");
  Impl& m = *impl_;
  m.sys = fem_precompute(mesh.V, mesh.T, materials);
  const auto rigid = rigid_nodes(mesh, materials);
  for (long i = 0; i < n; ++i) fixed_node_[i] = fixed_node_[i] || rigid[i];
  m.fixed_dof = node_to_dof_flags(fixed_node_);
  m.u.setZero(3 * n);
  m.v.setZero(3 * n);
  f_ext.setZero(3 * n);
  m.local.assign(3 * n, -1);

  const auto t0 = Clock::now();
  if (opt_.formulation == FemFormulation::linear) {
    StaticSolver check;  // fails early (with a clear message) on a free-floating body
    static_precompute(m.sys.K, m.fixed_dof, check);
    m.act = check.split.free;
    m.K_c = check.K_ff;
    if (!opt_.lumped_mass) m.M_c = submatrix(m.sys.M, m.act, m.act);
  } else if (opt_.formulation == FemFormulation::condensed) {
    if (!opt_.lumped_mass)
      throw InputError("fem: the condensed formulation uses lumped mass (lumped_mass = true)");
    if (static_cast<long>(opt_.operational_tet.size()) != mesh.T.rows())
      throw InputError("fem: condensed formulation needs one operational flag per tet (" +
                       std::to_string(mesh.T.rows()) + ")");
    condense_precompute(m.sys.K, m.sys.T, m.fixed_dof, opt_.operational_tet, m.cond);
    m.act = m.cond.reduced;
    m.K_c = m.cond.K_r;
  } else {
    // Slots of the diagonal, of entries coupling a fixed dof, of the fixed diagonal.
    const SparseMatrixd& P = m.sys.pattern.matrix;
    m.diag_slot.assign(3 * n, -1);
    for (long j = 0; j < P.outerSize(); ++j)
      for (long q = P.outerIndexPtr()[j]; q < P.outerIndexPtr()[j + 1]; ++q) {
        const long i = P.innerIndexPtr()[q];
        if (i == j) {
          m.diag_slot[j] = static_cast<int>(q);
          if (m.fixed_dof[j]) m.fixed_diag_slot.push_back(static_cast<int>(q));
        } else if (m.fixed_dof[i] || m.fixed_dof[j]) {
          m.zero_slot.push_back(static_cast<int>(q));
        }
      }
    StaticSolver check;
    static_precompute(m.sys.K, m.fixed_dof, check);
    m.act = check.split.free;
  }
  for (size_t k = 0; k < m.act.size(); ++k) m.local[m.act[k]] = static_cast<int>(k);
  m.m_c = gather(m.sys.m_lumped, m.act);
  if (m.m_c.size() && !(m.m_c.minCoeff() > 0))
    throw InputError("fem: a moving node has zero mass (density 0)");
  factor_ms_ = ms_since(t0);
}

FemModel::~FemModel() = default;

const FemSystem& FemModel::system() const {
  return impl_->sys;
}
long FemModel::dofs() const {
  return static_cast<long>(impl_->act.size());
}
long FemModel::total_dofs() const {
  return impl_->sys.dofs();
}

std::string FemModel::solver() const {
  switch (opt_.formulation) {
    case FemFormulation::linear:
      return "SimplicialLDLT (AMD), factorised once per h; contact by Sherman-Morrison";
    case FemFormulation::condensed:
      return "SimplicialLDLT (AMD) on operational+interface dofs with dense Schur complement; "
             "contact by Sherman-Morrison";
    case FemFormulation::corotational:
      return "SimplicialLDLT (AMD), pattern analysed once, refactorised every step";
  }
  return "";
}

bool FemModel::solves_node(int v) const {
  return v >= 0 && 3 * v < static_cast<long>(impl_->local.size()) && impl_->local[3 * v] >= 0;
}

void FemModel::reset() {
  impl_->Ku_age = -1;
  impl_->u.setZero();
  impl_->v.setZero();
  impl_->positions_valid = false;
  time_ = 0;
}

Eigen::Vector3d FemModel::node_position(int v) const {
  return impl_->sys.X0.row(v).transpose() + impl_->u.segment<3>(3 * v);
}

double FemModel::penetration() const {
  if (contact_node < 0) return 0.0;
  const Eigen::Vector3d x =
      impl_->sys.X0.row(contact_node).transpose() + impl_->u.segment<3>(3 * contact_node);
  return std::max(0.0, (x - contact_point).dot(contact_normal));
}

Eigen::Vector3d FemModel::device_force() const {
  return contact_k * penetration() * contact_normal;
}

const Eigen::VectorXd& FemModel::displacement() {
  Impl& m = *impl_;
  if (opt_.formulation == FemFormulation::condensed && !m.positions_valid &&
      !m.cond.dofs_i.empty()) {
    // Interior recovery u_i = K_ii^-1 (f_i - K_is u_s): the graphics-rate part.
    const Eigen::VectorXd us = gather(m.u, m.cond.dofs_s);
    scatter(m.cond.ldlt_ii.solve(gather(f_ext, m.cond.dofs_i) - m.cond.K_is * us), m.cond.dofs_i,
            m.u);
  }
  return m.u;
}

const mesh::Positions& FemModel::positions() {
  Impl& m = *impl_;
  if (!m.positions_valid) {
    displacement();
    m.X = m.sys.X0 + unflatten(m.u);
    m.positions_valid = true;
  }
  return m.X;
}

void FemModel::step(double h) {
  if (!(h > 0)) throw std::invalid_argument("FemModel::step: h must be > 0");
  Impl& m = *impl_;
  const double alpha = opt_.rayleigh_alpha, beta = opt_.rayleigh_beta;
  const double d = penetration();
  const bool touching = d > 0 && contact_k > 0;
  if (touching && !solves_node(contact_node)) {
    if (!fixed_node_[contact_node])
      throw std::logic_error("FemModel::step: contact node " + std::to_string(contact_node) +
                             " is outside the operational region of the condensed model");
  }
  const bool implicit_contact = touching && solves_node(contact_node);
  const Eigen::Vector3d fc = -contact_k * d * contact_normal;  // on the node

  if (opt_.formulation == FemFormulation::corotational) {
    const Eigen::VectorXd x = flatten(m.sys.X0) + m.u;
    corotational_stiffness(m.sys, x, opt_.jacobian, m.Ke_t, m.K_t, &m.f_int);
    const auto t0 = Clock::now();
    m.A = m.K_t * (h * beta + h * h);
    double* a = m.A.valuePtr();
    if (opt_.lumped_mass) {
      for (long i = 0; i < m.A.rows(); ++i)
        a[m.diag_slot[i]] += (1 + h * alpha) * m.sys.m_lumped[i];
    } else {  // M has the pattern of K: add value by value
      const double* mv = m.sys.M.valuePtr();
      for (long q = 0; q < m.A.nonZeros(); ++q) a[q] += (1 + h * alpha) * mv[q];
    }
    if (implicit_contact) {
      const Eigen::Matrix3d J = h * h * contact_k * contact_normal * contact_normal.transpose();
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r)
          m.A.coeffRef(3 * contact_node + r, 3 * contact_node + c) += J(r, c);
    }
    for (int s : m.zero_slot) a[s] = 0.0;
    for (int s : m.fixed_diag_slot) a[s] = 1.0;
    Eigen::VectorXd b = (opt_.lumped_mass ? Eigen::VectorXd(m.sys.m_lumped.cwiseProduct(m.v))
                                          : Eigen::VectorXd(m.sys.M * m.v)) +
                        h * (m.f_int + f_ext);
    if (touching) b.segment<3>(3 * contact_node) += h * fc;
    for (long i = 0; i < b.size(); ++i)
      if (m.fixed_dof[i]) b[i] = 0.0;
    if (!m.analysed) {
      m.ldlt.analyzePattern(m.A);
      m.analysed = true;
    }
    m.ldlt.factorize(m.A);
    if (m.ldlt.info() != Eigen::Success)
      throw std::runtime_error("FemModel::step: factorisation failed");
    factor_ms_ = ms_since(t0);
    m.v = m.ldlt.solve(b);
    m.u += h * m.v;
  } else {
    if (h != m.h_factored) {
      const auto t0 = Clock::now();
      SparseMatrixd A = (h * beta + h * h) * m.K_c;
      if (m.M_c.size())
        A += (1 + h * alpha) * m.M_c;
      else
        for (long i = 0; i < A.rows(); ++i) A.coeffRef(i, i) += (1 + h * alpha) * m.m_c[i];
      m.ldlt.compute(A);
      if (m.ldlt.info() != Eigen::Success)
        throw std::runtime_error("FemModel::step: factorisation failed");
      m.h_factored = h;
      m.cached_node = -1;
      factor_ms_ = ms_since(t0);
    }
    const Eigen::VectorXd ua = gather(m.u, m.act), va = gather(m.v, m.act);
    const bool lumped = m.M_c.size() == 0;
    if (!lumped || m.Ku_age < 0 || m.Ku_age >= Impl::kResync) {
      m.Ku = m.K_c * ua;
      m.Ku_age = 0;
    }
    Eigen::VectorXd fa = gather(f_ext, m.act) - m.Ku;
    if (opt_.formulation == FemFormulation::condensed && !m.cond.dofs_i.empty()) {
      const Eigen::VectorXd fi = gather(f_ext, m.cond.dofs_i);
      if (fi.cwiseAbs().maxCoeff() > 0)  // interior loads reach the interface through P*
        fa.tail(m.cond.dofs_s.size()) -= m.cond.K_si * m.cond.ldlt_ii.solve(fi);
    }
    int lp = -1;
    if (implicit_contact) {
      lp = m.local[3 * contact_node];
      fa.segment<3>(lp) += fc;  // the three dofs of a node are consecutive in act
    }
    const Eigen::VectorXd Mv =
        m.M_c.size() ? Eigen::VectorXd(m.M_c * va) : Eigen::VectorXd(m.m_c.cwiseProduct(va));
    const Eigen::VectorXd b = Mv + h * fa;
    Eigen::VectorXd y = m.ldlt.solve(b);
    double s_ey = 0;  // s e^T y of the contact term, for the K y update below
    if (implicit_contact) {
      // (A + h^2 k e e^T)^-1 b by Sherman–Morrison, e = n on the node's dofs.
      if (m.cached_node != contact_node) {
        Eigen::MatrixXd E = Eigen::MatrixXd::Zero(m.act.size(), 3);
        for (int c = 0; c < 3; ++c) E(lp + c, c) = 1.0;
        m.Z = m.ldlt.solve(E);
        m.cached_node = contact_node;
      }
      const Eigen::VectorXd z = m.Z * contact_normal;
      const double s = h * h * contact_k;
      const double ey = contact_normal.dot(y.segment<3>(lp));
      const double ez = contact_normal.dot(z.segment<3>(lp));
      y -= z * (s * ey / (1 + s * ez));
      s_ey = s * contact_normal.dot(y.segment<3>(lp));
    }
    if (lumped) {
      // K y without a sparse product: A y = b - s e (e^T y) and A = (1 + h alpha) M +
      // (h beta + h^2) K with M diagonal, so K y = (A y - (1 + h alpha) M y) / (h beta + h^2).
      Eigen::VectorXd Ay = b;
      if (implicit_contact) Ay.segment<3>(lp) -= s_ey * contact_normal;
      m.Ku += h * (Ay - (1 + h * alpha) * m.m_c.cwiseProduct(y)) / (h * beta + h * h);
      ++m.Ku_age;
    }
    Eigen::VectorXd u_new = ua + h * y;
    scatter(y, m.act, m.v);
    scatter(u_new, m.act, m.u);
  }
  m.positions_valid = false;
  time_ += h;
}

}  // namespace palplab::engine
