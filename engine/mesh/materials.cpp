#include "engine/mesh/materials.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/input_error.hpp"
#include "common/json_locate.hpp"
#include "common/read_file.hpp"

namespace palplab::mesh {

const Material* MaterialTable::find(int a) const {
  for (const Material& m : materials)
    if (a >= m.first && a <= m.last) return &m;
  return nullptr;
}

std::string MaterialTable::describe() const {
  if (materials.empty()) return "no tissue at all (the \"materials\" array is empty)";
  std::vector<const Material*> sorted;
  for (const Material& m : materials) sorted.push_back(&m);
  std::sort(sorted.begin(), sorted.end(),
            [](const Material* a, const Material* b) { return a->first < b->first; });
  std::string s;
  for (const Material* m : sorted) {
    if (!s.empty()) s += ", ";
    s += std::to_string(m->first);
    if (m->last != m->first) s += "-" + std::to_string(m->last);
    s += " " + m->name;
  }
  return s;
}

const std::string& default_materials_json() {
  // Keep identical to engine/mesh/materials.json (a test compares them).
  static const std::string s = R"JSON({
  "format": "palplab-materials",
  "version": 1,
  "note": "Order-of-magnitude defaults for soft-tissue simulation; E in Pa, density in kg/m^3. Edit for your study.",
  "needle_note": "needle: puncture_force N, puncture_stiffness N/m, cutting_force N, friction N/m of shaft in the tissue. Model form (spring until puncture, constant cutting force, shaft friction) after Okamura, Simone & O'Leary 2004, IEEE Trans Biomed Eng 51(10):1707-1716; magnitudes are palplab estimates chosen inside the ranges surveyed by Abolhassani, Patel & Moallem 2007, Med Eng Phys 29(4):413-431, not values copied from a table of either paper: calibrate them for a study.",
  "materials": [
    {"first": 0, "last": 99, "name": "undefined", "youngs_modulus": 10000.0, "poisson_ratio": 0.45, "density": 1000.0, "colour": [0.7, 0.7, 0.7], "rigid": false, "needle": {"puncture_force": 0.5, "puncture_stiffness": 200.0, "cutting_force": 0.2, "friction": 10.0, "source": "palplab estimate (generic soft tissue)"}},
    {"first": 100, "last": 100, "name": "skin", "youngs_modulus": 150000.0, "poisson_ratio": 0.48, "density": 1100.0, "colour": [0.94, 0.76, 0.64], "rigid": false, "needle": {"puncture_force": 1.5, "puncture_stiffness": 300.0, "cutting_force": 0.4, "friction": 30.0, "source": "palplab estimate of the order of the skin puncture forces surveyed by Abolhassani et al. 2007 (figure not taken from a table)"}},
    {"first": 101, "last": 101, "name": "soft tissue", "youngs_modulus": 10000.0, "poisson_ratio": 0.45, "density": 1000.0, "colour": [0.9, 0.55, 0.55], "rigid": false, "needle": {"puncture_force": 0.3, "puncture_stiffness": 150.0, "cutting_force": 0.1, "friction": 10.0, "source": "palplab estimate (fat punctures far more easily than skin; cf. Abolhassani et al. 2007)"}},
    {"first": 102, "last": 102, "name": "veins", "youngs_modulus": 500000.0, "poisson_ratio": 0.45, "density": 1060.0, "colour": [0.25, 0.3, 0.8], "rigid": false, "needle": {"puncture_force": 0.5, "puncture_stiffness": 300.0, "cutting_force": 0.1, "friction": 10.0, "source": "palplab estimate"}},
    {"first": 103, "last": 103, "name": "arteries", "youngs_modulus": 1000000.0, "poisson_ratio": 0.45, "density": 1060.0, "colour": [0.85, 0.1, 0.1], "rigid": false, "needle": {"puncture_force": 0.8, "puncture_stiffness": 400.0, "cutting_force": 0.15, "friction": 10.0, "source": "palplab estimate"}},
    {"first": 104, "last": 104, "name": "nerves", "youngs_modulus": 500000.0, "poisson_ratio": 0.45, "density": 1040.0, "colour": [0.95, 0.9, 0.3], "rigid": false, "needle": {"puncture_force": 0.6, "puncture_stiffness": 300.0, "cutting_force": 0.15, "friction": 10.0, "source": "palplab estimate"}},
    {"first": 105, "last": 105, "name": "lung", "youngs_modulus": 3000.0, "poisson_ratio": 0.3, "density": 300.0, "colour": [0.95, 0.7, 0.75], "rigid": false, "needle": {"puncture_force": 0.3, "puncture_stiffness": 100.0, "cutting_force": 0.05, "friction": 5.0, "source": "palplab estimate"}},
    {"first": 106, "last": 106, "name": "heart", "youngs_modulus": 100000.0, "poisson_ratio": 0.45, "density": 1060.0, "colour": [0.6, 0.1, 0.15], "rigid": false, "needle": {"puncture_force": 1.0, "puncture_stiffness": 300.0, "cutting_force": 0.3, "friction": 20.0, "source": "palplab estimate"}},
    {"first": 107, "last": 107, "name": "membrane", "youngs_modulus": 1000000.0, "poisson_ratio": 0.45, "density": 1100.0, "colour": [0.3, 0.8, 0.4], "rigid": false, "needle": {"puncture_force": 1.0, "puncture_stiffness": 500.0, "cutting_force": 0.2, "friction": 15.0, "source": "palplab estimate of the order of the capsule-puncture peak of Okamura et al. 2004 (figure not taken from a table)"}},
    {"first": 200, "last": 299, "name": "bone", "youngs_modulus": 15000000000.0, "poisson_ratio": 0.3, "density": 1900.0, "colour": [0.95, 0.93, 0.85], "rigid": true, "needle": {"puncture_stiffness": 20000.0, "source": "palplab choice: a stiff haptic wall (bone is rigid and not punctured)"}},
    {"first": 300, "last": 399, "name": "muscle", "youngs_modulus": 50000.0, "poisson_ratio": 0.45, "density": 1060.0, "colour": [0.7, 0.2, 0.2], "rigid": false, "needle": {"puncture_force": 0.8, "puncture_stiffness": 250.0, "cutting_force": 0.25, "friction": 25.0, "source": "palplab estimate (muscle fascia between fat and skin; cf. Abolhassani et al. 2007)"}}
  ]
}
)JSON";
  return s;
}

