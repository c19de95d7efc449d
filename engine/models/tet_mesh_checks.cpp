#include "engine/models/tet_mesh_checks.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <map>
#include <vector>

#include "common/input_error.hpp"
#include "engine/mesh/materials.hpp"

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
  std::map<std::array<int, 4>, long> first;
  std::vector<char> used(static_cast<std::size_t>(cm.model_V.rows()), 0);
  for (long t = 0; t < cm.model_T.rows(); ++t) {
    std::array<int, 4> key{cm.model_T(t, 0), cm.model_T(t, 1), cm.model_T(t, 2), cm.model_T(t, 3)};
    for (int v : key) used[static_cast<std::size_t>(v)] = 1;
    std::sort(key.begin(), key.end());
    if (std::adjacent_find(key.begin(), key.end()) != key.end())
      throw InputError(where + "tet " + std::to_string(t) + " (in file order from 0; nodes " +
                           nodes_of(t) +
                           ") names a node twice: a tet needs four distinct nodes (`palplab "
                           "mesh check` lists the degenerate tets)",
                       file);
    if (const auto [it, fresh] = first.emplace(key, t); !fresh)
      throw InputError(where + "tet " + std::to_string(t) + " (in file order from 0; nodes " +
                           nodes_of(t) + ") repeats tet " + std::to_string(it->second) +
                           ": a tet given twice counts its mass and stiffness twice (remove "
                           "the line; `palplab mesh check` lists every duplicate_tet)",
                       file);
  }
  for (long v = 0; v < cm.model_V.rows(); ++v)
    if (!used[static_cast<std::size_t>(v)]) {
      std::string node_file = file;
      if (const std::filesystem::path fp(file); fp.extension() == ".ele")
        node_file = std::filesystem::path(fp).replace_extension(".node").string();
      throw InputError(where + "node " + std::to_string(v) +
                           " (in file order from 0) belongs to no tet: it would have no mass and "
                           "no stiffness (remove it, or mesh it; `palplab mesh check` lists every "
                           "unused_vertex)",
                       node_file);
    }
}

}  // namespace palplab::engine
