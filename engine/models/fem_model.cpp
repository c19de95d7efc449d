#include "engine/models/fem_model.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "common/input_error.hpp"
#include "engine/models/stored_factor.hpp"
#include "engine/solvers/fem_condensation.hpp"
#include "engine/solvers/fem_multirate.hpp"
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
  if (s == "corotational_multirate") return FemFormulation::corotational_multirate;
  throw InputError("unknown FEM formulation '" + s +
                   "' (expected linear, corotational, condensed or corotational_multirate)");
}

const char* to_string(FemFormulation f) {
  switch (f) {
    case FemFormulation::linear:
      return "linear";
    case FemFormulation::corotational:
      return "corotational";
    case FemFormulation::condensed:
      return "condensed";
    case FemFormulation::corotational_multirate:
      return "corotational_multirate";
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
  SparseLdlt ldlt;  // corotational: refactorised every step on a fixed pattern
  LdltFactor lin;   // linear / condensed: the factor of the step matrix (see factor())
  double h_factored = -1;
  int cached_node = -1;
  Eigen::Matrix<double, Eigen::Dynamic, 3> Z;  // A^-1 G of the cached patch
  std::vector<int> cached_nodes;
  std::vector<double> cached_weights;
  // The patch of this step: first dof (in the solve's numbering) and weight of every solved
  // patch node.
  struct Tap {
    int dof;
    double w;
  };
  std::vector<Tap> taps;
  CondensedFem cond;

  // corotational: full-size system with identity rows on fixed dofs.
  std::vector<Matrix12d> Ke_t;
  SparseMatrixd K_t, A;
  Eigen::VectorXd f_int;
  std::vector<int> diag_slot, zero_slot, fixed_diag_slot;
  bool analysed = false;

  // .psim (stored_factor.hpp): digest of the constructor's inputs; a stored factorisation used.
  FemInputsDigest inputs{};
  bool loaded = false;

  // corotational_multirate (declared after sys: it refers to it): the linearisations, the
  // force of the last step (N, along contact_normal), time since the last update (s).
  std::unique_ptr<CorotMultirate> mr;
  PatchPads mr_pads;                       // this step's pads (moving nodes)
  std::vector<double> mr_blend;            // their blend weights
  std::vector<const PadColumns*> mr_cols;  // their columns about the current linearisation
  double mr_force = 0, since_update = 0;

  // linear / condensed: factorises A = (1 + h alpha) M + (h beta + h^2) K_c for step size h.
  void factor(double h, double alpha, double beta, double& ms) {
    const auto t0 = Clock::now();
    SparseMatrixd A = (h * beta + h * h) * K_c;
    if (M_c.size())
      A += (1 + h * alpha) * M_c;
    else
      for (long i = 0; i < A.rows(); ++i) A.coeffRef(i, i) += (1 + h * alpha) * m_c[i];
    SparseLdlt f(A);
    if (f.info() != Eigen::Success)
      throw std::runtime_error("FemModel::step: factorisation failed");
    lin = LdltFactor::from(f);
    h_factored = h;
    cached_node = -1;
    ms = ms_since(t0);
  }
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
  m.inputs = fem_inputs_digest(mesh, materials, fixed_node_, opt_);
  // A .psim file's linear model made from these very inputs (stored_factor.hpp): its matrices,
  // lumped masses and factorisation are restored, the assembly and its checks (which the stored
  // model passed) are skipped; system() then holds X0, T, material and m_lumped only.
  StoredLinearFem stored;
  m.loaded = opt_.formulation == FemFormulation::linear && opt_.lumped_mass && opt_.precomputed &&
             !opt_.precomputed->empty() &&
             load_linear_fem(*opt_.precomputed, m.inputs, 3 * n, stored, m.lin);
  opt_.precomputed = nullptr;  // the caller's: not kept
  if (m.loaded) {
    m.sys.X0 = mesh.V;
    m.sys.T = mesh.T;
    m.sys.material = materials;
    m.sys.m_lumped = std::move(stored.m_lumped);
    m.h_factored = stored.h;
  } else {
    m.sys = fem_precompute(mesh.V, mesh.T, materials);
  }
  if (opt_.support_stiffness.size() && !m.loaded) {
    if (opt_.support_stiffness.size() != 3 * n || !(opt_.support_stiffness.minCoeff() >= 0))
      throw InputError("fem: support stiffness needs 3#V values >= 0");
    // The diagonal is in the pattern (each node's 3x3 block): no insertion.
    for (long i = 0; i < 3 * n; ++i) m.sys.K.coeffRef(i, i) += opt_.support_stiffness[i];
  }
  const auto rigid = rigid_nodes(mesh, materials);
  for (long i = 0; i < n; ++i) fixed_node_[i] = fixed_node_[i] || rigid[i];
  m.fixed_dof = node_to_dof_flags(fixed_node_);
  m.u.setZero(3 * n);
  m.v.setZero(3 * n);
  f_ext.setZero(3 * n);
  m.local.assign(3 * n, -1);

  const auto t0 = Clock::now();
  if (opt_.formulation == FemFormulation::linear && m.loaded) {
    m.act = std::move(stored.act);
    m.K_c.swap(stored.K_c);  // Eigen 3.4's sparse move-assignment copies
  } else if (opt_.formulation == FemFormulation::linear) {
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
  } else if (opt_.formulation == FemFormulation::corotational_multirate) {
    if (!(opt_.update_interval > 0))
      throw InputError("fem: the multi-rate update interval must be > 0 s");
    StaticSolver check;
    static_precompute(m.sys.K, m.fixed_dof, check);
    m.act = check.split.free;
    m.mr =
        std::make_unique<CorotMultirate>(m.sys, m.fixed_dof, opt_.support_stiffness, opt_.jacobian,
                                         opt_.multirate_background, opt_.multirate_deterministic);
    m.mr->relinearise_now(m.u, f_ext, {});
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
    case FemFormulation::corotational_multirate:
      return std::string(
                 "SimplicialLDLT (AMD) of the co-rotational tangent, refactorised at the "
                 "update rate") +
             (opt_.multirate_background ? " in a worker thread" : "") +
             "; haptic steps: patch compliance about the last linearisation (no sparse solve)";
  }
  return "";
}

long FemModel::relinearisations() const {
  return impl_->mr ? impl_->mr->relinearisations() : 0;
}

long FemModel::linearisation_max_lag() const {
  return impl_->mr ? impl_->mr->max_lag() : 0;
}

long FemModel::pad_solves() const {
  return impl_->mr ? impl_->mr->pad_solves() : 0;
}

bool FemModel::solves_node(int v) const {
  return v >= 0 && 3 * v < static_cast<long>(impl_->local.size()) && impl_->local[3 * v] >= 0;
}

void FemModel::reset() {
  impl_->Ku_age = -1;
  impl_->u.setZero();
  impl_->v.setZero();
  impl_->positions_valid = false;
  if (impl_->mr) {
    impl_->mr_cols.clear();  // pointers into the linearisation replaced below
    impl_->mr->relinearise_now(impl_->u, f_ext, {});
    impl_->mr_force = 0;
    impl_->since_update = 0;
  }
  time_ = 0;
}

Eigen::Vector3d FemModel::node_position(int v) const {
  const Impl& m = *impl_;
  if (m.mr) {
    // Multi-rate: the haptic-rate prediction u_L + delta0 - f Y n at this node.
    const CorotLinearisation& L = m.mr->current();
    Eigen::Vector3d p =
        m.sys.X0.row(v).transpose() + L.u.segment<3>(3 * v) + L.delta0.segment<3>(3 * v);
    if (m.mr_force > 0)
      for (size_t b = 0; b < m.mr_cols.size(); ++b)
        if (m.mr_cols[b])
          p -= (m.mr_force * m.mr_blend[b]) *
               (m.mr_cols[b]->Y.middleRows<3>(3 * v) * contact_normal);
    return p;
  }
  return m.sys.X0.row(v).transpose() + m.u.segment<3>(3 * v);
}

double FemModel::patch_gap(const Eigen::VectorXd& a, const Eigen::VectorXd* b) const {
  const Impl& m = *impl_;
  const auto disp = [&](int i) {
    Eigen::Vector3d d = a.segment<3>(3 * i);
    if (b) d += b->segment<3>(3 * i);
    return d;
  };
  if (contact_nodes.empty()) {
    const Eigen::Vector3d x = m.sys.X0.row(contact_node).transpose() + disp(contact_node);
    return (x - contact_point).dot(contact_normal);
  }
  if (contact_weights.size() != contact_nodes.size())
    throw std::logic_error("FemModel: one contact weight per patch node");
  const Eigen::Vector3d xp = m.sys.X0.row(contact_node).transpose();
  double d = 0.0;
  for (size_t k = 0; k < contact_nodes.size(); ++k) {
    const int i = contact_nodes[k];
    const Eigen::Vector3d x0 = m.sys.X0.row(i).transpose();
    const double above = std::max(0.0, (x0 - xp).dot(contact_normal));
    d += contact_weights[k] * ((x0 + disp(i) - contact_point).dot(contact_normal) - above);
  }
  return d;
}

double FemModel::penetration() const {
  if (contact_node < 0) return 0.0;
  if (impl_->mr) return contact_k > 0 ? impl_->mr_force / contact_k : 0.0;
  return std::max(0.0, patch_gap(impl_->u, nullptr));
}

Eigen::Vector3d FemModel::device_force() const {
  if (impl_->mr)
    return contact_node < 0 ? Eigen::Vector3d::Zero()
                            : Eigen::Vector3d(impl_->mr_force * contact_normal);
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

void FemModel::step_multirate(double h) {
  Impl& m = *impl_;
  CorotMultirate& mr = *m.mr;
  m.mr_cols.clear();
  size_t np = 0;  // pads of this step
  const auto add_pad = [&](double blend) -> std::vector<PatchTap>& {
    if (m.mr_pads.size() <= np) m.mr_pads.emplace_back();
    m.mr_blend.resize(np + 1);
    m.mr_blend[np] = blend;
    m.mr_pads[np].clear();
    return m.mr_pads[np++];
  };
  double f = 0;
  if (contact_node >= 0 && contact_k > 0) {
    // The pads' moving nodes (a pinned node takes its share into the support).
    if (!contact_pads.empty()) {
      for (const ContactPad& P : contact_pads) {
        if (!(P.blend > 0)) continue;
        if (P.weights.size() != P.nodes.size())
          throw std::logic_error("FemModel: one weight per contact pad node");
        std::vector<PatchTap>& taps = add_pad(P.blend);
        for (size_t k = 0; k < P.nodes.size(); ++k)
          if (!fixed_node_[P.nodes[k]]) taps.push_back({3 * P.nodes[k], P.weights[k]});
      }
    } else {
      std::vector<PatchTap>& taps = add_pad(1.0);
      const bool single = contact_nodes.empty();
      for (size_t k = 0; k < (single ? 1 : contact_nodes.size()); ++k) {
        const int i = single ? contact_node : contact_nodes[k];
        if (!fixed_node_[i]) taps.push_back({3 * i, single ? 1.0 : contact_weights[k]});
      }
    }
  }
  m.mr_pads.resize(np);
  m.mr_blend.resize(np);
  if (np) {
    const CorotLinearisation& L = mr.current();
    // The penetration of the unloaded Newton prediction, then the spring in series with the
    // patch's compliance about the linearisation (fem_multirate.hpp), blended from its pads':
    // c = n^T (sum_ab b_a b_b G_a^T Y_b) n.
    const double d0 = patch_gap(L.u, &L.delta0);
    if (d0 > 0) {
      mr.pad_columns(m.mr_pads, m.mr_cols);
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
      for (size_t a = 0; a < np; ++a)
        for (size_t b = 0; b < np; ++b) {
          if (!m.mr_cols[b]) continue;
          const auto& Y = m.mr_cols[b]->Y;
          const double ab = m.mr_blend[a] * m.mr_blend[b];
          for (const PatchTap& t : m.mr_pads[a]) C += (ab * t.w) * Y.middleRows<3>(t.dof);
        }
      f = contact_k * d0 / (1 + contact_k * contact_normal.dot(C * contact_normal));
    }
  }
  m.mr_force = f;
  time_ += h;
  m.since_update += h;
  if (m.since_update >= opt_.update_interval * (1 - 1e-9)) {
    // Graphics rate: the deformation moves to the predicted equilibrium under f, and the model
    // re-linearises about it (solving the columns of this step's pads).
    m.since_update = 0;
    const CorotLinearisation& L = mr.current();
    m.u = L.u + L.delta0;
    if (f > 0)
      for (size_t b = 0; b < np; ++b)
        if (m.mr_cols[b]) m.u -= (f * m.mr_blend[b]) * (m.mr_cols[b]->Y * contact_normal);
    mr.update(m.u, f_ext, m.mr_pads);
    factor_ms_ = mr.current().factor_ms;
    m.positions_valid = false;
    // The columns of the (possibly new) current linearisation, where it has them, for
    // node_position() until the next step; none if any pad is missing.
    const CorotLinearisation& N = mr.current();
    m.mr_cols.clear();
    if (f > 0) {
      bool all = true;
      for (size_t q = 0; q < np; ++q) {
        m.mr_cols.push_back(m.mr_pads[q].empty() ? nullptr : N.find(m.mr_pads[q]));
        all = all && (m.mr_pads[q].empty() || m.mr_cols.back());
      }
      if (!all) m.mr_cols.clear();
    }
  }
}

void FemModel::step(double h) {
  if (!(h > 0)) throw std::invalid_argument("FemModel::step: h must be > 0");
  if (impl_->mr) return step_multirate(h);
  Impl& m = *impl_;
  const double alpha = opt_.rayleigh_alpha, beta = opt_.rayleigh_beta;
  // The contact is a one-sided penalty on the patch's gap at the END of the step: the step is
  // solved without it, and the patch is pushed only when that free motion ends inside the probe
  // (g_free > 0); then the implicit penalty (A + s e e^T) y = b - h k d e gives the gap
  // g = g_free / (1 + s e^T A^-1 e) > 0 exactly, so the force is never adhesive. Deciding from
  // the gap at the step's START (d > 0), as before 2026-12-07, let a tissue released by a stiff
  // probe rebound into it for a whole step unopposed: a probe withdrawing from D at 5 cm/s with
  // a 2e4 N/m pad felt 2.05 N for a 1 N hold (a period-3 cycle of 2.0, 1.2, 0.8 N).
  const double d = contact_node >= 0 ? patch_gap(m.u, nullptr) : 0.0;  // signed, at the start
  const bool touching = contact_node >= 0 && contact_k > 0;
  const bool corot = opt_.formulation == FemFormulation::corotational;
  m.taps.clear();
  if (touching) {
    const bool single = contact_nodes.empty();
    const size_t np = single ? 1 : contact_nodes.size();
    for (size_t k = 0; k < np; ++k) {
      const int i = single ? contact_node : contact_nodes[k];
      const double w = single ? 1.0 : contact_weights[k];
      if (fixed_node_[i]) continue;  // a pinned node takes its share into the support
      const int dof = corot ? 3 * i : m.local[3 * i];
      if (dof < 0)
        throw std::logic_error("FemModel::step: contact node " + std::to_string(i) +
                               " is outside the operational region of the condensed model");
      m.taps.push_back({dof, w});
    }
  }
  const bool implicit_contact = !m.taps.empty();
  const Eigen::Vector3d nrm = contact_normal;
  // e^T y for e = sum_i w_i e_i n.
  auto e_dot = [&](const Eigen::VectorXd& y) {
    double r = 0;
    for (const auto& t : m.taps) r += t.w * nrm.dot(y.segment<3>(t.dof));
    return r;
  };

  if (opt_.formulation == FemFormulation::corotational) {
    const Eigen::VectorXd x = flatten(m.sys.X0) + m.u;
    corotational_stiffness(m.sys, x, opt_.jacobian, m.Ke_t, m.K_t, &m.f_int);
    if (opt_.support_stiffness.size()) {  // the foundation is linear: not rotated
      double* kt = m.K_t.valuePtr();
      for (long i = 0; i < m.K_t.rows(); ++i) kt[m.diag_slot[i]] += opt_.support_stiffness[i];
      m.f_int -= opt_.support_stiffness.cwiseProduct(m.u);
    }
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
    for (int s : m.zero_slot) a[s] = 0.0;
    for (int s : m.fixed_diag_slot) a[s] = 1.0;
    Eigen::VectorXd b = (opt_.lumped_mass ? Eigen::VectorXd(m.sys.m_lumped.cwiseProduct(m.v))
                                          : Eigen::VectorXd(m.sys.M * m.v)) +
                        h * (m.f_int + f_ext);
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
    m.v = m.ldlt.solve(b);  // the free step
    if (const double g_free = d + h * e_dot(m.v); implicit_contact && g_free > 0) {
      // The penalty by Sherman–Morrison: A changes every step, so z = A^-1 e is one more
      // back-substitution; y = y_free - z h k g (above).
      Eigen::VectorXd e = Eigen::VectorXd::Zero(b.size());
      for (const auto& t : m.taps) e.segment<3>(t.dof) += t.w * nrm;
      const Eigen::VectorXd z = m.ldlt.solve(e);
      const double s = h * h * contact_k;
      m.v -= z * (h * contact_k * g_free / (1 + s * e_dot(z)));
    }
    m.u += h * m.v;
  } else {
    if (h != m.h_factored) m.factor(h, alpha, beta, factor_ms_);
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
    const Eigen::VectorXd Mv =
        m.M_c.size() ? Eigen::VectorXd(m.M_c * va) : Eigen::VectorXd(m.m_c.cwiseProduct(va));
    const Eigen::VectorXd b = Mv + h * fa;
    Eigen::VectorXd y = m.lin.solve(b);  // the free step
    double hkg = 0;  // h k g of the contact term (g: the gap at the step's end), for K y below
    if (const double g_free = d + h * e_dot(y); implicit_contact && g_free > 0) {
      // (A + h^2 k e e^T)^-1 b by Sherman–Morrison, e = G n with G = sum_i w_i E_i (E_i: the
      // three dofs of patch node i); A^-1 G is cached per patch.
      if (m.cached_node != contact_node || m.cached_nodes != contact_nodes ||
          m.cached_weights != contact_weights) {
        Eigen::MatrixXd G = Eigen::MatrixXd::Zero(m.act.size(), 3);
        for (const auto& t : m.taps)
          for (int c = 0; c < 3; ++c) G(t.dof + c, c) += t.w;
        m.Z = m.lin.solve(G);
        m.cached_node = contact_node;
        m.cached_nodes = contact_nodes;
        m.cached_weights = contact_weights;
      }
      const Eigen::VectorXd z = m.Z * nrm;
      const double s = h * h * contact_k;
      hkg = h * contact_k * g_free / (1 + s * e_dot(z));
      y -= hkg * z;
    }
    if (lumped) {
      // K y without a sparse product: A y = b - h k g e and A = (1 + h alpha) M +
      // (h beta + h^2) K with M diagonal, so K y = (A y - (1 + h alpha) M y) / (h beta + h^2).
      Eigen::VectorXd Ay = b;
      for (const auto& t : m.taps) Ay.segment<3>(t.dof) -= (hkg * t.w) * nrm;
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

// ---- .psim precomputation (issue 16; the format in stored_factor.cpp) -------------------

std::string FemModel::save_precomputation(double h) {
  Impl& m = *impl_;
  if (opt_.formulation != FemFormulation::linear || !opt_.lumped_mass || !(h > 0)) return {};
  if (h != m.h_factored) m.factor(h, opt_.rayleigh_alpha, opt_.rayleigh_beta, factor_ms_);
  return save_linear_fem(m.inputs, m.act, m.K_c, m.sys.m_lumped, m.lin, h);
}

bool FemModel::precomputation_loaded() const {
  return impl_->loaded;
}

}  // namespace palplab::engine
