#pragma once
// Time integrators for MassSpringSystem (improving on the original's semi-implicit step):
//   symplectic_euler  v += h F/m, x += h v — what the original called "implicit"; first order,
//                     stable only for h < 2/omega_max.
//   backward_euler    linearised backward Euler (Baraff & Witkin 1998), one sparse solve per step:
//                     (M - h D - h^2 K) dv = h (f0 + h K v0),  v += dv,  x += h v.
//                     First order, unconditionally stable for the (PSD-projected) linearisation.
//   rk4               classical Runge–Kutta on (x, v); fourth order; the accuracy reference.
// Each step integrates only the nodes of an ActiveSet (all nodes by default); the others are held
// where they are (Dirichlet). Fixed nodes never move. Workspaces are reused so that a step does
// not allocate once warmed up (except LDLT, whose sparse factorisation allocates in Eigen).
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <string>
#include <vector>

#include "engine/models/mass_spring.hpp"

namespace palplab::engine {

enum class Integrator { symplectic_euler, backward_euler, rk4 };
// How backward Euler solves its linear system.
enum class LinearSolver {
  cg,             // matrix-free block-Jacobi preconditioned CG, warm-started from the last dv
  ldlt_refactor,  // assembled sparse LDLT: pattern analysed once per active set, numeric
                  // factorisation every step (exact linearised backward Euler)
  ldlt_frozen,    // factorise once per active set and reuse it while the set is unchanged
                // (the matrix lags the deformation: cheaper, not exact — see bench_engine_solver)
};

// How the CG solver stores a spring's block S = -(h Kv + h^2 Kx) of the system matrix.
//   matrix:   a 3x3 matrix per spring, assembled from spring_eval (the original path).
//   rank_one: S = a d d^T + b I (spring_tangent's factored form: 5 numbers, no 3x3 products);
//             the same matrix in exact arithmetic, rounded differently (not bit-identical to
//             `matrix`: differences are at the CG tolerance, see docs/ARCHITECTURE.md).
// The LDLT solvers always assemble matrices.
enum class SpringBlocks { matrix, rank_one };

Integrator integrator_from_string(const std::string& s);  // throws std::invalid_argument
const char* to_string(Integrator i);
LinearSolver linear_solver_from_string(const std::string& s);
const char* to_string(LinearSolver s);
SpringBlocks spring_blocks_from_string(const std::string& s);  // throws std::invalid_argument
const char* to_string(SpringBlocks b);

// The nodes to integrate and the springs touching them. `version` changes whenever the set does,
// so solvers can cache per-set data (sparsity pattern, factorisation).
struct ActiveSet {
  std::vector<int> nodes;               // integrated nodes (not fixed), ascending
  std::vector<int> springs;             // springs with at least one endpoint in `nodes`, ascending
  std::vector<std::uint8_t> is_active;  // #V
  long version = 0;
  std::vector<int> removed;  // scratch of update_sleeping
};
// Every non-fixed node.
void activate_all(const MassSpringSystem& sys, ActiveSet& act);
// Rebuilds act.springs from act.nodes / act.is_active (uses sys adjacency); bumps version.
void rebuild_active_springs(const MassSpringSystem& sys, ActiveSet& act);

struct SolverStats {
  int cg_iterations = 0;
  double residual = 0.0;  // relative residual of the last solve
};

// A symmetric 3x3 block (kg): xx, yy, zz, xy, xz, yz.
struct Sym3 {
  double xx, yy, zz, xy, xz, yz;
};

// Compact per-active-set data of the CG solver (see integrators.cpp).
struct CompactCg {
  struct Link {
    int a, b, k;  // local node indices (b = -1: other end held), index into S
  };
  long version = -1;
  std::vector<int> local, prev_nodes;
  std::vector<Link> inner, held;
  std::vector<Eigen::Matrix3d> D, Dinv;
  Eigen::VectorXd x, r, z, p, ap;
  // The rank_one path (SpringBlocks::rank_one): per active spring its local ends (-1 = held),
  // per node the symmetric diagonal block of the product (mass, support, contact, held springs)
  // and the inverse of A's full diagonal block (the preconditioner), and the rhs b (3m).
  struct Ends {
    int a, b;
  };
  std::vector<Ends> ends;
  // Per inner spring (in the order of `inner`) its block a d d^T + b I beside its local ends,
  // contiguous for the CG product (written by the step's spring pass).
  struct InnerBlock {
    double d0, d1, d2, a, b;
    int ia, ib;
  };
  std::vector<InnerBlock> iblocks;
  // Per active spring this step's unit direction d = du / |du|, |du| and 1 / |du| (the spring
  // pass's first loop: its square roots and divisions off the second loop's critical path).
  struct Direction {
    double d0, d1, d2, len, il;
  };
  std::vector<Direction> dirs;
  std::vector<Sym3> Ds, Pinv;
  Eigen::VectorXd rhs;
  // warm_start == extrapolated: the solutions of the last two steps on this set (3m each) and
  // how many of them are valid (reset when the set changes).
  Eigen::VectorXd x1, x2;
  int history = 0;
};

// CG's first guess for dv: the last step's dv of each node (`previous`), or its linear
// extrapolation 2 dv_{n-1} - dv_{n-2} over the last two steps on the same active set
// (`extrapolated`). Both stop at the same tolerance; the results differ within it. Measured on
// C's presses (bench_engine_step --solver) extrapolation needs more CG iterations, not fewer
// (dv is not smooth from step to step at C's tolerance): `previous` is the default.
enum class WarmStart { previous, extrapolated };
WarmStart warm_start_from_string(const std::string& s);  // throws std::invalid_argument
const char* to_string(WarmStart w);

// How backward Euler solves its system: the settings a scene configures (engine::SceneConfig
// holds one of these; its defaults are the scene defaults).
struct SolverConfig {
  LinearSolver solver = LinearSolver::cg;
  double cg_tolerance = 1e-6;        // relative residual
  double cg_force_tolerance = 1e-6;  // N: absolute floor of the residual (as a force)
  int cg_max_iterations = 500;
  SpringJacobian jacobian = SpringJacobian::definite;  // spring tangent used by the solve
  SpringBlocks blocks = SpringBlocks::rank_one;        // CG's storage of the spring blocks
  WarmStart warm_start = WarmStart::previous;          // CG's first guess
};

// One spring's block of A in rank_one form: S = a d d^T + b I (d unit, a and b in kg).
struct RankOneBlock {
  Eigen::Vector3d d;
  double a, b;
};

// The settings plus the buffers of one integrated system.
struct IntegratorWorkspace : SolverConfig {
  SolverStats last;
  // buffers (sized on first use)
  RowMatX3d F, X1, V1, kx[4], kv[4], R, P, Z, AP, DV;
  std::vector<Eigen::Matrix3d> S;     // per active spring: h Kv + h^2 Kx (negated sign kept)
  std::vector<RankOneBlock> SR;       // the same in rank_one form (blocks == rank_one)
  std::vector<Eigen::Matrix3d> Dinv;  // per node: inverse diagonal block of A
  std::vector<int> dof_of_node;       // LDLT: node -> row block, -1 inactive
  Eigen::SparseMatrix<double> A;
  std::vector<Eigen::Triplet<double>> triplets;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  long analysed_version = -1, factor_version = -1;
  Eigen::VectorXd b, x;
  bool contact_on = false;
  double h = 0.0;
  CompactCg compact;
  int factor_contact = -2;
  double factor_h = 0.0, factor_contact_k = 0.0;
  // Backward-Euler system blocks of the probe contact, one per penetrating patch node.
  std::vector<Eigen::Matrix3d> contact_blocks;
  std::vector<int> contact_block_node;
};

// Advances sys by h seconds (one step of `method`) on the nodes of `act`.
void integrate(MassSpringSystem& sys, const ActiveSet& act, double h, Integrator method,
               IntegratorWorkspace& ws);

}  // namespace palplab::engine
