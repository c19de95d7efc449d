#pragma once
// The accuracy reference of issue 12 (core of `palplab fem reference`): the static response of
// one press on a sequence of uniformly refined tet meshes of the same closed surface (TetGen,
// maximum tet volume halved per level, so h shrinks by 2^(1/3)), with the Richardson-
// extrapolated contact stiffness and displacement field and the estimated discretisation error
// of each level.
//
// The press is a pressure of total force `force` (N) along `press_direction` (unit, into the
// body) with the smooth profile (1 - (r/a)^2)^2 over the boundary within a = press_radius (m)
// of press_point, applied as the consistent load (integrated with 16 points per face): a finite
// patch, because the displacement under a point load does not converge in 3D, and smooth, so
// the load functional is the same on every level. The contact
// displacement of a level is the work-conjugate f . u / force (m), the contact stiffness
// force / displacement (N/m).
//
// The input surface vertices keep their indices at every level (tetrahedralize() appends Steiner
// points), so the displacement field is compared and extrapolated at those vertices.
#include <functional>
#include <vector>

#include "engine/mesh/materials.hpp"
#include "engine/mesh/surface_mesh.hpp"
#include "engine/mesh/tetrahedralize.hpp"

namespace palplab::engine {

struct FemReferenceOptions {
  mesh::SurfaceMesh surface;            // closed surface of the body (m)
  std::vector<mesh::RegionSeed> seeds;  // tissue regions (attributes); empty = default_attribute
  int default_attribute = 101;          // soft tissue
  mesh::MaterialTable materials = mesh::default_materials();
  std::function<bool(const Eigen::Vector3d&)> is_fixed;  // pinned nodes (by rest position)
  Eigen::Vector3d press_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d press_direction = -Eigen::Vector3d::UnitZ();
  double force = 1.0;          // N
  double press_radius = 0.01;  // m
  // Elastic foundation (N/m^3) on the whole boundary surface, lumped per node (a third of the
  // area of its boundary faces, all three directions): the support of prototypes C and D.
  double support_modulus = 0;
  double max_volume = 0;  // level-0 maximum tet volume (m^3), > 0
  double quality = 2.0;   // TetGen radius-edge bound at every level
  int levels = 3;         // >= 3 for an extrapolation
  // Optional: the mesh of each level instead of TetGen (e.g. structured blocks refined by 2);
  // refinement_ratio is then the ratio of mesh sizes between levels. The default (TetGen,
  // max volume halved) has the nominal ratio 2^(1/3). With a mesher the displacement field is
  // not extrapolated (node numbering is the mesher's; `field` stays empty).
  std::function<mesh::TetMesh(int level)> mesher;
  double refinement_ratio = 0;  // 0 = 2^(1/3)
};

struct FemReferenceLevel {
  double max_volume = 0;  // m^3
  long nodes = 0, tets = 0, dofs = 0;
  double patch_area = 0;    // m^2, boundary faces touching the loaded vertices
  double displacement = 0;  // m
  double stiffness = 0;     // N/m
  double est_error = 0;     // |stiffness - extrapolated| / extrapolated
  double field_error = 0;   // max over surface vertices |u - u_extrapolated| / max |u_extrapolated|
  double mesh_size = 0;     // (volume / #tets)^(1/3) (m)
  double solve_ms = 0;
};

struct FemReferenceResult {
  std::vector<FemReferenceLevel> levels;
  double observed_order = 0;  // in h (refinement ratio 2^(1/3) per level), from the last three
  double stiffness = 0;       // extrapolated (N/m)
  double displacement = 0;    // extrapolated (m)
  mesh::Positions field;      // #surface vertices by 3: extrapolated displacement (m)
  bool monotone = false;      // est_error strictly decreasing over the levels
  // observed_order within [0.5, 4] (linear elements: 2 for smooth problems, less with corner
  // singularities). Outside it the levels are not in the asymptotic range or their sizes are
  // not what was assumed, and the extrapolation should not be trusted.
  bool order_plausible = false;
};

// Richardson extrapolation from three values on meshes refined by ratio r: the observed order
// p = ln((q0 - q1)/(q1 - q2)) / ln r and q = q2 + (q2 - q1)/(r^p - 1). Returns false (and the
// finest value) when the differences do not shrink monotonically.
bool richardson(double q0, double q1, double q2, double r, double& order, double& extrapolated);

// Caveat (measured, tests/fem): TetGen levels are not nested and their size ratio is only
// nominal, so on coarse unstructured meshes the differences between levels can fail to shrink;
// then observed_order is NaN, `monotone` is false and the finest level is reported unextrapolated.
// On nested structured refinements the estimate is monotone with a clean order.
// With TetGen levels the mesh size of a level is measured, h = (volume / #tets)^(1/3), and the
// extrapolation uses those sizes (richardson_sizes), not the nominal ratio.
// The same for arbitrary mesh sizes h0 > h1 > h2: q(h) = q + C h^p through the three points
// (p by bisection in [0.05, 12]). Reduces to richardson() for a constant ratio.
bool richardson_sizes(const double q[3], const double h[3], double& order, double& extrapolated);

// Options for the press of node `press_node` of an existing tet mesh (a prototype's): the
// surface is the mesh's outer boundary, every tet gets the mesh's most common attribute (a
// single-tissue body such as Model-C; multi-tissue bodies need seeds), level 0 uses the mesh's
// mean tet volume as max volume, the press direction is the inward area-weighted normal at the
// node. The caller still sets is_fixed (e.g. the prototype's pinned region) and may edit the rest.
FemReferenceOptions reference_options_from_mesh(const mesh::TetMesh& m, int press_node,
                                                double force, double press_radius);

// Throws InputError for bad options (no fixed node, empty patch, levels < 3, ...).
FemReferenceResult fem_reference(const FemReferenceOptions& opt);

}  // namespace palplab::engine
