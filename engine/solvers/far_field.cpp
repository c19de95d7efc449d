#include "engine/solvers/far_field.hpp"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "engine/models/stored_factor.hpp"
#include "results/sha256.hpp"

namespace palplab::engine {

namespace {

constexpr char kFarFieldTag[8] = {'F', 'A', 'R', 'L', 'D', 'L', 'T', '1'};
using Digest = std::array<std::uint8_t, 32>;

// SHA-256 of everything K is assembled from (lengths keep the fields apart).
Digest inputs_digest(const MassSpringSystem& sys) {
  results::Sha256 h;
  auto add = [&](const void* p, std::size_t n) {
    const std::uint64_t len = n;
    h.update(&len, sizeof len);
    h.update(p, n);
  };
  const std::int64_t n = sys.nodes();
  add(&n, sizeof n);
  add(sys.X_rest.data(), sizeof(double) * sys.X_rest.size());
  add(sys.fixed.data(), sys.fixed.size());
  add(sys.home_ks.data(), sizeof(double) * sys.home_ks.size());
  add(sys.springs.E.data(), sizeof(int) * sys.springs.E.size());
  add(sys.springs.ks.data(), sizeof(double) * sys.springs.ks.size());
  return h.digest();
}

// The factor of a far_field_save blob made from inputs d for m dofs, or false.
bool restore(const std::string& blob, const Digest& d, long m, LdltFactor& f) {
  constexpr std::size_t head = sizeof kFarFieldTag + 32 + sizeof(std::int64_t);
  if (blob.size() < head || std::memcmp(blob.data(), kFarFieldTag, sizeof kFarFieldTag) != 0 ||
      std::memcmp(blob.data() + sizeof kFarFieldTag, d.data(), 32) != 0)
    return false;
  std::int64_t dofs;
  std::memcpy(&dofs, blob.data() + sizeof kFarFieldTag + 32, sizeof dofs);
  std::size_t at = head;
  return dofs == m && get_ldlt_factor(blob, at, m, f) && at == blob.size();
}

}  // namespace

std::string far_field_save(const MassSpringSystem& sys, const FarField& ff) {
  if (!ff.ready() || ff.nodes != sys.nodes() || !ff.factor.L.isCompressed()) return {};
  const Digest d = inputs_digest(sys);
  const std::int64_t dofs = ff.factor.size();
  std::string s(kFarFieldTag, sizeof kFarFieldTag);
  s.append(reinterpret_cast<const char*>(d.data()), d.size());
  s.append(reinterpret_cast<const char*>(&dofs), sizeof dofs);
  put_ldlt_factor(s, ff.factor);
  return s;
}

void far_field_build(const MassSpringSystem& sys, FarField& ff, const std::string* stored) {
  const auto t0 = std::chrono::steady_clock::now();
  const long n = sys.nodes();
  ff.dof.assign(n, -1);
  int m = 0;
  for (long i = 0; i < n; ++i)
    if (sys.fixed.empty() || !sys.fixed[i]) ff.dof[i] = 3 * m++;
  auto finish = [&] {
    ff.load.setZero(3 * m);
    ff.g.setZero(3 * m);
    ff.tmp.setZero(3 * m);
    ff.nodes = n;
    ff.factor_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  // The stored factor passed the singularity check below when it was made from these inputs.
  ff.restored =
      stored && !stored->empty() && restore(*stored, inputs_digest(sys), 3L * m, ff.factor);
  if (ff.restored) return finish();
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(9 * 4 * sys.springs.size() + 3 * m);
  for (long i = 0; i < n; ++i)
    if (ff.dof[i] >= 0)
      for (int r = 0; r < 3; ++r) t.emplace_back(ff.dof[i] + r, ff.dof[i] + r, sys.home_ks[i]);
  for (long s = 0; s < sys.springs.size(); ++s) {
    const int a = sys.springs.E(s, 0), b = sys.springs.E(s, 1);
    const Eigen::Vector3d du = (sys.X_rest.row(a) - sys.X_rest.row(b)).transpose();
    const double len = du.norm();
    if (!(len > 0.0)) continue;
    // At rest the lateral term ks (1 - l/|du|) of spring_eval's Jacobian is 0: -Kx = ks d d^T.
    const Eigen::Matrix3d k = sys.springs.ks[s] * (du / len) * (du / len).transpose();
    const int da = ff.dof[a], db = ff.dof[b];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        if (da >= 0) t.emplace_back(da + r, da + c, k(r, c));
        if (db >= 0) t.emplace_back(db + r, db + c, k(r, c));
        if (da >= 0 && db >= 0) {
          t.emplace_back(da + r, db + c, -k(r, c));
          t.emplace_back(db + r, da + c, -k(r, c));
        }
      }
  }
  Eigen::SparseMatrix<double> K(3 * m, 3 * m);
  K.setFromTriplets(t.begin(), t.end());
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(K);
  // A zero pivot shows up as rounding noise: compare it with the largest one.
  const Eigen::VectorXd D = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || D.size() == 0 || !(D.minCoeff() > 1e-10 * D.maxCoeff()))
    throw std::runtime_error(
        "far field: the model's stiffness at rest is singular (a part without support)");
  // Solved from the plain factors, built here or restored: the same data, the same solve.
  ff.factor = LdltFactor::from(ldlt);
  finish();
}

