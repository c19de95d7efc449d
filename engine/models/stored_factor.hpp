#pragma once
// A FemModel's precomputation in a .psim file (issue 16, engine/haptics/scene_file.hpp), for the
// linear formulation with lumped mass: the solved dofs, the stiffness K_c on them (support
// included), the lumped masses and the sparse LDL^T factorisation of the step matrix
// A = (1 + h alpha) M + (h beta + h^2) K_c (its L, D and fill-reducing permutation as an
// LdltFactor, engine/solvers/ldlt_factor.hpp), tagged with a SHA-256 digest of everything the model
// was built from (nodes, tets, per-tet materials, fixed nodes, every option). A model built from
// the same inputs restores them instead of assembling and factorising (and skips the checks the
// stored model passed), so it steps bit-identically; any difference and the blob is ignored.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/mesh/tet_mesh.hpp"
#include "engine/solvers/fem_assembly.hpp"
#include "engine/solvers/fem_static.hpp"
#include "engine/solvers/ldlt_factor.hpp"

namespace palplab::engine {

struct FemModelOptions;
using FemInputsDigest = std::array<std::uint8_t, 32>;

// Digest of a FemModel's constructor arguments (options.precomputed excluded).
FemInputsDigest fem_inputs_digest(const mesh::TetMesh& mesh, const TetMaterials& materials,
                                  const std::vector<std::uint8_t>& fixed_node,
                                  const FemModelOptions& options);

struct StoredLinearFem {
  std::vector<int> act;      // solved dofs (ascending global dof indices)
  SparseMatrixd K_c;         // stiffness on act (N/m)
  Eigen::VectorXd m_lumped;  // 3#V lumped mass (kg)
  double h = 0;              // s, the step size of the factorisation
};

// The linear model's precomputation made from inputs `d`, as bytes.
std::string save_linear_fem(const FemInputsDigest& d, const std::vector<int>& act,
                            const SparseMatrixd& K_c, const Eigen::VectorXd& m_lumped,
                            const LdltFactor& factor, double h);

// An LdltFactor as bytes appended to s (L compressed column, D, P, P^-1), and read back from
// blob at `at` (advanced past it) for a factor of n rows: false (f untouched) when malformed
// (sizes, index ranges, a permutation that is not one, L not strictly lower, a zero in D). The
// one serialisation of a factorisation, shared by the FEM blob and the mass-spring far field
// (engine/solvers/far_field.hpp).
void put_ldlt_factor(std::string& s, const LdltFactor& f);
bool get_ldlt_factor(const std::string& blob, std::size_t& at, long n, LdltFactor& f);

// Restores `out` and factor from `blob` when it was made from inputs `d` for a model of
// `total_dofs` (3#V); false (factor untouched) otherwise, including for a malformed blob.
bool load_linear_fem(const std::string& blob, const FemInputsDigest& d, long total_dofs,
                     StoredLinearFem& out, LdltFactor& factor);

}  // namespace palplab::engine
