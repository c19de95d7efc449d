#pragma once
// FemModel: the tissue FEM of a haptic scene (prototype D, issue 12). A tet mesh with per-tet
// materials (tissue table, SI units) and fixed nodes (rigid tissue is always fixed; the caller
// adds a pinned region), integrated with linearised backward Euler, touched by the device through
// the same penalty contact as the mass-spring model (mass_spring.hpp), on a contact patch:
//   patch nodes i with area weights w_i (sum 1; default: the contact node alone, w = 1), rest
//   offsets o_i = max(0, (X0_i - X0_p) . n) above the tangent plane at p = contact_node,
//   penetration d = max(0, sum_i w_i ((x_i - contact_point) . n - o_i));
//   while d > 0 patch node i gets -w_i contact_k d n and the device feels +contact_k d n.
// The patch is a rigid flat probe face whose force is shared by area: a finite pressure patch,
// so the response converges under mesh refinement (a single-node point load does not in 3D).
// The contact Jacobian -k g g^T (g = sum_i w_i e_i n) enters the implicit step as a rank-1 term
// (Sherman–Morrison), so a stiff coupling stays stable and costs one extra cached solve.
//
// Formulations:
//   linear        small-strain FEM, A = M + h C + h^2 K factorised once per time step size;
//                 the rank-1 contact term is added with Sherman–Morrison on 3 cached columns
//                 A^-1 G (G = sum_i w_i E_i, cached per patch), so a step is ONE sparse
//                 back-substitution.
//   corotational  co-rotational FEM (fem_corotational.hpp): per step the tangent and forces
//                 are re-assembled on the fixed pattern and refactorised (pattern analysed once);
//                 the contact term by Sherman–Morrison (one more back-substitution).
//   condensed     the hybrid condensed FEM (fem_condensation.hpp) as a dynamic model: the
//                 operational region (options.operational_tet) and its interface are integrated;
//                 the rest is statically condensed onto the interface (Guyan: its interior is
//                 massless and follows quasi-statically). Exact at equilibrium (== linear);
//                 interior positions are recovered only when positions() is called (graphics
//                 rate), so a step costs a solve of the reduced system. The contact node and
//                 every patch node must be operational (solves_node()) or fixed.
//   corotational_multirate
//                 the multi-rate co-rotational model (fem_multirate.hpp): each step renders the
//                 contact force from the patch's compliance about the last linearisation of the
//                 co-rotational FEM (quasi-static, no sparse solve); every update_interval the
//                 deformation moves to the predicted equilibrium and the model re-linearises
//                 (in a worker thread with multirate_background). positions() and
//                 displacement() are the graphics-rate state; penetration() and device_force()
//                 are those of the last step.
// Mass is lumped (diagonal) by default; options.lumped_mass = false uses the consistent mass
// (linear and corotational; the condensed model is always lumped: its Guyan reduction keeps
// the mass on the solved nodes). Damping is Rayleigh C = alpha M + beta K (K = tangent for
// corotational). Units: m, s, kg, N.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "engine/mesh/tet_mesh.hpp"
#include "engine/models/fem_formulation.hpp"
#include "engine/solvers/fem_assembly.hpp"
#include "engine/solvers/fem_corotational.hpp"

namespace palplab::engine {

struct FemModelOptions {
  FemFormulation formulation = FemFormulation::linear;
  double rayleigh_alpha = 1.0;                    // mass-proportional damping (1/s)
  double rayleigh_beta = 0.001;                   // stiffness-proportional damping (s)
  CorotJacobian jacobian = CorotJacobian::exact;  // corotational tangent
  bool lumped_mass = true;                        // false: consistent mass (not condensed)
  std::vector<std::uint8_t> operational_tet;      // #T, condensed only (1 = operational)
  // 3#V diagonal elastic foundation (N/m per dof; empty = none): zero-rest-length springs that
  // hold nodes to their rest position (the surrounding tissue; the scene model gives each
  // surface node support_modulus x its lumped area, as the mass-spring model does). Part of K.
  Eigen::VectorXd support_stiffness;
  // corotational_multirate: time between deformation updates (s, > 0; the graphics rate) and
  // whether the re-linearisation runs in a worker thread (fem_multirate.hpp).
  // multirate_deterministic: the step waits for the worker at the next update (reproducible;
  // for tests), else it adopts it when finished (real time).
  double update_interval = 1.0 / 60.0;
  bool multirate_background = true;
  bool multirate_deterministic = false;
  // A .psim file's stored precomputation (save_precomputation; engine/haptics/scene_file.hpp):
  // used when it was made from the same inputs (mesh, materials, fixed nodes, options, step),
  // otherwise ignored and everything is computed. Linear formulation only. Not owned (the
  // blob is megabytes: no copy); read in the constructor only, so it must outlive that.
  const std::string* precomputed = nullptr;
};

class FemModel {
 public:
  // fixed_node: #V (empty = none); nodes of rigid tets are fixed in addition.
  // Throws InputError for bad meshes/materials/options, std::runtime_error when the
  // constraints leave the body free (singular stiffness).
  FemModel(const mesh::TetMesh& mesh, const TetMaterials& materials,
           std::vector<std::uint8_t> fixed_node, FemModelOptions options = {});
  ~FemModel();
  FemModel(const FemModel&) = delete;
  FemModel& operator=(const FemModel&) = delete;

