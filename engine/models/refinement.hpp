#pragma once
// Adaptive area-based refinement of a mass-spring surface, its two baselines, and the
// parameter identification of Eq 5.10–5.18.
//
// The coarse surface faces F0 (#F0 by 3, indices into the model's nodes; on a tet model these
// are the boundary faces, so only the surface refines) are the roots of quadtrees of red 1→4
// splits at edge midpoints. The current surface is generated from the trees: leaves, made
// 1-irregular (a leaf is split when a neighbour is two levels finer along a shared edge), then
// closed with green bisections (one hanging midpoint → 2 triangles, two → 3, three → a red
// split), so it is always conforming: no cracks, no T-junctions.
//
// Level and SLoD, per coarse face: l = depth to which its tree is complete, SLoD = how many
// quarters of the next level are split (ceil(4·fraction), 1..3; 4 when nothing is partial);
// time step h = h_coarse / 2^l_max (Eq 5.18). The refinement policy (which faces split) is the
// the original work's; the parameter identification is not Eq 5.10–5.17, which change the press
// force by 23–51 % and the patch mass x3 to x11.7 (measured): instead
//   masses and support: each coarse node's value q_v is split over its surface faces by area
//     (q_v A_f / A_v); a refined coarse face gathers its corners' shares and lumps them over its
//     leaf triangles by area — the patch's total mass is conserved exactly;
//   springs: a surface face carries the membrane share c_f A_f / |e|^2 of each of its edges
//     (van Gelder 1998, J. Graphics Tools 3(2): k_e = sum over the elements at e of E|el|/|e|^2);
//     a refined face moves that share from its coarse edges to its leaves' edges by the same
//     rule, which keeps the strain energy of any uniform in-plane strain exactly for 1->4 splits
//     (the children are similar to the parent) and to first order for the green closures;
//   volume (tet models, CoarseTets given): the new surface nodes get the volume stiffness of the
//     tets under them, by re-dividing those tets and applying van Gelder's rule to the parts —
//     a refined face's tet becomes the fan of sub-tets over its leaves and its apex (the leaf's
//     volume share c_f A_leaf = E V_sub on each of the sub-tet's six edges, so the membrane
//     share above is the in-face part of it), and every other tet at a split surface edge is
//     bisected at the nodes along that edge (the conforming edge bisection of tet meshes,
//     Rivara 1991, J. Comput. Appl. Math. 36:79–89), parts (p, q, c, d) with E V |pq| / |ab|;
//     a tet with several boundary faces or split edges shares its E V between them. The parts'
//     volumes sum to the tet's exactly; no constant per node. Without this the new nodes held
//     only membrane springs and their share of the support, and a press whose pad rests on
//     them was 39 % soft (C at the body, 2.5 N);
//   dent support (tet models): every new node m (the midpoint of its parents a, b) is tied to
//     its parents' mean by the half-space stiffness of its own hat mode, k_m = c E l / (1 - nu^2)
//     with l = |m a| (the hat's radius), E and nu of the tet owning m's root face, and
//     c = 0.5546 the stiffness of a cone-shaped dent of unit radius on the surface of a unit
//     half-space (E* = E / (1 - nu^2); from the Boussinesq kernel p^(q) = E* |q| w^(q) / 2,
//     integrated numerically: k = (E* / 4 pi) int q^2 W(q)^2 dq, W the Hankel transform of the
//     cone; tests/engine/test_refinement.cpp recomputes it and checks the quadrature on a
//     Gaussian's closed form). The energy (k_m / 2) |x_m - (x_a + x_b) / 2|^2 is zero for every
//     displacement that is linear over the coarse face (uniform strain, rigid motion: the handed-on
//     springs' energy stays exact) and gives the new nodes' dent modes the stiffness that van
//     Gelder's sub-tets lack: without it the refined press was softer the finer the refinement (C's
//     body, static disc pressure: -18.5 / -36.1 / -44.9 % at max_level 1 / 2 / 3). It is three
//     zero-rest-length springs, (m, a) and (m, b) with k_m / 2 and (a, b) with -k_m / 4 (the
//     identity |m - (a + b) / 2|^2 = |m - a|^2 / 2 + |m - b|^2 / 2 - |a - b|^2 / 4), whose
//     tangent k I is exact and positive semi-definite in sum; no damping;
//   damping: kd = beta ks on the new springs (stiffness-proportional Rayleigh damping).
// Simplify restores the coarse arrays bit for bit.
#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "engine/models/mass_spring.hpp"

