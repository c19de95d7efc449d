#include "engine/models/tet_mesh_checks.hpp"

#include <filesystem>

#include "common/input_error.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::engine {

std::string tet_problem_file(const SceneConfig& cfg, std::string* where) {
  if (cfg.mesh.file.empty()) {
    *where = "mesh " + cfg.mesh.key() + ": ";
    return cfg.source;
  }
  where->clear();
  const std::filesystem::path fp(cfg.mesh.file);
  if (fp.extension() == ".node" || fp.extension() == ".ele")
    return std::filesystem::path(fp).replace_extension(".ele").string();
  return cfg.mesh.file;
}

void check_tet_attributes(const SceneConfig& cfg, const SceneMesh& cm, bool named_tissue_covers) {
  if (!cm.tet || (named_tissue_covers && !cfg.material.tissue.empty())) return;
  const mesh::MaterialTable& table = mesh::default_materials();
  for (long t = 0; t < cm.tet_attribute.size(); ++t)
    if (!table.find(cm.tet_attribute[t])) {
      std::string where;
      const std::string file = tet_problem_file(cfg, &where);
      throw InputError(
          where + "tet " + std::to_string(t) + " (in file order from 0) has attribute " +
              std::to_string(cm.tet_attribute[t]) +
              " (tissue type) which the material table does not cover (`palplab "
              "mesh materials` lists it; " +
              (named_tissue_covers
                   ? std::string("name a \"tissue\" in the model's \"material\" "
                                 "for the whole body, or give the tets a listed "
                                 "attribute)")
                   : std::string("give the tets a listed attribute: model \"" + cfg.model +
                                 "\" takes each tet's tissue from it, a named "
                                 "\"tissue\" replacing only its soft ones)")),
          file);
    }
}

void check_tet_connectivity(const SceneConfig& cfg, const SceneMesh& cm) {
  if (!cm.tet) return;
  std::string where;
  const std::string file = tet_problem_file(cfg, &where);
  auto nodes_of = [&](long t) {
    std::string s;
    for (int k = 0; k < 4; ++k) {
      if (k) s += ' ';
      s += std::to_string(cm.model_T(t, k));
    }
    return s;
  };
  const mesh::TetConnectivity c = mesh::tet_connectivity(cm.model_T, cm.model_V.rows());
  // The first defect in file order is said (a tet's before a node's).
  const int bad_tet = c.repeated_node.empty() ? -1 : c.repeated_node.front();
  const int dup_tet = c.duplicate_tet.empty() ? -1 : c.duplicate_tet.front().second;
  if (bad_tet >= 0 && (dup_tet < 0 || bad_tet <= dup_tet))
    throw InputError(where + "tet " + std::to_string(bad_tet) + " (in file order from 0; nodes " +
                         nodes_of(bad_tet) +
                         ") names a node twice: a tet needs four distinct nodes (`palplab "
                         "mesh check` lists the degenerate tets)",
                     file);
  if (dup_tet >= 0)
    throw InputError(where + "tet " + std::to_string(dup_tet) + " (in file order from 0; nodes " +
                         nodes_of(dup_tet) + ") repeats tet " +
                         std::to_string(c.duplicate_tet.front().first) +
                         ": a tet given twice counts its mass and stiffness twice (remove "
                         "the line; `palplab mesh check` lists every duplicate_tet)",
                     file);
  if (!c.unused_vertex.empty()) {
    std::string node_file = file;
    if (const std::filesystem::path fp(file); fp.extension() == ".ele")
      node_file = std::filesystem::path(fp).replace_extension(".node").string();
    throw InputError(where + "node " + std::to_string(c.unused_vertex.front()) +
                         " (in file order from 0) belongs to no tet: it would have no mass and "
                         "no stiffness (remove it, or mesh it; `palplab mesh check` lists every "
                         "unused_vertex)",
                     node_file);
  }
}

}  // namespace palplab::engine
