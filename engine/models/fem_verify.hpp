#pragma once
// The FEM verification suite behind `palplab fem verify` (issue 12): each case compares a
// computed value with an analytic (or independently computed) one. Meshes are generated in
// code (fem_block_mesh.hpp). The same functions back the unit tests in tests/fem.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace palplab::engine {

struct FemCheck {
  std::string name;      // e.g. "patch_test"
  std::string quantity;  // what `computed` / `analytic` are, with unit
  double computed = 0, analytic = 0;
  double rel_error = 0;  // the measure compared against tolerance (see `detail`)
  double tolerance = 0;
  double order = std::numeric_limits<double>::quiet_NaN();  // observed order, NaN if none
  bool pass = false;
  std::string detail;  // how rel_error is measured, extra numbers
};

struct FemVerifyOptions {
  // Cantilever refinement: elements through the thickness 1, 2, ..., 2^(levels-1). Linear
  // tets lock in bending: 4 levels (8 through the thickness, 20k dofs) are needed before the
  // observed order approaches 2.
  int cantilever_levels = 4;
};

FemCheck verify_patch_test();
FemCheck verify_uniaxial_displacement();  // u = F L / (E A)
FemCheck verify_uniaxial_poisson();       // lateral / axial strain = -nu
FemCheck verify_cantilever(int levels);   // tip deflection vs Euler-Bernoulli, observed order
FemCheck verify_stiffness_symmetry();     // K == K^T
FemCheck verify_rigid_modes();            // six zero eigenvalues before constraints
FemCheck verify_corotational_invariance();
FemCheck verify_corotational_small_strain();
FemCheck verify_corotational_tangent();  // exact tangent vs central differences of the forces
FemCheck verify_condensed_equals_full();
FemCheck verify_inverse_stiffness_contact();

std::vector<FemCheck> run_fem_verification(const FemVerifyOptions& opt = {});

}  // namespace palplab::engine
