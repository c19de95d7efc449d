#pragma once
// Multi-rate co-rotational FEM (issue 12; FemFormulation::corotational_multirate): the
// co-rotational model split into a haptic part at 1 kHz and a deformation part at graphics rate.
//
// A linearisation about a state u_L (x_L = X0 + u_L) is the tangent problem of the static
// co-rotational FEM there: K_t(x_L) (exact or warped tangent plus the linear foundation, identity
// rows on fixed dofs), factorised, and the Newton step of the unloaded problem
//   delta0 = K_t^-1 (f_int(x_L) + f_ext),     f_int including the foundation's -S u_L.
// Under an additional contact load -f G n on the patch (G = sum_i w_i E_i), one Newton step from
// x_L gives the static displacement
//   u(f) = u_L + delta0 - f Y n,   Y = K_t^-1 G  (3#V by 3: the patch's compliance columns),
// so the patch's normal gap is linear in f with the compliance c = n^T G^T Y n, and the penalty
// spring k in series with it renders f = k d0 / (1 + k c), d0 the penetration of u_L + delta0.
// That is the haptic step: a few patch-node reads and a 3x3 product, no sparse solve. Y is
// linear in G, and the scene's patch is a blend of pads (the contact face's three vertex pads
// weighted by the contact point's barycentric weights, G = sum_a b_a G_a): the columns
// Y_a = K_t^-1 G_a are solved once per linearisation and PAD (3 back-substitutions each, cached;
// the worker solves those of the pads it was started with) and blended each step,
// Y = sum_a b_a Y_a, c = n^T (sum_ab b_a b_b G_a^T Y_b) n. A slide then solves only when the
// contact reaches a new vertex, not at every step (the blend's weights change every step).
//
// At graphics rate (every update interval) the deformation is advanced to the predicted
// equilibrium u(f) under the current force and the model re-linearises about it: assembly of the
// tangent and forces, one numeric factorisation (pattern analysed once), delta0 and Y — the cost
// of one full co-rotational step. With `background` that work runs in a worker thread on a
// second buffer while the haptic steps go on with the previous linearisation, and is adopted at
// the first update at which it is finished (real time: the haptic step never waits; when the
// re-linearisation takes longer than an interval — ~75 ms on Model-C, ~300 ms under load — the
// deformation is still moved at every update, from the older linearisation, and the achieved
// re-linearisation rate is 1 / its cost). `deterministic` instead waits for it at the next
// update (one interval of lag; the result does not depend on thread timing; the step may
// block). Without background it runs in the update step itself (a p99 of one factorisation).
//
// Quasi-static: the haptic force is the static equilibrium of the linearised problem, the
// tissue's inertia and damping are not rendered (the full co-rotational model is dynamic; on a
// slow press the difference is the viscous force). At small strain K_t = K and f_int = -K u, so
// it equals the linear FEM's static response exactly (tests/fem). Units: m, N, s.
#include <Eigen/Core>
#include <cstdint>
#include <future>
#include <memory>
#include <vector>

#include "engine/solvers/fem_corotational.hpp"
#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

// A contact patch: (first dof, weight) of every patch node that moves.
struct PatchTap {
  int dof;
  double w;
  bool operator==(const PatchTap& o) const { return dof == o.dof && w == o.w; }
};

// A pad's compliance columns about one linearisation.
struct PadColumns {
  std::vector<PatchTap> pad;                   // (dof, weight) of the pad's moving nodes
  Eigen::Matrix<double, Eigen::Dynamic, 3> Y;  // 3#V by 3, K_t^-1 G_pad (m/N)
};
using PatchPads = std::vector<std::vector<PatchTap>>;

struct CorotLinearisation {
  Eigen::VectorXd u;             // 3#V, the state it is about (m)
  Eigen::VectorXd delta0;        // 3#V (m)
  std::vector<PadColumns> pads;  // cached columns of the pads solved about it
  double factor_ms = 0;          // assembly + factorisation (ms)
  long started = 0;              // the update (CorotMultirate::updates()) that captured u
  const PadColumns* find(const std::vector<PatchTap>& pad) const;
  // Workspace.
  SparseMatrixd K;
  SparseLdlt ldlt;
  bool analysed = false;
  std::vector<Matrix12d> Ke_t;
  Eigen::VectorXd f_int;
};

class CorotMultirate {
 public:
  // fixed_dof: 3#V flags; support: 3#V foundation stiffness (N/m, empty = none).
  CorotMultirate(const FemSystem& sys, std::vector<std::uint8_t> fixed_dof, Eigen::VectorXd support,
                 CorotJacobian jac, bool background, bool deterministic);
  ~CorotMultirate();
  CorotMultirate(const CorotMultirate&) = delete;
  CorotMultirate& operator=(const CorotMultirate&) = delete;

  // Re-linearises about u now (construction, reset); drops a pending background job.
  // `pads`: the pads whose columns the linearisation solves (those of the current contact).
  void relinearise_now(const Eigen::VectorXd& u, const Eigen::VectorXd& f_ext,
                       const PatchPads& pads);
  // The graphics-rate update: a finished (deterministic: the) pending linearisation becomes
  // current, then one about u is started (background; unless one is still running) or made now.
  void update(const Eigen::VectorXd& u, const Eigen::VectorXd& f_ext, const PatchPads& pads);
  const CorotLinearisation& current() const { return *cur_; }
  // The columns Y_a of the current linearisation for every pad (3 back-substitutions for each
  // pad not cached); out[a] stays valid until the next call or update.
  void pad_columns(const PatchPads& pads, std::vector<const PadColumns*>& out);
  long relinearisations() const { return count_; }  // adopted since construction
  long updates() const { return updates_; }         // update() calls since construction
  // The largest age (in update intervals) of the linearisation in use, sampled at every update
  // after the adoption: 0 without background, 1 deterministic, more when the worker was late.
  long max_lag() const { return max_lag_; }
  long pad_solves() const { return pad_solves_; }  // pads solved in the haptic thread

 private:
  void linearise(CorotLinearisation& L, const Eigen::VectorXd& u, const Eigen::VectorXd& f_ext,
                 const PatchPads& pads) const;
  static void solve_pad(CorotLinearisation& L, const std::vector<PatchTap>& pad);
  void wait();
  const FemSystem& sys_;
  std::vector<std::uint8_t> fixed_dof_;
  Eigen::VectorXd support_;
  CorotJacobian jac_;
  bool background_, deterministic_;
  long count_ = 0, pad_solves_ = 0, updates_ = 0, max_lag_ = 0;
  std::vector<int> diag_slot_, zero_slot_, fixed_diag_slot_;
  std::unique_ptr<CorotLinearisation> cur_, next_;
  std::future<void> job_;
  bool pending_ = false;
  Eigen::VectorXd job_u_, job_f_;  // the job's inputs (copies: the caller moves on)
};

}  // namespace palplab::engine
