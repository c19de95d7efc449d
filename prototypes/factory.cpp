#include "prototypes/factory.hpp"

#include <algorithm>
#include <filesystem>

#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "common/json_locate.hpp"
#include "engine/models/model.hpp"

namespace palplab::prototypes {

using nlohmann::json;
namespace pj = palplab::json;
using namespace palplab::engine;
using palplab::json::Checker;

Thresholds read_thresholds(Checker& c, const json& o, const std::string& p) {
  c.keys(o, p, {"ST", "MPF", "SFT"});
  const auto st = c.number(o, p, "ST", true, 0, 1e6, "the sound threshold ST (N)", true);
  const auto mpf = c.number(o, p, "MPF", true, 0, 1e6, "the maximum palpation force MPF (N)", true);
  const auto sft =
      c.number(o, p, "SFT", true, 0, 1e6, "the stopping force threshold SFT (N)", true);
  if (st && sft && !(*st < *sft))
    c.err(pj::path_key(p, "ST"), "ST (" + json(*st).dump() + " N) must be below SFT (" +
                                     json(*sft).dump() + " N): the sound comes before the stop");
  if (mpf && sft && !(*mpf <= *sft))
    c.err(pj::path_key(p, "MPF"),
          "MPF (" + json(*mpf).dump() + " N) must not exceed SFT (" + json(*sft).dump() + " N)");
  return {st.value_or(0), mpf.value_or(0), sft.value_or(0)};
}

namespace {

// "$.mesh": a generator or a file (relative to the prototype file).
void read_mesh(Checker& c, const json& m, const std::string& path, MeshSource& out) {
  const std::string P = "$.mesh";
  c.keys(m, P, {"generator", "vertices", "seed", "file"});
  const bool has_file = m.contains("file"), has_gen = m.contains("generator");
  if (has_file == has_gen) {
    c.err(P, has_file
                 ? "give either \"generator\" or \"file\", not both"
                 : "missing \"generator\" (tract, model_c, stomach, sphere, shoulder) or \"file\" "
                   "(a mesh file)");
  } else if (has_file) {
    if (auto f = c.text(m, P, "file", true)) {
      namespace fs = std::filesystem;
      fs::path fp(*f);
      if (fp.is_relative()) fp = fs::path(path).parent_path() / fp;
      std::error_code ec;
      if (!fs::is_regular_file(fp, ec) &&
          !fs::is_regular_file(fs::path(fp).replace_extension(".node"), ec))
        c.err("$.mesh.file", (fs::is_directory(fp, ec) ? "a directory, not a mesh file: "
                                                       : "no such mesh file: ") +
                                 fp.string() +
                                 " (expected .obj, .stl, .off, .ply, .vtu or TetGen .node/.ele, "
                                 "relative to the prototype file)");
      else
        out.file = fs::absolute(fp).lexically_normal().string();
    }
    for (const char* k : {"vertices", "seed"})
      if (m.contains(k))
        c.err(pj::path_key(P, k), std::string("\"") + k + "\" applies to generators only", true);
  } else {
    out.generator =
        c.text(m, P, "generator", true, {"tract", "model_c", "stomach", "sphere", "shoulder"})
            .value_or(out.generator);
    // Each generator's own vertex range (engine/mesh/generate*.cpp), so that a count the
    // generator would refuse is an error here, at its JSON path; the stomach is one fixed mesh.
    if (out.generator == "stomach") {
      if (m.contains("vertices"))
        c.err(pj::path_key(P, "vertices"),
              "\"vertices\" does not apply to the stomach generator (one fixed mesh)", true);
    } else {
      const long long lo = out.generator == "sphere" ? 12 : out.generator == "shoulder" ? 162 : 200;
      const long long hi = out.generator == "shoulder" ? 40962 : 200000;
      const std::string what = out.generator == "shoulder"
                                   ? "the vertex count per skin layer"
                                   : "the " +
                                         std::string(out.generator == "sphere" ? "" : "surface ") +
                                         "vertex count of the " + out.generator + " generator";
      out.vertices = static_cast<int>(
          c.integer(m, P, "vertices", false, lo, hi, what.c_str()).value_or(out.vertices));
    }
    out.seed = static_cast<std::uint64_t>(
        c.integer(m, P, "seed", false, 0, 1L << 40, "the shape seed (0 = reference)")
            .value_or(static_cast<long long>(out.seed)));
  }
}

// What holds a deformable body ("$.model": "support_modulus", "fixed_z_below", "fixed_region",
// read by engine::read_support for the kinds "mass_spring" and "fem", which pin the model nodes
// below fixed_z_below and the nodes of fixed_region as their makers do). Nonsense that the
// models would accept: nothing holds the body (no pinned node, no foundation: a press pushes it
// away), or every surface node is pinned (nothing can be pressed: an infinite stiffness). The
// mesh is needed when pins are declared; it is built once per process (engine::scene_mesh's
// cache), so the scene made from this prototype reuses it.
void check_support(Checker& c, const json& model, const SceneConfig& s) {
  const SupportConfig& sp = s.support;
  const std::string P = "$.model";
  const bool foundation = sp.modulus > 0;
  if (sp.fixed_region.empty() && !(sp.fixed_z_below > 0)) {
    if (!foundation)
      c.err(model.contains("support_modulus") ? P + ".support_modulus" : P,
            "nothing holds the body: no node is pinned (\"fixed_z_below\", \"fixed_region\") "
            "and \"support_modulus\" is 0, so a press would push the whole body away; pin its "
            "base (e.g. \"fixed_z_below\": 0.02) or give an elastic foundation "
            "(\"support_modulus\" > 0)");
    return;
  }
  const auto mesh = scene_mesh(s.mesh);
  const SceneMesh& m = *mesh;
  const long nm = m.model_V.rows(), nv = m.V.rows();
  if (nm == 0 || nv == 0) return;
  std::vector<std::uint8_t> pinned(static_cast<size_t>(nm), 0);
  int region = -1;
  if (!sp.fixed_region.empty())
    for (size_t r = 0; r < m.region_names.size(); ++r)
      if (m.region_names[r] == sp.fixed_region) region = static_cast<int>(r);
  if (region >= 0)
    for (size_t i = 0; i < m.vertex_region.size(); ++i)
      if (m.vertex_region[i] == region) pinned[static_cast<size_t>(m.surface_to_model[i])] = 1;
  const double z0 = m.model_V.col(2).minCoeff(), height = m.model_V.col(2).maxCoeff() - z0;
  if (sp.fixed_z_below > 0)
    for (long i = 0; i < nm; ++i)
      if (m.model_V(i, 2) < z0 + sp.fixed_z_below) pinned[static_cast<size_t>(i)] = 1;
  long surface_pinned = 0, model_pinned = 0;
  for (long i = 0; i < nm; ++i) model_pinned += pinned[static_cast<size_t>(i)];
  for (long i = 0; i < nv; ++i)
    surface_pinned += pinned[static_cast<size_t>(m.surface_to_model[static_cast<size_t>(i)])];
  // Located at the member that pins (fixed_z_below when both are given and it alone pins all).
  const std::string where = sp.fixed_z_below > 0 ? P + ".fixed_z_below" : P + ".fixed_region";
  if (surface_pinned == nv)
    c.err(where,
          "pins every surface node (" + std::to_string(nv) + " of " + std::to_string(nv) +
              "): nothing is left to press (the body would be infinitely stiff); the "
              "mesh is " +
              Checker::fmt(height) + " m tall above its lowest point, \"fixed_z_below\" is " +
              Checker::fmt(sp.fixed_z_below) + " m" +
              (sp.fixed_region.empty() ? std::string()
                                       : ", \"fixed_region\" is \"" + sp.fixed_region + "\""));
  else if (model_pinned < 3 && !foundation)
    c.err(where, "pins only " + std::to_string(model_pinned) +
                     " node(s) and \"support_modulus\" is 0: the body can turn about them (at "
                     "least 3 pinned nodes are needed to hold it); raise \"fixed_z_below\" or "
                     "give an elastic foundation (\"support_modulus\" > 0)");
}

}  // namespace

SceneConfig load_prototype(const std::string& path) {
  std::string text;
  std::vector<Problem> repeated;  // reported with the file's other problems
  const json root = pj::parse_file_located(path, &text, &repeated);
  Checker c(path, text);
  c.add(repeated);
  SceneConfig s;  // every default comes from here
  s.source = path;
  const std::string R = "$";
  if (!root.is_object()) {
    c.err(R, "expected a JSON object describing a prototype");
    c.throw_if_any();
  }
  c.keys(root, R,
         {"format", "id", "scene", "description", "mesh", "model", "contact", "cues", "haptic_step",
          "thresholds", "start_position"});
  if (auto f = c.text(root, R, "format", true)) {
    if (*f != "palplab-prototype/1")
      c.err("$.format", "unsupported format \"" + *f + "\" (expected \"palplab-prototype/1\")");
  }
  s.id = c.text(root, R, "id", true).value_or("");
  // The id is a study's prototype name, a figure's and a still's file name and database text:
  // the ids' grammar (an id with an escape sequence reached the terminal through `probe`).
  if (root.contains("id") && root["id"].is_string()) palplab::json::check_id(c, s.id, "$.id");
  s.scene = c.text(root, R, "scene", false).value_or("");
  s.description = c.text(root, R, "description", false).value_or("");
  s.dt = c.number(root, R, "haptic_step", false, 1e-5, 0.01, "the haptic step (s)", false)
             .value_or(s.dt);

  bool mesh_ok = false;
  if (const json* m = c.object(root, R, "mesh", true)) {
    read_mesh(c, *m, path, s.mesh);
    mesh_ok = c.ok();
  }
  // Region names: fixed for generators; a mesh file is read (and cached) to learn them. A bad
  // mesh file throws its own located InputError (file, line or byte).
  static const std::vector<std::string> no_regions;
  const auto& regions = mesh_ok ? mesh_region_names(s.mesh) : no_regions;

  const ModelKind* kind = nullptr;
  if (const json* m = c.object(root, R, "model", true)) {
    if (auto k = c.text(*m, "$.model", "kind", true)) {
      kind = find_model_kind(*k);
      if (kind) {
        s.model = *k;
        kind->read(c, *m, "$.model", s, regions);
      } else {
        std::string names;
        for (const auto& mk : model_kinds())
          names += (names.empty() ? "\"" : ", \"") + std::string(mk.name) + "\"";
        c.err("$.model.kind", "unknown model kind \"" + *k + "\" (expected one of: " + names + ")");
      }
    }
  }
  if (const json* ct = c.object(root, R, "contact", false)) {
    const std::string P = "$.contact";
    ContactConfig& k = s.contact;
    c.keys(*ct, P, {"stiffness", "radius", "patch_radius", "force_limit"});
    k.force_limit =
        c.number(*ct, P, "force_limit", false, 0, 1000, "the device's peak force (N)", true)
            .value_or(k.force_limit);
    k.patch_radius =
        c.number(*ct, P, "patch_radius", false, 0, 0.1, "the radius of the probe face (m)", true)
            .value_or(k.patch_radius);
    k.stiffness = c.number(*ct, P, "stiffness", false, 0, 1e6, "the contact stiffness (N/m)", true)
                      .value_or(k.stiffness);
    // Removed (issue 10): it was the capture radius of the old nearest-node contact, which the
    // god-object contact made meaningless; the size of the probe is contact.patch_radius.
    if (ct->contains("radius"))
      c.err(P + ".radius",
            "\"radius\" is no longer a key: it was the capture radius of the old nearest-node "
            "contact (a contact now starts where the device's path crosses the surface); the "
            "probe's size is \"patch_radius\" (m, radius of the probe face of deformable "
            "models) — delete \"radius\", or rename it to \"patch_radius\" if it meant the probe",
            true);
  }
  if (kind && kind->check && c.ok()) kind->check(c, s);
  // The kinds whose body is held by the support (the ones that read it, engine::read_support).
  if (kind && c.ok() && (s.model == "mass_spring" || s.model == "fem"))
    check_support(c, root["model"], s);
  if (const json* cu = c.object(root, R, "cues", false)) {
    const std::string P = "$.cues";
    c.keys(*cu, P, {"haptic", "visual_deformation", "audio", "transparency"});
    s.cues.transparency = c.boolean(*cu, P, "transparency", false).value_or(s.cues.transparency);
    s.cues.haptic = c.boolean(*cu, P, "haptic", false).value_or(s.cues.haptic);
    s.cues.visual_deformation =
        c.boolean(*cu, P, "visual_deformation", false).value_or(s.cues.visual_deformation);
    s.cues.audio = c.boolean(*cu, P, "audio", false).value_or(s.cues.audio);
  }
  if (const json* th = c.object(root, R, "thresholds", false)) {
    for (auto it = th->begin(); it != th->end(); ++it) {
      const std::string P = pj::path_key("$.thresholds", it.key());
      if (it.key() != "*" && std::find(regions.begin(), regions.end(), it.key()) == regions.end()) {
        c.err(P,
              "unknown region \"" + it.key() + "\" (expected \"*\" or a region of the mesh)" +
                  pj::did_you_mean(it.key(), regions),
              true);
        continue;
      }
      if (!it.value().is_object()) {
        c.err(P, "expected an object {\"ST\", \"MPF\", \"SFT\"} in N");
        continue;
      }
      s.thresholds[it.key()] = read_thresholds(c, it.value(), P);
    }
  }
  if (auto sp = c.vec3(root, R, "start_position", false, -10, 10, "the device start position (m)"))
    s.start_position = Eigen::Vector3d((*sp)[0], (*sp)[1], (*sp)[2]);
  c.throw_if_any();
  return s;
}

PrototypeSummary inspect_prototype(const std::string& path) {
  const SceneConfig s = load_prototype(path);
  // What the model needs of its mesh, said now rather than when the first session builds it (a
  // run left an empty database behind, and `validate` passed it; review 2026-12-07).
  if (const ModelKind* kind = find_model_kind(s.model); kind && kind->check_mesh)
    kind->check_mesh(s, *scene_mesh(s.mesh));
  return {s.id, s.scene, s.model, mesh_region_names(s.mesh), mesh_inner_region_names(s.mesh), s.dt};
}

engine::Scene build_scene(const std::string& path, const SceneOverrides& ov) {
  SceneConfig cfg = load_prototype(path);
  apply(cfg, ov);
  return make_scene(cfg);
}

}  // namespace palplab::prototypes
