#pragma once
// Checks of a prepared tet mesh that a model needs before it can be built, said before anything
// runs: `validate` and `run` make them through prototypes::inspect_prototype (ModelKind's
// check_mesh), and the models' make() through the same functions, so that what passes the one
// is what the other builds. A problem of a tet is said at the mesh file that holds the tets (a
// TetGen mesh's .ele), else at the prototype with its generator.
#include <string>

#include "engine/models/model.hpp"

namespace palplab::engine {

// Where a tet's problem is said: the file (out), and a prefix naming a generated mesh ("mesh
// generator model_c: ", empty for a file).
std::string tet_problem_file(const SceneConfig& cfg, std::string* where);

// Every tet's tissue attribute must be in the material table (default_materials()): a tet of an
// attribute it does not cover has no stiffness and no mass (a mass-spring body of 0 kg ran).
// Skipped when the prototype names one tissue for the whole body and `named_tissue_covers`.
void check_tet_attributes(const SceneConfig& cfg, const SceneMesh& cm, bool named_tissue_covers);

// Every tet names four distinct nodes, no two tets the same four (a tet given twice counts its
// mass and stiffness twice: a FEM press 3.6x deeper), and every node belongs to a tet (one that
// does not has no mass and no stiffness: the FEM said "stiffness factorisation failed (pin the
// body ...)" although it was pinned). Review 2026-12-07.
void check_tet_connectivity(const SceneConfig& cfg, const SceneMesh& cm);

}  // namespace palplab::engine
