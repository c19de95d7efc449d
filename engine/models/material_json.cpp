// The "material" member of a deformable model's "model" object (docs/FORMATS.md): a tissue name
// of the table, or {"tissue", "youngs_modulus", "density"}. Shared by every deformable model kind.
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
        c.number(*mat, Q, "youngs_modulus", false, 0, 1e11, "Young's modulus E (Pa)", true);
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

}  // namespace palplab::engine
