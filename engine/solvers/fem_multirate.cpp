#include "engine/solvers/fem_multirate.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace palplab::engine {

CorotMultirate::CorotMultirate(const FemSystem& sys, std::vector<std::uint8_t> fixed_dof,
                               Eigen::VectorXd support, CorotJacobian jac, bool background,
                               bool deterministic)
    : sys_(sys),
      fixed_dof_(std::move(fixed_dof)),
      support_(std::move(support)),
      jac_(jac),
      background_(background),
      deterministic_(deterministic),
      cur_(std::make_unique<CorotLinearisation>()),
      next_(std::make_unique<CorotLinearisation>()) {
  // Slots of the diagonal, of entries coupling a fixed dof and of the fixed diagonal on the
  // pattern (the tangent gets identity rows and columns on fixed dofs).
  const SparseMatrixd& P = sys_.pattern.matrix;
  diag_slot_.assign(P.rows(), -1);
  for (long j = 0; j < P.outerSize(); ++j)
    for (long q = P.outerIndexPtr()[j]; q < P.outerIndexPtr()[j + 1]; ++q) {
      const long i = P.innerIndexPtr()[q];
      if (i == j) {
        diag_slot_[j] = static_cast<int>(q);
        if (fixed_dof_[j]) fixed_diag_slot_.push_back(static_cast<int>(q));
      } else if (fixed_dof_[i] || fixed_dof_[j]) {
        zero_slot_.push_back(static_cast<int>(q));
      }
    }
}

CorotMultirate::~CorotMultirate() {
  if (job_.valid()) job_.wait();
}

void CorotMultirate::wait() {
  if (job_.valid()) job_.get();  // rethrows a failed factorisation
}

const PadColumns* CorotLinearisation::find(const std::vector<PatchTap>& pad) const {
  for (const PadColumns& c : pads)
    if (c.pad == pad) return &c;
  return nullptr;
}

void CorotMultirate::solve_pad(CorotLinearisation& L, const std::vector<PatchTap>& pad) {
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(L.u.size(), 3);
  for (const auto& t : pad)
    for (int c = 0; c < 3; ++c) G(t.dof + c, c) += t.w;
  L.pads.push_back({pad, L.ldlt.solve(G)});
}

void CorotMultirate::linearise(CorotLinearisation& L, const Eigen::VectorXd& u,
                               const Eigen::VectorXd& f_ext, const PatchPads& pads) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::VectorXd x = flatten(sys_.X0) + u;
  corotational_stiffness(sys_, x, jac_, L.Ke_t, L.K, &L.f_int);
  double* k = L.K.valuePtr();
  if (support_.size()) {  // the foundation is linear: not rotated
    for (long i = 0; i < L.K.rows(); ++i) k[diag_slot_[i]] += support_[i];
    L.f_int -= support_.cwiseProduct(u);
  }
  for (int s : zero_slot_) k[s] = 0.0;
  for (int s : fixed_diag_slot_) k[s] = 1.0;
  if (!L.analysed) {
    L.ldlt.analyzePattern(L.K);
    L.analysed = true;
  }
  L.ldlt.factorize(L.K);
  if (L.ldlt.info() != Eigen::Success)
    throw std::runtime_error("fem multirate: factorisation of the co-rotational tangent failed");
  L.factor_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  Eigen::VectorXd r = L.f_int + f_ext;
  for (long i = 0; i < r.size(); ++i)
    if (fixed_dof_[i]) r[i] = 0.0;
  L.u = u;
  L.delta0 = L.ldlt.solve(r);
  L.pads.clear();
  for (const auto& pad : pads)
    if (!pad.empty() && !L.find(pad)) solve_pad(L, pad);
}

void CorotMultirate::relinearise_now(const Eigen::VectorXd& u, const Eigen::VectorXd& f_ext,
                                     const PatchPads& pads) {
  wait();
  pending_ = false;
  linearise(*cur_, u, f_ext, pads);
  cur_->started = updates_;
  ++count_;
}

void CorotMultirate::update(const Eigen::VectorXd& u, const Eigen::VectorXd& f_ext,
                            const PatchPads& pads) {
  ++updates_;
  if (!background_) {
    linearise(*cur_, u, f_ext, pads);
    cur_->started = updates_;
    ++count_;
    return;
  }
  if (pending_) {
    if (!deterministic_ && job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
      max_lag_ = std::max(max_lag_, updates_ - cur_->started);
      return;  // still running: the haptic step does not wait
    }
    wait();
    std::swap(cur_, next_);
    pending_ = false;
    ++count_;
  }
  max_lag_ = std::max(max_lag_, updates_ - cur_->started);
  job_u_ = u;
  job_f_ = f_ext;
  CorotLinearisation* L = next_.get();
  L->started = updates_;
  PatchPads p = pads;
  job_ = std::async(std::launch::async,
                    [this, L, p = std::move(p)] { linearise(*L, job_u_, job_f_, p); });
  pending_ = true;
}

void CorotMultirate::pad_columns(const PatchPads& pads, std::vector<const PadColumns*>& out) {
  CorotLinearisation& L = *cur_;
  // Bounded cache: cleared before any pointer of this call is taken (a long slide visits many
  // vertices; one linearisation lives 1/60 s).
  if (L.pads.size() > 16) L.pads.clear();
  for (const auto& pad : pads)
    if (!pad.empty() && !L.find(pad)) {
      solve_pad(L, pad);
      ++pad_solves_;
    }
  out.clear();
  for (const auto& pad : pads) out.push_back(pad.empty() ? nullptr : L.find(pad));
}

}  // namespace palplab::engine
