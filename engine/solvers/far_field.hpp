#pragma once
// The exterior of a local integration scope as the linear, quasi-static response of the whole
// mass-spring model at rest (prototype C).
//
// A scope integrates the nodes near the contact; the rest of the organ used to be held at rest,
// a rigid wall 3 cm away that made the press 19-26 % too stiff (bench `sleeping`). Here the
// exterior follows the whole model's linear static response to the current contact force F:
//   K g = l,   u_exterior = |F| g,
// K: the stiffness of every non-fixed coarse node at rest (springs ks d d^T, support home_ks;
// fixed nodes removed), l: a unit load along -n spread over the contact patch by its weights.
// With the exterior's true displacement prescribed on the scope's boundary, the scope's own
// (nonlinear, dynamic) solution is the whole model's in the quasi-static linear limit: the
// exterior's compliance without integrating it. K is factorised once per model (sparse LDLT),
// g costs one solve when the scope is re-centred; a step adds |exterior| 3-vectors.
// Vectors are 3 #coarse, node-major; nodes beyond `nodes` (refinement) are not part of it.
// A .psim file stores the factorisation (far_field_save; the LdltFactor serialisation of
// engine/models/stored_factor.hpp) tagged with a SHA-256 of every input of K; a build from the
// same system restores it instead of factorising, and solves bit-identically.
#include <Eigen/SparseCore>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "engine/models/mass_spring.hpp"
#include "engine/solvers/ldlt_factor.hpp"

namespace palplab::engine {

struct FarField {
  long nodes = 0;           // coarse nodes K was assembled for
  std::vector<int> dof;     // #nodes: first dof of a node, -1 = fixed
  LdltFactor factor;        // P K P^T = L D L^T (#dofs square)
  Eigen::VectorXd load, g;  // #dofs: the unit load and its displacement (m/N)
  Eigen::VectorXd tmp;      // #dofs: solve buffer
  double factor_ms = 0.0;   // time the factorisation (or its restoring) took
  bool restored = false;    // the factorisation came from a stored blob
  double solve_ms = 0.0;    // time the last far_field_solve took (wall, ms)
  bool ready() const { return nodes > 0; }
};

// Assembles K at rest over sys's nodes and factorises it. Throws std::runtime_error when K is
// singular (a part of the model with neither support nor fixed node). `stored` (nullptr = none):
// a far_field_save blob; used (ff.restored) only when it was made from a system with the same
// nodes, rest positions, fixed nodes, support and springs, and is well formed; else ignored.
void far_field_build(const MassSpringSystem& sys, FarField& ff,
                     const std::string* stored = nullptr);

// ff's factorisation (built for sys) as bytes for a .psim file.
std::string far_field_save(const MassSpringSystem& sys, const FarField& ff);

// g for a unit force along `dir` (the direction the tissue is pushed) shared by the patch
// `nodes` with `weights` (nodes >= ff.nodes are left out and the weights renormalised).
void far_field_solve(FarField& ff, const std::vector<int>& nodes,
                     const std::vector<double>& weights, const Eigen::Vector3d& dir);

// How the exterior follows a moved scope (issue 9): one far_field_solve costs 3-25 ms on
// Model-C, against a 1 ms haptic step, so it does not run inside the step.
//   sync:          solved in the step that moved the scope (the step takes the solve's time).
//   deterministic: solved by a worker thread, adopted exactly `latency` haptic steps after the
//                  request; the step waits for the worker at that step if it is not finished
//                  (never in practice at 1 kHz: the solve takes a fraction of the latency; in
//                  lock-step, faster than real time, it may). The result is a function of the
//                  step index alone: virtual participants in lock-step, reproducible.
//   async:         solved by the worker, adopted at the first step >= `latency` steps after the
//                  request at which it is finished; a step never waits (real time). When the
//                  solve finishes within the latency — the normal case — the adoption step and
//                  so every force equal the deterministic mode's; otherwise it is adopted later
//                  (counted as late: latency <= the latency or two solves, whichever is longer).
// Until the adoption the exterior keeps the previous solution (the last scope's load; zero after
// a reset, i.e. held at rest).
// Blend (issue 9): with blend = B > 1 an adopted solution is not put in use in one step but over
// B haptic steps, g = g_old + (k / B)(g_new - g_old) at the k-th step from the adoption (k = 1
// at the adoption step, the request's step in sync mode); the B-th step puts g_new itself in use
// (bit for bit: the converged exterior is that of B = 1). Put in use at once, a re-centred scope's
// exterior moved every exterior node in one step and the force under a sliding press of C jumped
// by up to 0.82 N. A newer adoption during a blend blends on from the g in use.
enum class FarFieldMode { sync, deterministic, async };

// Counters since construction (read by the haptic thread).
struct FarFieldUpdateStats {
  long requests = 0;      // solves requested (scope moves)
  long adopted = 0;       // solutions put in use
  long superseded = 0;    // requests replaced by a newer one before adoption
  long waits = 0;         // steps that waited for the worker (deterministic mode only)
  long late = 0;          // adoptions after the latency (async: the solve took longer)
  long max_latency = 0;   // most steps from a request to its adoption
  double solve_ms = 0.0;  // the last finished solve (wall, ms)
};

// The solution g of a FarField, updated beside the haptic loop. The haptic thread calls
// request() when the scope moves and advance() once per haptic step; g() is the solution in use.
// The worker only reads the factorisation (built before, never changed while it runs) and its
// own buffers; the request's inputs and the finished solution pass under a mutex (swaps of
// preallocated vectors: neither thread allocates per request). Destruction and clear() while a
// solve is in flight are safe: the destructor joins the worker after its current solve; clear()
// discards the result of every earlier request.
class FarFieldUpdater {
 public:
  // ff must be built (far_field_build) and outlive this object. latency >= 1 (steps) for the
  // worker modes; blend >= 1 steps (see above; values below 1 count as 1).
  FarFieldUpdater(const FarField& ff, FarFieldMode mode, int latency, int blend = 1);
  ~FarFieldUpdater();
  FarFieldUpdater(const FarFieldUpdater&) = delete;
  FarFieldUpdater& operator=(const FarFieldUpdater&) = delete;

