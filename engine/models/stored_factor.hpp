#pragma once
// A FemModel's precomputation in a .psim file (issue 16, engine/haptics/scene_file.hpp): the
// sparse LDL^T factorisation of the linear model's step matrix A = (1 + h alpha) M +
// (h beta + h^2) K (its L, D and fill-reducing permutation, exactly as Eigen computed them), tagged
// with a SHA-256 digest of everything the model was built from (nodes, tets, per-tet materials,
// fixed nodes, every option) and the step size. A model built from the same inputs restores it
// instead of factorising (and skips the singularity check the stored model passed), so it steps
// bit-identically; any difference and the blob is ignored (everything is recomputed).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/mesh/tet_mesh.hpp"
#include "engine/solvers/fem_assembly.hpp"
#include "engine/solvers/fem_static.hpp"

namespace palplab::engine {

struct FemModelOptions;
using FemInputsDigest = std::array<std::uint8_t, 32>;

// Digest of a FemModel's constructor arguments (options.precomputed excluded).
FemInputsDigest fem_inputs_digest(const mesh::TetMesh& mesh, const TetMaterials& materials,
                                  const std::vector<std::uint8_t>& fixed_node,
                                  const FemModelOptions& options);

// The factorisation `ldlt` of step size h made from inputs `d`, as bytes.
std::string save_fem_factor(const FemInputsDigest& d, const SparseLdlt& ldlt, double h);

// Restores ldlt and h from `blob` when it was made from inputs `d` and has `dofs` unknowns;
// false (ldlt untouched) otherwise, including for a malformed blob.
bool load_fem_factor(const std::string& blob, const FemInputsDigest& d, std::size_t dofs,
                     SparseLdlt& ldlt, double& h);

}  // namespace palplab::engine