namespace {

// g for the patch into `g` (load, tmp: buffers of the same size), from ff's factor only (read):
// the one solve of every mode, so that all of them give bit-identical solutions.
void solve_into(const FarField& ff, const std::vector<int>& nodes,
                const std::vector<double>& weights, const Eigen::Vector3d& dir,
                Eigen::VectorXd& load, Eigen::VectorXd& tmp, Eigen::VectorXd& g) {
  load.setZero();
  double sum = 0.0;
  for (size_t k = 0; k < nodes.size(); ++k)
    if (nodes[k] < ff.nodes && ff.dof[nodes[k]] >= 0) sum += weights[k];
  if (!(sum > 0.0)) {
    g.setZero();
    return;
  }
  for (size_t k = 0; k < nodes.size(); ++k)
    if (nodes[k] < ff.nodes && ff.dof[nodes[k]] >= 0)
      load.segment<3>(ff.dof[nodes[k]]) += (weights[k] / sum) * dir;
  // LdltFactor::solve written out (permutation, unit-lower L, D, L^T): Eigen's in-place
  // permutation and triangular solves allocate a temporary, and this solve runs beside (or, in
  // sync mode, in) a haptic step.
  const auto& perm = ff.factor.P.indices();
  const bool permuted = perm.size() == load.size();
  for (Eigen::Index i = 0; i < load.size(); ++i) tmp[permuted ? perm[i] : i] = load[i];
  const SparseMatrixd& L = ff.factor.L;  // strictly lower part, column-major
  for (Eigen::Index j = 0; j < L.outerSize(); ++j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, j); it; ++it)
      if (it.row() > j) tmp[it.row()] -= it.value() * tmp[j];
  tmp.array() /= ff.factor.D.array();
  for (Eigen::Index j = L.outerSize() - 1; j >= 0; --j)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, j); it; ++it)
      if (it.row() > j) tmp[j] -= it.value() * tmp[it.row()];
  for (Eigen::Index i = 0; i < g.size(); ++i) g[i] = tmp[permuted ? perm[i] : i];
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

void far_field_solve(FarField& ff, const std::vector<int>& nodes,
                     const std::vector<double>& weights, const Eigen::Vector3d& dir) {
  // Timed on its own (one solve per scope move; the bench reports it apart from the step).
  const auto t0 = std::chrono::steady_clock::now();
  solve_into(ff, nodes, weights, dir, ff.load, ff.tmp, ff.g);
  ff.solve_ms = ms_since(t0);
}

FarFieldUpdater::FarFieldUpdater(const FarField& ff, FarFieldMode mode, int latency, int blend)
    : ff_(ff), mode_(mode), latency_(std::max(1, latency)), blend_(std::max(1, blend)) {
  const long m = ff.g.size();
  cur_.setZero(m);
  if (blend_ > 1) {
    from_.setZero(m);
    to_.setZero(m);
  }
  if (mode_ == FarFieldMode::sync) {
    load_.setZero(m);
    tmp_.setZero(m);
    return;
  }
  ready_.setZero(m);
  work_g_.setZero(m);
  work_load_.setZero(m);
  work_tmp_.setZero(m);
  // Room for a patch of every coarse node: request() copies without allocating.
  for (Job* j : {&queued_, &run_}) {
    j->nodes.reserve(ff.nodes);
    j->weights.reserve(ff.nodes);
  }
  worker_ = std::thread([this] { work(); });
}