  // The scope moved: g for a unit force along dir on the patch (as far_field_solve). sync: solved
  // now (g() changes); else queued for the worker (replaces a queued, not yet started request).
  void request(const std::vector<int>& nodes, const std::vector<double>& weights,
               const Eigen::Vector3d& dir);
  // One haptic step passed: adopts the newest request's solution when the mode says so, or
  // takes the next step of a blend. True when g() changed.
  bool advance();
  // Back to rest: pending requests and a solve in flight are dropped, g() = 0. Does not wait.
  void clear();
  // Switches between deterministic and async (real-time loops; see Scene::set_realtime). No
  // effect in sync mode.
  void set_realtime(bool realtime);
  FarFieldMode mode() const { return mode_; }
  int latency() const { return latency_; }
  int blend() const { return blend_; }
  // g() changes at a coming advance(): a request waits for adoption, or a blend runs.
  bool pending() const { return want_ > 0 || blend_k_ > 0; }
  bool blending() const { return blend_k_ > 0; }
  const Eigen::VectorXd& g() const { return cur_; }
  const FarFieldUpdateStats& stats() const { return st_; }

 private:
  void work();
  // Puts `g` in use (swapping buffers with it): at once, or as the first step of a blend.
  void adopt(Eigen::VectorXd& g);
  void blend_step();
  struct Job {
    std::vector<int> nodes;
    std::vector<double> weights;
    Eigen::Vector3d dir = Eigen::Vector3d::Zero();
    long id = 0;
  };
  const FarField& ff_;
  FarFieldMode mode_;
  int latency_;
  int blend_;
  // Haptic thread only.
  Eigen::VectorXd cur_, load_, tmp_;  // g in use; sync-mode solve buffers
  Eigen::VectorXd from_, to_;         // a blend's g before the adoption and the adopted one
  int blend_k_ = 0;                   // steps of the running blend done (0: none runs)
  long step_ = 0;                     // advance() calls
  long next_id_ = 0;                  // ids of requests (1, 2, ...)
  long want_ = 0;                     // the newest request's id (0 = none pending)
  long want_step_ = 0;                // the step it was made at
  FarFieldUpdateStats st_;
  // Guarded by mu_.
  std::mutex mu_;
  std::condition_variable cv_;
  Job queued_;               // the request waiting for the worker
  bool has_queued_ = false;  //
  bool stop_ = false;
  long floor_id_ = 0;      // results of requests <= this are discarded (clear())
  Eigen::VectorXd ready_;  // a finished solution ...
  long ready_id_ = 0;      // ... of this request (0 = none)
  double ready_ms_ = 0.0;
  // Worker only (the job it runs, its buffers).
  Job run_;
  Eigen::VectorXd work_g_, work_load_, work_tmp_;
  std::thread worker_;  // last: started after every member above exists
};

}  // namespace palplab::engine
