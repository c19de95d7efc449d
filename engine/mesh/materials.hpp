#pragma once
// Tissue types and materials. A tet's integer attribute names its tissue type:
// 0-99 undefined, 100 skin, 101 soft tissue, 102 veins, 103 arteries, 104 nerves, 105 lung,
// 106 heart, 107 membrane, 200-299 bones (rigid), 300-399 muscles. Each type carries Young's
// modulus E (Pa), Poisson ratio nu, density (kg/m^3) and a display colour (RGB in [0, 1]).
// The table is JSON (engine/mesh/materials.json is the default, also compiled in), so a study
// can edit the values without rebuilding.
#include <array>
#include <string>
#include <vector>

namespace palplab::mesh {

// Needle-insertion parameters of a tissue (issue 16; engine/models/needle.hpp uses them).
// Model form after Okamura, Simone & O'Leary 2004: before puncture the tissue boundary deflects
// like a spring (puncture_stiffness) until the force reaches puncture_force; after puncture the
// tip cuts with a constant cutting_force while it advances into fresh tissue, and the shaft
// feels friction proportional to the length inside the tissue. For a rigid tissue (bone) only
// puncture_stiffness is used: the contact stiffness of the unpunctured bone surface.
struct NeedleParams {
  bool defined = false;           // false: the entry has no "needle" object
  double puncture_force = 0;      // N, > 0 (unused for rigid tissue)
  double puncture_stiffness = 0;  // N/m, > 0
  double cutting_force = 0;       // N, >= 0
  double friction = 0;            // N/m: shaft friction per metre of shaft in the tissue, >= 0
  std::string source;             // where the values come from
};

struct Material {
  int first = 0, last = 0;  // attribute range [first, last] this entry covers
  std::string name;
  double youngs_modulus = 0;  // Pa
  double poisson_ratio = 0;   // in (-1, 0.5)
  double density = 0;         // kg/m^3
  std::array<double, 3> colour{0.5, 0.5, 0.5};
  bool rigid = false;
  NeedleParams needle;  // optional JSON object "needle"
};

struct MaterialTable {
  std::vector<Material> materials;  // non-overlapping ranges
  std::string source;               // where it was read from (file, "<built-in materials>")
  // The entry covering attribute a, or nullptr.
  const Material* find(int attribute) const;
  // The attributes defined, for messages: "0-99 undefined, 100 skin, ..." ("no tissue at all
  // (the \"materials\" array is empty)" for an empty table).
  std::string describe() const;
};

// The compiled-in default table (same content as engine/mesh/materials.json).
const MaterialTable& default_materials();
const std::string& default_materials_json();
// Parses a table; `source` names the file in errors (JSON paths like $.materials[2].density).
MaterialTable parse_materials(const std::string& json_text, const std::string& source);
MaterialTable read_materials(const std::string& path);
std::string materials_to_json(const MaterialTable& t);

}  // namespace palplab::mesh