namespace palplab::engine {

enum class RefinePolicy {
  area_based,    // split one-neighbourhood faces while their rest area > threshold_area
  conventional,  // split every one-neighbourhood face to `level`, regardless of area
  whole,         // split every face of the mesh to `level` (the "refined model")
};

struct RefineParams {
  RefinePolicy policy = RefinePolicy::area_based;
  double threshold_area = 1e-4;  // m^2 (area_based)
  int level = 1;                 // fixed level (conventional, whole)
  int max_level = 3;             // hard cap on the depth (area_based)
};

struct RefineTri {
  std::array<int, 3> v{};  // node indices, ccw seen from outside
  int child = -1;          // first of 4 consecutive children in tris, -1 = leaf
  int depth = 0;
  int root = 0;  // coarse face
};

// The adaptive model: the coarse system (kept untouched) and the current one.
struct AdaptiveMassSpring {
  MassSpringSystem coarse;        // rest state, coarse masses/springs/home springs
  RowMatX3i F0;                   // #F0 coarse surface faces
  Eigen::VectorXd face_membrane;  // #F0 membrane modulus c_f (N/m) of each coarse face
  // Tet models: the coarse tets that a refined surface re-divides (empty for a membrane).
  RowMatX4i tets;             // #T by 4 coarse tets
  Eigen::VectorXd tet_ev;     // #T: E_t V_t (N m), the numerator of van Gelder's rule
  Eigen::VectorXi face_tet;   // #F0 tet owning each coarse face
  Eigen::VectorXi face_apex;  // #F0 vertex of that tet opposite the face, -1 (membrane)
  Eigen::VectorXd tet_estar;  // #T: E / (1 - nu^2) (Pa), the dent support's modulus
  std::unordered_map<std::uint64_t, std::vector<int>> edge_tets;  // surface edge -> its tets
  Eigen::VectorXd face_area;                                      // #F0 rest areas (m^2)
  Eigen::VectorXd node_area;  // #coarse nodes: rest area of the coarse faces around it (m^2)
  Eigen::VectorXd coarse_surface_area;  // #coarse nodes: lumped surface area (A_v / 3) (m^2)
  std::unordered_map<std::uint64_t, int> coarse_spring;  // edge (a<b) -> coarse spring
  double beta = 0.0;       // s, Rayleigh stiffness-proportional damping of new springs
  double h_coarse = 1e-3;  // s

  // --- current state ---
  MassSpringSystem sys;         // coarse nodes first (same indices), then midpoints
  RowMatX3i F;                  // current conforming surface
  std::vector<RefineTri> tris;  // [0, #F0) are the roots
  std::unordered_map<std::uint64_t, int> midpoint;   // edge (a<b) -> midpoint node
  std::vector<std::array<int, 2>> midpoint_parents;  // per new node (index - coarse nodes)
  std::vector<int> midpoint_root;                    // per new node: the coarse face it split
  std::vector<int> node_level;          // per node: 0 coarse, d+1 for a midpoint of a depth-d split
  std::vector<std::uint8_t> mid_flag;   // per node: endpoint of an edge that has a midpoint
  std::vector<int> flagged;             // nodes with mid_flag set (to clear them cheaply)
  int level = 0;                        // deepest leaf
  double h = 1e-3;                      // current time step (Eq 5.18)
  long new_nodes = 0, new_springs = 0;  // new_springs includes the dent ties (3 per node)
  Eigen::VectorXd surface_area;  // #V(now): lumped area of the current surface (m^2), 0 inside

  long coarse_nodes() const { return coarse.nodes(); }
  long coarse_springs() const { return coarse.springs.size(); }
  bool refined() const { return new_nodes > 0; }
};

// Builds the adaptive model from a coarse system (positions at rest, adjacency not needed) and
// its surface faces F0 (#F0 by 3). face_membrane: #F0 membrane modulus c_f (N/m) — the share of
// the springs that each face holds (see above); beta: s, kd/ks of new springs; h_coarse: s.
// On a tet model, `tets` are the coarse tets (T, E_t per tet, the owning tet of each face of
// F0; face_membrane must then be boundary_membrane's): refinement re-divides the tets under the
// refined surface (see above). Without them the surface refines as a membrane.
struct CoarseTets {
  RowMatX4i T;               // #T by 4
  Eigen::VectorXd E;         // #T Young's moduli (Pa)
  Eigen::VectorXi face_tet;  // #F0 owning tet
  Eigen::VectorXd nu;        // #T Poisson's ratios (the dent support's modulus)
};
// The stiffness of a cone-shaped dent of unit radius on a half-space of unit E* (see above).
constexpr double kConeDentStiffness = 0.5546;
AdaptiveMassSpring make_adaptive(MassSpringSystem coarse, RowMatX3i F0,
                                 Eigen::VectorXd face_membrane, double beta, double h_coarse,
                                 const CoarseTets& tets = {});
// #F by 1 triangle areas of F over X (m^2).
Eigen::VectorXd mesh_face_areas(const RowMatX3d& X, const RowMatX3i& F);

// Refines around `node` (a node of the current surface) per `p`; returns true when the mesh
// changed. The current state (X, V) carries over; new nodes start at the midpoint of their
// parents' current positions and velocities. sys is rebuilt (sizes change, adjacency rebuilt).
bool refine_around(AdaptiveMassSpring& m, int node, const RefineParams& p);
// Refines every face to p.level (whole-model baseline).
bool refine_whole(AdaptiveMassSpring& m, int level);
// Back to the coarse mesh: masses, springs, home springs, time step restored exactly; coarse
// nodes keep their current position and velocity. Returns true when something was refined.
bool simplify(AdaptiveMassSpring& m);

// Per-coarse-face level and SLoD of the current trees (for tests and stats).
void level_and_slod(const AdaptiveMassSpring& m, int root, int* level, int* slod);

}  // namespace palplab::engine
