// The members every deformable model kind reads the same way (docs/FORMATS.md): "material" (a
// tissue name of the table, or {"tissue", "youngs_modulus", "density"}) and the support
// ("support_modulus", "fixed_z_below", "fixed_region").
#include <algorithm>
#include <nlohmann/json.hpp>

#include "common/json_check.hpp"
#include "engine/mesh/materials.hpp"
#include "engine/models/model.hpp"

namespace palplab::engine {

void read_material(json::Checker& c, const nlohmann::json& m, const std::string& P,
                   MaterialConfig& mc) {
  const nlohmann::json* mat = c.member(m, P, "material", false, "a tissue name or an object");
  if (!mat) return;
  const std::string Q = P + ".material";
  if (mat->is_string()) {
    mc.tissue = mat->get<std::string>();
  } else if (mat->is_object()) {
    c.keys(*mat, Q, {"tissue", "youngs_modulus", "density"});
    mc.tissue = c.text(*mat, Q, "tissue", false).value_or("");
    mc.youngs_modulus =
        c.number(*mat, Q, "youngs_modulus", false, 1, 1e11, "Young's modulus E (Pa)");
    mc.density = c.number(*mat, Q, "density", false, 0, 1e5, "the density (kg/m^3)", true);
  } else {
    c.err(Q, std::string("expected a tissue name or an object, got ") + json::kind_name(*mat));
  }
  if (mc.tissue.empty()) return;
  std::string names;
  bool known = false;
  for (const auto& e : mesh::default_materials().materials) {
    known |= e.name == mc.tissue;
    names += (names.empty() ? "" : ", ") + e.name;
  }
  if (!known) c.err(Q, "unknown tissue \"" + mc.tissue + "\" (expected one of: " + names + ")");
}

void read_support(json::Checker& c, const nlohmann::json& m, const std::string& P,
                  SupportConfig& sp, const std::vector<std::string>& regions) {
  sp.modulus = c.number(m, P, "support_modulus", false, 0, 1e9,
                        "the elastic foundation under the surface (N/m^3)")
                   .value_or(sp.modulus);
  sp.fixed_z_below = c.number(m, P, "fixed_z_below", false, 0, 10,
                              "the height above the mesh's lowest point below which nodes are "
                              "pinned (m)")
                         .value_or(sp.fixed_z_below);
  if (auto fr = c.text(m, P, "fixed_region", false)) {
    if (std::find(regions.begin(), regions.end(), *fr) == regions.end())
      c.err(P + ".fixed_region",
            "unknown region \"" + *fr + "\" of the mesh" + json::did_you_mean(*fr, regions));
    else
      sp.fixed_region = *fr;
  }
}

}  // namespace palplab::engine
