// `palplab fem verify [--json] [--levels N]`: the FEM verification cases (issue 12). For each
// case the computed value, the analytic value, the relative error, its tolerance and the
// observed convergence order. Exit 0 when every case is within tolerance, 1 otherwise.
// `palplab fem reference PROTOTYPE.json --press REGION --force N [--levels 3] --out FILE.json
//  [--refinement nested|tetgen] [--steps 5]`:
// the accuracy reference (engine/models/fem_reference.hpp) of one press on the prototype's tet
// mesh: the static response on `levels` meshes — by default the prototype's mesh and its
// nested red refinements (1 -> 8 tets, h halved); --refinement tetgen: TetGen meshes of its
// surface with max tet volume halved per level (not nested) — the Richardson-extrapolated
// contact stiffness and surface displacement field, the estimated discretisation error of each
// level, and the quasi-static force-displacement curve of a slow press (`--steps` load steps,
// co-rotational FEM; 0 = none) (docs/FORMATS.md "FEM reference").
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/command.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/press.hpp"
#include "engine/models/fem_reference.hpp"
#include "engine/models/fem_verify.hpp"
#include "engine/models/model.hpp"
#include "prototypes/factory.hpp"

namespace {

using json = nlohmann::ordered_json;

int run_verify(bool as_json, int levels) {
  if (levels < 4 || levels > 5)
    throw palplab::InputError("--levels must be between 4 and 5 (got " + std::to_string(levels) +
                              ")");
  palplab::engine::FemVerifyOptions opt;
  opt.cantilever_levels = levels;
  const auto checks = palplab::engine::run_fem_verification(opt);
  bool ok = true;
  for (const auto& c : checks) ok = ok && c.pass;
  if (as_json) {
    json cases = json::array();
    for (const auto& c : checks)
      cases.push_back({{"name", c.name},
                       {"quantity", c.quantity},
                       {"computed", c.computed},
                       {"analytic", c.analytic},
                       {"rel_error", c.rel_error},
                       {"tolerance", c.tolerance},
                       {"observed_order", std::isnan(c.order) ? json(nullptr) : json(c.order)},
                       {"pass", c.pass},
                       {"detail", c.detail}});
    std::cout << json{{"pass", ok}, {"cases", cases}}.dump(2) << "\n";
  } else {
    std::printf("%-26s %14s %14s %11s %9s %7s  %s\n", "case", "computed", "analytic", "rel_error",
                "tol", "order", "result");
    for (const auto& c : checks) {
      char order[16] = "-";
      if (!std::isnan(c.order)) std::snprintf(order, sizeof order, "%.2f", c.order);
      std::printf("%-26s %14.8g %14.8g %11.3g %9.1g %7s  %s\n", c.name.c_str(), c.computed,
                  c.analytic, c.rel_error, c.tolerance, order, c.pass ? "ok" : "FAIL");
      std::printf("    %s: %s\n", c.quantity.c_str(), c.detail.c_str());
    }
    std::printf("%s\n", ok ? "all cases within tolerance" : "SOME CASES OUTSIDE TOLERANCE");
  }
  return ok ? 0 : 1;
}

struct ReferenceArgs {
  std::string prototype, press, out;
  std::string refinement = "nested";
  double force = 0;
  int levels = 3;
  int steps = 5;
};

json num(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

int run_reference(const ReferenceArgs& a) {
  using namespace palplab;
  if (!(a.force > 0) || !std::isfinite(a.force) || a.force > 1e3)
    throw InputError("--force: expected a force in N in (0, 1000], got " + std::to_string(a.force));
  if (a.levels < 3 || a.levels > 6)
    throw InputError("--levels: expected 3 to 6 levels (3 are needed for an extrapolation), got " +
                     std::to_string(a.levels));
  if (a.out.empty()) throw InputError("--out: expected an output file name");
  if (a.refinement != "nested" && a.refinement != "tetgen")
    throw InputError("--refinement: expected nested or tetgen, got \"" + a.refinement + "\"");
  if (a.steps < 0 || a.steps > 100)
    throw InputError("--steps: expected 0 to 100 load steps, got " + std::to_string(a.steps));
  const engine::SceneConfig cfg = prototypes::load_prototype(a.prototype);
  const auto cm = engine::scene_mesh(cfg.mesh);
  if (!cm->tet)
    throw InputError("prototype " + cfg.id +
                         ": fem reference needs a tetrahedral mesh (generator model_c or a tet "
                         "mesh file)",
                     a.prototype);
  // The press node and its region, as `palplab probe` picks them (the scene's geometry).
  const engine::Scene scene = engine::make_scene(cfg);
  const engine::SceneGeometry& g = scene.geometry();
  int node = -1;
  try {
    node = engine::press_node(g, a.press);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("--press: ") + e.what());
  }
  const long tets = cm->model_T.rows();
  if (a.refinement == "nested") {
    // The finest nested level has 8^(levels-1) times the prototype's tets; a sparse Cholesky
    // of millions of tets needs tens of GB.
    const double finest = static_cast<double>(tets) * std::pow(8.0, a.levels - 1);
    if (finest > 2e6)
      throw InputError("--levels: " + std::to_string(a.levels) + " nested levels of " + cfg.id +
                       "'s " + std::to_string(tets) + " tets give " +
                       std::to_string(static_cast<long>(finest)) +
                       " tets on the finest level (limit 2e6): use fewer levels or a coarser "
                       "copy of the prototype (mesh \"vertices\")");
    if (finest > 2e5)
      std::fprintf(stderr,
                   "note: the finest nested level has %.0f tets (8x per level): this takes "
                   "minutes and GBs of memory; a coarser copy of the prototype (mesh "
                   "\"vertices\": 400) runs in about a minute\n",
                   finest);
  }
  engine::FemReferenceOptions o = engine::reference_options_for_prototype(cfg, node, a.force);
  o.levels = a.levels;
  const bool nested = a.refinement == "nested";
  o.refinement = nested ? engine::FemRefinement::nested : engine::FemRefinement::tetgen;
  o.curve_steps = a.steps;
  const engine::FemReferenceResult r = engine::fem_reference(o);

  json levels = json::array();
  for (size_t l = 0; l < r.levels.size(); ++l) {
    const auto& lv = r.levels[l];
    levels.push_back({{"level", l},
                      {"max_volume", lv.max_volume},
                      {"nodes", lv.nodes},
                      {"tets", lv.tets},
                      {"dofs", lv.dofs},
                      {"mesh_size", lv.mesh_size},
                      {"patch_area", lv.patch_area},
                      {"displacement", lv.displacement},
                      {"stiffness", lv.stiffness},
                      {"est_error", num(lv.est_error)},
                      {"field_error", num(lv.field_error)},
                      {"solve_ms", lv.solve_ms}});
  }
  json field_x = json::array(), field_u = json::array();
  for (long i = 0; i < r.field.rows(); ++i) {
    field_x.push_back({o.surface.V(i, 0), o.surface.V(i, 1), o.surface.V(i, 2)});
    field_u.push_back({r.field(i, 0), r.field(i, 1), r.field(i, 2)});
  }
  const std::string untrusted = engine::reference_untrusted_reason(r);
  const bool trusted = untrusted.empty();
  json out = {
      {"format", "palplab-fem-reference/1"},
      {"prototype", cfg.id},
      {"prototype_file", a.prototype},
      {"press", a.press},
      {"node", node},
      {"region", g.vertex_region[node] >= 0 ? g.region_names[g.vertex_region[node]] : ""},
      {"force", a.force},
      {"press_radius", cfg.contact.patch_radius},
      {"press_point", {o.press_point.x(), o.press_point.y(), o.press_point.z()}},
      {"press_direction", {o.press_direction.x(), o.press_direction.y(), o.press_direction.z()}},
      {"load", "smooth pressure (1 - (r/a)^2)^2 over the surface within press_radius"},
      {"analysis", "static, linear elasticity"},
      {"support_modulus", o.support_modulus},
      {"refinement", nested ? "nested red refinement of the prototype's mesh (1 -> 8 tets, h "
                              "halved per level; the surface stays the level-0 polyhedron)"
                            : "TetGen, max tet volume halved per level (meshes not nested)"},
      {"refinement_kind", a.refinement},
      {"refinement_ratio", r.refinement_ratio},
      {"plausible_order", {engine::kPlausibleOrder[0], engine::kPlausibleOrder[1]}},
      {"levels", levels},
      {"observed_order", num(r.observed_order)},
      {"stiffness", num(r.stiffness)},
      {"displacement", num(r.displacement)},
      {"monotone", r.monotone},
      {"order_plausible", r.order_plausible},
      {"trusted", trusted},
      {"untrusted_reason", untrusted},
      {"field", {{"positions", field_x}, {"displacement", field_u}}}};
  if (a.steps > 0) {
    json pts = json::array();
    for (size_t k = 0; k < r.curve.size(); ++k) {
      json per_level = json::array();
      for (const auto& lv : r.levels) per_level.push_back(lv.curve_displacement[k]);
      pts.push_back({{"force", r.curve[k].force},
                     {"displacement", num(r.curve[k].displacement)},
                     {"linear_displacement", num(r.curve[k].linear_displacement)},
                     {"secant_stiffness", num(r.curve[k].secant_stiffness)},
                     {"observed_order", num(r.curve[k].observed_order)},
                     {"extrapolated", r.curve[k].extrapolated},
                     {"level_displacement", per_level}});
    }
    json iters = json::array(), ms = json::array();
    for (const auto& lv : r.levels) {
      iters.push_back(lv.curve_iterations);
      ms.push_back(lv.curve_ms);
    }
    out["curve"] = {{"analysis",
                     "quasi-static: dead load ramped in equal steps, each an equilibrium of the "
                     "co-rotational FEM (large rotations, linear material)"},
                    {"steps", a.steps},
                    {"points", pts},
                    {"newton_iterations", iters},
                    {"solve_ms", ms}};
  }
  std::ofstream f(a.out);
  if (!f) throw InputError("--out: cannot write \"" + a.out + "\"");
  f << out.dump(1) << "\n";
  if (!f) throw InputError("--out: writing \"" + a.out + "\" failed");
  std::printf("%5s %8s %8s %12s %12s %12s %10s\n", "level", "tets", "dofs", "h (m)", "k (N/m)",
              "u (m)", "est_error");
  for (size_t l = 0; l < r.levels.size(); ++l) {
    const auto& lv = r.levels[l];
    std::printf("%5zu %8ld %8ld %12.5g %12.6g %12.6g %10.3g\n", l, lv.tets, lv.dofs, lv.mesh_size,
                lv.stiffness, lv.displacement, lv.est_error);
  }
  std::printf(
      "extrapolated stiffness %.6g N/m, displacement %.6g m, observed order %.3g (ratio %.3g; "
      "asymptotic range [%.2g, %.2g])\n",
      r.stiffness, r.displacement, r.observed_order, r.refinement_ratio, engine::kPlausibleOrder[0],
      engine::kPlausibleOrder[1]);
  if (!r.curve.empty()) {
    std::printf("quasi-static press (co-rotational):\n%10s %14s %14s %14s\n", "F (N)", "u (m)",
                "u_linear (m)", "k_secant (N/m)");
    for (const auto& c : r.curve)
      std::printf("%10.4g %14.6g %14.6g %14.6g\n", c.force, c.displacement, c.linear_displacement,
                  c.secant_stiffness);
  }
  if (!trusted)
    std::printf(
        "WARNING: the extrapolation is not trustworthy: %s (monotone %s, order %s); add a level "
        "or refine the base mesh\n",
        untrusted.c_str(), r.monotone ? "yes" : "no",
        r.order_plausible ? "plausible" : "implausible");
  std::printf("written %s\n", a.out.c_str());
  return 0;
}

palplab::app::CommandRegistration reg{
    "fem", [](CLI::App& root, int* code) {
      auto* fem = root.add_subcommand(
          "fem", "Tissue finite element model: verification and the accuracy reference");
      fem->require_subcommand(1);
      auto* verify = fem->add_subcommand(
          "verify", "Run the FEM verification cases (exit 1 if any is outside its tolerance)");
      auto json_out = std::make_shared<bool>(false);
      auto levels = std::make_shared<int>(4);
      verify->add_flag("--json", *json_out, "Print the cases as JSON");
      verify
          ->add_option("--levels", *levels,
                       "Cantilever refinement levels (4-5; elements through the thickness "
                       "1, 2, ..., 2^(levels-1); 5 takes minutes)")
          ->capture_default_str();
      verify->callback([=] { *code = run_verify(*json_out, *levels); });
      auto* ref = fem->add_subcommand(
          "reference",
          "Static press on uniformly refined tet meshes of a prototype with the Richardson-"
          "extrapolated contact stiffness and displacement field");
      auto ra = std::make_shared<ReferenceArgs>();
      ref->add_option("prototype", ra->prototype, "Prototype JSON file (a tet mesh)")->required();
      ref->add_option("--press", ra->press, "Region name or surface node index to press")
          ->required();
      ref->add_option("--force", ra->force, "Press force (N)")->required();
      ref->add_option("--levels", ra->levels, "Refinement levels (3-6)")->capture_default_str();
      ref->add_option("--out", ra->out, "Output JSON file")->required();
      ref->add_option("--refinement", ra->refinement,
                      "nested: red 1->8 refinements of the prototype's mesh (nested, h halved); "
                      "tetgen: TetGen meshes with max tet volume halved (not nested)")
          ->capture_default_str();
      ref->add_option("--steps", ra->steps,
                      "Load steps of the quasi-static (co-rotational) press curve; 0 = none")
          ->capture_default_str();
      ref->callback([=] { *code = run_reference(*ra); });
    }};

}  // namespace