FarFieldUpdater::~FarFieldUpdater() {
  if (!worker_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  worker_.join();  // after the solve in flight, if any (it reads only ff_ and its buffers)
}

void FarFieldUpdater::work() {
  std::unique_lock<std::mutex> lock(mu_);
  for (;;) {
    cv_.wait(lock, [this] { return stop_ || has_queued_; });
    if (stop_) return;
    std::swap(run_, queued_);  // vectors swap their buffers: no allocation
    has_queued_ = false;
    lock.unlock();
    const auto t0 = std::chrono::steady_clock::now();
    solve_into(ff_, run_.nodes, run_.weights, run_.dir, work_load_, work_tmp_, work_g_);
    const double ms = ms_since(t0);
    lock.lock();
    if (run_.id > floor_id_) {  // not cleared meanwhile
      std::swap(ready_, work_g_);
      ready_id_ = run_.id;
      ready_ms_ = ms;
    }
    cv_.notify_all();  // a deterministic step may wait for it
  }
}

void FarFieldUpdater::request(const std::vector<int>& nodes, const std::vector<double>& weights,
                              const Eigen::Vector3d& dir) {
  ++st_.requests;
  if (mode_ == FarFieldMode::sync) {
    const auto t0 = std::chrono::steady_clock::now();
    if (blend_ > 1) {
      solve_into(ff_, nodes, weights, dir, load_, tmp_, to_);  // a running blend's target: replaced
      adopt(to_);
    } else {
      solve_into(ff_, nodes, weights, dir, load_, tmp_, cur_);
    }
    st_.solve_ms = ms_since(t0);
    ++st_.adopted;
    return;
  }
  if (want_ > 0) ++st_.superseded;
  want_ = ++next_id_;
  want_step_ = step_;
  {
    std::lock_guard<std::mutex> lock(mu_);
    queued_.nodes.assign(nodes.begin(), nodes.end());
    queued_.weights.assign(weights.begin(), weights.end());
    queued_.dir = dir;
    queued_.id = want_;
    has_queued_ = true;
  }
  cv_.notify_all();
}

void FarFieldUpdater::adopt(Eigen::VectorXd& g) {
  if (blend_ <= 1) {
    std::swap(cur_, g);
    return;
  }
  // g_old is the g in use now (a running blend's too); g_new moves into to_ (g may be to_ itself).
  if (&g != &to_) std::swap(to_, g);
  from_ = cur_;  // same size: no allocation
  blend_k_ = 0;
  blend_step();
}

void FarFieldUpdater::blend_step() {
  if (++blend_k_ >= blend_) {
    cur_ = to_;  // the adopted solution itself, bit for bit
    blend_k_ = 0;
    return;
  }
  const double s = static_cast<double>(blend_k_) / static_cast<double>(blend_);
  cur_ = from_ + s * (to_ - from_);  // one expression: no temporary
}

bool FarFieldUpdater::advance() {
  ++step_;
  // Not adopting this step: the next step of a running blend, if any.
  const auto blend_on = [this] {
    if (blend_k_ == 0) return false;
    blend_step();
    return true;
  };
  if (want_ == 0 || step_ - want_step_ < latency_) return blend_on();
  std::unique_lock<std::mutex> lock(mu_);
  if (ready_id_ != want_) {
    if (mode_ == FarFieldMode::async) {  // never waits: adopted later
      lock.unlock();
      return blend_on();
    }
    ++st_.waits;
    cv_.wait(lock, [this] { return ready_id_ == want_; });
  }
  adopt(ready_);  // ready_ gets a buffer not in use
  ready_id_ = 0;
  st_.solve_ms = ready_ms_;
  lock.unlock();
  ++st_.adopted;
  if (step_ - want_step_ > latency_) ++st_.late;
  st_.max_latency = std::max(st_.max_latency, step_ - want_step_);
  want_ = 0;
  return true;
}

void FarFieldUpdater::clear() {
  cur_.setZero();
  blend_k_ = 0;
  if (mode_ == FarFieldMode::sync) return;
  want_ = 0;
  std::lock_guard<std::mutex> lock(mu_);
  has_queued_ = false;
  floor_id_ = next_id_;
  ready_id_ = 0;
}

void FarFieldUpdater::set_realtime(bool realtime) {
  if (mode_ != FarFieldMode::sync)
    mode_ = realtime ? FarFieldMode::async : FarFieldMode::deterministic;
}

}  // namespace palplab::engine