const MaterialTable& default_materials() {
  static const MaterialTable t = parse_materials(default_materials_json(), "<built-in materials>");
  return t;
}

namespace {

// Where a JSON path of the table lies in its text (line:column when the locator knows it).
struct Ctx {
  const std::string& source;
  const json::JsonLocator& loc;
  [[noreturn]] void bad(const std::string& path, const std::string& what,
                        bool at_key = false) const {
    throw InputError(loc.locate(source, path, at_key), what);
  }
};

std::string fmt_g(double x) {
  char b[64];
  std::snprintf(b, sizeof b, "%g", x);
  return b;
}

// Refuses members of `j` (an object at `path`) that are not in `allowed`.
void check_keys(const Ctx& c, const nlohmann::json& j, const std::string& path,
                std::initializer_list<const char*> allowed) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    if (std::any_of(allowed.begin(), allowed.end(), [&](const char* a) { return k == a; }))
      continue;
    std::string list;
    for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
    c.bad(json::path_key(path, k), "unknown key \"" + k + "\" (allowed: " + list + ")", true);
  }
}

double number(const Ctx& c, const nlohmann::json& j, const std::string& path, const char* key,
              double lo, double hi, bool open_lo, bool open_hi) {
  const std::string p = json::path_key(path, key);
  if (!j.contains(key)) c.bad(path, std::string("missing \"") + key + "\"");
  const auto& v = j.at(key);
  const std::string range =
      std::string(open_lo ? "(" : "[") + fmt_g(lo) + ", " + fmt_g(hi) + (open_hi ? ")" : "]");
  if (!v.is_number()) c.bad(p, "expected a number in " + range);
  const double x = v.get<double>();
  if (!std::isfinite(x) || (open_lo ? x <= lo : x < lo) || (open_hi ? x >= hi : x > hi))
    c.bad(p, "expected a value in " + range + ", got " + fmt_g(x));
  return x;
}

