#include "engine/models/tet_mesh_checks.hpp"

#include <filesystem>

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

}  // namespace palplab::engine
