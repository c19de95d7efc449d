#pragma once
// Mass-spring (Voigt) model data and forces, Eq 5.3 of the original work, plus damped
// zero-rest-length home springs (Eq 4.11). Everything is a plain array so any function can be
// tested on 2 nodes.
//
//   X, V      #V by 3 positions (m) and velocities (m/s)
//   X_rest    #V by 3 rest positions (m); also the anchors of the home springs
//   mass      #V node masses (kg)
//   springs   #S springs: E #S by 2 node indices, rest #S lengths (m), ks #S stiffness (N/m),
//             kd #S damping (N s/m)
//   home_ks   #V home-spring stiffness (N/m), 0 = none; home_kd #V home damping (N s/m)
//   fixed     #V 1 = node never moves (boundary condition)
//   F_ext     #V by 3 external forces (N), e.g. the contact force
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "engine/mesh/types.hpp"
#include "engine/mesh/unique_edges.hpp"

namespace palplab::engine {

// The mesh toolkit's array types (engine/mesh/types.hpp) under the engine's names.
using RowMatX3d = mesh::Positions;
using RowMatX3i = mesh::Faces;
using RowMatX4i = mesh::Tets;
using RowMatX2i = mesh::Edges;

struct Springs {
  RowMatX2i E;           // #S by 2 node indices
  Eigen::VectorXd rest;  // #S rest lengths (m)
  Eigen::VectorXd ks;    // #S stiffness (N/m)
  Eigen::VectorXd kd;    // #S damping (N s/m)
  long size() const { return E.rows(); }
};

struct MassSpringSystem {
  RowMatX3d X, V, X_rest, F_ext;
  Eigen::VectorXd mass, home_ks, home_kd;
  std::vector<std::uint8_t> fixed;
  Springs springs;
  // Contact with the haptic device's probe, a flat pad of finite size (so the press stiffness
  // converges as the mesh is refined: a point load on a continuum does not). The pad passes
  // through contact_point with outward normal n = contact_normal; node contact_nodes[k]
  // penetrates it by
  //   d_k = (X_k - contact_point) . n - max(0, (X_rest_k - X_rest_c) . n),   c = contact_node:
  // a flat face on convex tissue, which yields (like a fingertip's pulp) to nodes that stand
  // above the centre's rest tangent plane in a concave spot, so that no pad node is already
  // deep when the contact engages and the force grows continuously from 0. While d_k > 0 the
  // node gets the penalty force -contact_k w_k d_k n, with w_k = contact_weights[k] its share of
  // the pad (lumped surface area, the weights sum to 1). The device feels the sum,
  // contact_k * sum_k w_k d_k+. The Jacobian blocks -contact_k w_k n n^T enter backward Euler,
  // so a stiff coupling stays stable. contact_node = -1: no contact.
  // A pad blended from several centres (the contact point inside a face: the three vertex pads
  // weighted by its barycentric weights, so the force is continuous from node to node) lists a
  // node once per centre, with that centre in contact_refs[k] in place of c above.
  int contact_node = -1;           // the centre node of the contact
  std::vector<int> contact_nodes;  // the patch (contains contact_node); a node may repeat
  std::vector<double> contact_weights;
  std::vector<int> contact_refs;  // per entry its pad's centre; empty = contact_node for all
  // Per entry its rest offset o_k (m) in place of max(0, above): d_k = flat_k - o_k (the disc
  // pad of engine/models/contact_pad.hpp); empty = the centre-plane rule above.
  std::vector<double> contact_offsets;
  Eigen::Vector3d contact_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d contact_normal = Eigen::Vector3d::UnitZ();
  double contact_k = 0.0;  // N/m, total coupling stiffness of the probe face
  // Incident springs per node (CSR): springs of node i are adj_spring[adj_start[i] ..
  // adj_start[i+1]). Built by build_adjacency(); needed by sleeping and the solvers.
  std::vector<int> adj_start, adj_spring;
  long nodes() const { return X.rows(); }
};

// Force on node 1 of one Voigt spring (Eq 5.3); the force on node 2 is its negative.
//   F1 = -[ks(|du| - l) + kd (dv . du)/|du|] du/|du|,  du = x1 - x2, dv = v1 - v2.
// A zero-length spring (x1 == x2) exerts no force (its direction is undefined).
Eigen::Vector3d spring_force(const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                             const Eigen::Vector3d& v1, const Eigen::Vector3d& v2, double ks,
                             double kd, double rest);

// How the spring Jacobian treats a compressed spring. Its lateral stiffness ks(1 - l/|du|) is
// negative under compression (buckling), which can make M - hD - h^2 K indefinite and CG fail.
//   definite: drop the negative lateral part (Choi & Ko 2002): -Kx stays positive semi-definite,
//             the step is a modified (not exact) linearisation; it changes h^2 K only for
//             compressed springs and only in the two directions across the spring.
//   exact:    the true derivative (use with an LDLT solver; CG may stop on an indefinite A).
enum class SpringJacobian { definite, exact };

// Force on node 1 (f1) and the 3x3 Jacobian blocks of one spring w.r.t. node 1: Kx = dF1/dx1 of
// the elastic part and Kv = dF1/dv1 (exact). dF1/dx2 = -Kx, dF1/dv2 = -Kv, dF2 = -dF1. The
// position derivative of the damping term is left out (Baraff & Witkin 1998; it vanishes when
// dv = 0 and makes the system matrix unsymmetric). This is THE spring evaluation: the force
// sums and the backward-Euler assembly both call it, and the finite-difference tests test it.
void spring_eval(const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, const Eigen::Vector3d& v1,
                 const Eigen::Vector3d& v2, double ks, double kd, double rest, SpringJacobian jac,
                 Eigen::Vector3d& f1, Eigen::Matrix3d& Kx, Eigen::Matrix3d& Kv);

// spring_eval in factored form, which spring_eval itself expands: with P = d d^T,
//   Kx = -(axial P + lateral (I - P)),  Kv = -kd P,
// d the unit vector along x1 - x2, axial = ks (N/m), lateral = ks (1 - l/|du|) (clamped at 0 for
// `definite`). Every block of the spring is a rank-one update of a multiple of I, so the
// backward-Euler solver can keep 5 numbers per spring instead of a 3x3 block. A zero-length
// spring has f1 = 0 and all coefficients 0 (d = 0).
struct SpringTangent {
  Eigen::Vector3d f1, d;  // N; unit direction
  double axial = 0.0, lateral = 0.0, kd = 0.0;
};
void spring_tangent(const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, const Eigen::Vector3d& v1,
                    const Eigen::Vector3d& v2, double ks, double kd, double rest,
                    SpringJacobian jac, SpringTangent& t);

// The lateral coefficient ks (1 - rest/|du|), given rest/|du| (callers keep their own rounding
// of it). Under `definite` a compressed spring's negative value is clamped at 0, except for a
// zero-rest-length spring (the refinement's dent ties, refinement.hpp; ks may be negative
// there), whose tangent ks I is exact. spring_tangent and the integrators' fused spring pass
// both use it.
inline double spring_lateral(double ks, double rest, double rest_over_length, SpringJacobian jac) {
  const double lateral = ks * (1.0 - rest_over_length);
  return jac == SpringJacobian::definite && rest > 0.0 && lateral < 0.0 ? 0.0 : lateral;
}

// Rebuilds sys.adj_start / adj_spring from sys.springs.E.
void build_adjacency(MassSpringSystem& sys);

// F (#V by 3) = spring forces + home-spring forces + F_ext, at state (X, V). Only rows of
// `nodes` are written (all nodes if `nodes` is null); springs listed in `springs` (all if null)
// are summed, so a caller integrating a sub-set passes the springs touching it.
void compute_forces(const MassSpringSystem& sys, const RowMatX3d& X, const RowMatX3d& V,
                    RowMatX3d& F, const std::vector<int>* nodes = nullptr,
                    const std::vector<int>* springs = nullptr);

// Springs on `edges` (e.g. mesh::unique_edges of a triangle or tet mesh), rest lengths from X
// (m), uniform ks, kd.
Springs springs_from_edges(const RowMatX3d& X, const RowMatX2i& edges, double ks, double kd);
// The mesh toolkit's edge extraction (engine/mesh/unique_edges.hpp) under the engine's name.
using mesh::unique_edges;

double total_mass(const MassSpringSystem& sys);

// Penetration of node contact_nodes[k] below the probe face (m, 0 when it does not touch).
double contact_node_penetration(const MassSpringSystem& sys, const RowMatX3d& X, size_t k);
// The probe's weighted penetration sum_k w_k d_k+ (m): the device force is contact_k times this.
// 0 without contact.
double contact_penetration(const MassSpringSystem& sys, const RowMatX3d& X);

}  // namespace palplab::engine