// A tissue attribute: an integer that fits an int (no wrap-around of 4294967296 to 0).
int attribute(const Ctx& c, const nlohmann::json& e, const std::string& path, const char* key) {
  const std::string p = json::path_key(path, key);
  const std::string expected = "expected an integer tissue attribute in [" +
                               std::to_string(std::numeric_limits<int>::min()) + ", " +
                               std::to_string(std::numeric_limits<int>::max()) + "]";
  if (!e.contains(key)) c.bad(path, std::string("missing \"") + key + "\" (" + expected + ")");
  const auto& v = e.at(key);
  if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(std::numeric_limits<int>::max()))
      c.bad(p, expected + ", got " + std::to_string(u));
    return static_cast<int>(u);
  }
  if (v.is_number_integer()) {
    const auto i = v.get<std::int64_t>();
    if (i < std::numeric_limits<int>::min() || i > std::numeric_limits<int>::max())
      c.bad(p, expected + ", got " + std::to_string(i));
    return static_cast<int>(i);
  }
  c.bad(p, expected + ", got " + v.dump());
}

}  // namespace

MaterialTable parse_materials(const std::string& text, const std::string& source) {
  // Syntax errors and duplicate keys: located InputErrors (FILE:LINE:COL) from the shared reader.
  const nlohmann::json j = json::parse_located(text, source);
  const json::JsonLocator loc(text);
  const Ctx c{source, loc};
  if (!j.is_object() || !j.contains("materials") || !j["materials"].is_array())
    c.bad("$", "expected an object with a \"materials\" array");
  check_keys(c, j, "$", {"format", "version", "note", "needle_note", "materials"});
  // "format" and "version" are optional (tables written before they existed), checked if given.
  if (j.contains("format") &&
      (!j["format"].is_string() || j["format"].get<std::string>() != "palplab-materials"))
    c.bad("$.format", "expected \"palplab-materials\", got " + j["format"].dump());
  if (j.contains("version") && !(j["version"].is_number_integer() && j["version"] == 1))
    c.bad("$.version",
          "expected 1 (the only version of the material table), got " + j["version"].dump());
  for (const char* k : {"note", "needle_note"})
    if (j.contains(k) && !j[k].is_string())
      c.bad(json::path_key("$", k), "expected a string (a free-form note)");
  MaterialTable t;
  t.source = source;
  const auto& arr = j["materials"];
  for (size_t i = 0; i < arr.size(); ++i) {
    const std::string p = "$.materials[" + std::to_string(i) + "]";
    const auto& e = arr[i];
    if (!e.is_object()) c.bad(p, "expected an object");
    check_keys(c, e, p,
               {"first", "last", "name", "youngs_modulus", "poisson_ratio", "density", "colour",
                "rigid", "needle"});
    Material m;
    m.first = attribute(c, e, p, "first");
    m.last = attribute(c, e, p, "last");
    if (m.last < m.first) c.bad(p + ".last", "must be >= \"first\"");
    if (!e.contains("name") || !e["name"].is_string() || e["name"].get<std::string>().empty())
      c.bad(e.contains("name") ? p + ".name" : p, "expected a non-empty string \"name\"");
    m.name = e["name"].get<std::string>();
    m.youngs_modulus = number(c, e, p, "youngs_modulus", 0, 1e13, true, false);
    m.poisson_ratio = number(c, e, p, "poisson_ratio", -1, 0.5, true, true);
    m.density = number(c, e, p, "density", 0, 1e5, true, false);
    if (!e.contains("colour") || !e["colour"].is_array() || e["colour"].size() != 3)
      c.bad(e.contains("colour") ? p + ".colour" : p,
            "expected \"colour\": [r, g, b] with values in [0, 1]");
    for (int k = 0; k < 3; ++k) {
      const auto& v = e["colour"][k];
      if (!v.is_number() || v.get<double>() < 0 || v.get<double>() > 1)
        c.bad(p + ".colour[" + std::to_string(k) + "]", "expected a number in [0, 1]");
      m.colour[k] = v.get<double>();
    }
    if (e.contains("rigid")) {
      if (!e["rigid"].is_boolean()) c.bad(p + ".rigid", "expected true or false");
      m.rigid = e["rigid"].get<bool>();
    }
    if (e.contains("needle")) {
      const auto& n = e["needle"];
      const std::string q = p + ".needle";
      if (!n.is_object()) c.bad(q, "expected an object");
      check_keys(c, n, q,
                 {"puncture_force", "puncture_stiffness", "cutting_force", "friction", "source"});
      NeedleParams& np = m.needle;
      np.defined = true;
      np.puncture_stiffness = number(c, n, q, "puncture_stiffness", 0, 1e9, true, false);
      // A rigid tissue is never punctured: the other values are optional there.
      if (!m.rigid || n.contains("puncture_force"))
        np.puncture_force = number(c, n, q, "puncture_force", 0, 1e4, true, false);
      if (!m.rigid || n.contains("cutting_force"))
        np.cutting_force = number(c, n, q, "cutting_force", 0, 1e4, false, false);
      if (!m.rigid || n.contains("friction"))
        np.friction = number(c, n, q, "friction", 0, 1e6, false, false);
      if (n.contains("source")) {
        if (!n["source"].is_string()) c.bad(q + ".source", "expected a string");
        np.source = n["source"].get<std::string>();
      }
    }
    for (size_t k = 0; k < t.materials.size(); ++k)
      if (m.first <= t.materials[k].last && t.materials[k].first <= m.last)
        c.bad(p, "attribute range overlaps $.materials[" + std::to_string(k) + "]");
    t.materials.push_back(std::move(m));
  }
  return t;
}