  // Advances by h seconds (h > 0).
  void step(double h);
  // Back to rest (u = v = 0, t = 0).
  void reset();

  // #V by 3 current positions (m) of every node.
  const mesh::Positions& positions();
  const Eigen::VectorXd& displacement();  // 3#V (m)
  // Current position of one node (m) without recovering the condensed interior: exact for
  // nodes the step solves (solves_node) and fixed nodes — what the haptic contact needs.
  Eigen::Vector3d node_position(int v) const;
  double time() const { return time_; }

  // Penalty contact (see top). contact_node = -1: no contact.
  int contact_node = -1;
  std::vector<int> contact_nodes;       // the patch (contact_node among them); empty = the node
  std::vector<double> contact_weights;  // one per patch node, summing to 1
  // Optional structure of the patch, used by corotational_multirate (the other formulations
  // read contact_nodes/contact_weights only): the patch is the blend sum_a blend_a x pad a (each
  // pad's weights summing to 1; contact_nodes/contact_weights must equal that blend). The
  // multi-rate model then caches compliance columns per pad, not per blend, so a slide (whose
  // blend changes every step) solves only when a new pad appears (fem_multirate.hpp).
  struct ContactPad {
    std::vector<int> nodes;
    std::vector<double> weights;
    double blend = 0;
  };
  std::vector<ContactPad> contact_pads;  // empty = the patch is one pad
  Eigen::Vector3d contact_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d contact_normal = Eigen::Vector3d::UnitZ();
  double contact_k = 0.0;                // N/m
  double penetration() const;            // d (m), 0 without contact
  Eigen::Vector3d device_force() const;  // +k d n (N), what the device feels
  // External nodal forces (N), 3#V, constant over a step; zero after construction.
  Eigen::VectorXd f_ext;

  FemFormulation formulation() const { return opt_.formulation; }
  long dofs() const;                               // unknowns of the per-step solve
  long total_dofs() const;                         // 3#V
  std::string solver() const;                      // the linear solver used per step
  double factor_ms() const { return factor_ms_; }  // last factorisation (ms)
  long relinearisations() const;                   // corotational_multirate: adopted so far
  // corotational_multirate: the largest age, in update intervals, of the linearisation in use
  // (1 deterministic; more when the real-time worker was late)
  long linearisation_max_lag() const;
  long pad_solves() const;        // corotational_multirate: pads solved in the haptic step
  bool solves_node(int v) const;  // node v moves in the per-step solve
  const FemSystem& system() const;
  const std::vector<std::uint8_t>& fixed_nodes() const { return fixed_node_; }
  // For a .psim file: the linear model's factorisation for step size h (factorised now if
  // needed) with a digest of the inputs it was made from; "" for the other formulations (they
  // recompute). A model built from it steps bit-identically.
  std::string save_precomputation(double h);
  bool precomputation_loaded() const;  // options.precomputed was used

 private:
  void step_multirate(double h);
  // sum_i w_i ((x_i - contact_point) . n - o_i) of the patch (unclamped) at displacement a (+ b).
  double patch_gap(const Eigen::VectorXd& a, const Eigen::VectorXd* b) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  FemModelOptions opt_;
  std::vector<std::uint8_t> fixed_node_;
  double time_ = 0, factor_ms_ = 0;
};

}  // namespace palplab::engine