MaterialTable read_materials(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError("is a directory (expected a material table, JSON)", path);
  return parse_materials(
      read_file_bounded(path, palplab::json::kMaxJsonFileBytes, "JSON material table"), path);
}

std::string materials_to_json(const MaterialTable& t) {
  nlohmann::ordered_json j;
  j["format"] = "palplab-materials";
  j["version"] = 1;
  j["materials"] = nlohmann::ordered_json::array();
  for (const Material& m : t.materials) {
    nlohmann::ordered_json e;
    e["first"] = m.first;
    e["last"] = m.last;
    e["name"] = m.name;
    e["youngs_modulus"] = m.youngs_modulus;
    e["poisson_ratio"] = m.poisson_ratio;
    e["density"] = m.density;
    e["colour"] = m.colour;
    e["rigid"] = m.rigid;
    if (m.needle.defined) {
      nlohmann::ordered_json n;
      if (!m.rigid || m.needle.puncture_force > 0) n["puncture_force"] = m.needle.puncture_force;
      n["puncture_stiffness"] = m.needle.puncture_stiffness;
      if (!m.rigid || m.needle.cutting_force > 0) n["cutting_force"] = m.needle.cutting_force;
      if (!m.rigid || m.needle.friction > 0) n["friction"] = m.needle.friction;
      if (!m.needle.source.empty()) n["source"] = m.needle.source;
      e["needle"] = n;
    }
    j["materials"].push_back(e);
  }
  return j.dump(2) + "\n";
}

}  // namespace palplab::mesh
