// `palplab fem verify [--json] [--levels N]`: the FEM verification cases (issue 12). For each
// case the computed value, the analytic value, the relative error, its tolerance and the
// observed convergence order. Exit 0 when every case is within tolerance, 1 otherwise.
// `palplab fem reference PROTOTYPE.json --press REGION --force N [--levels 3] --out FILE.json
//  [--refinement nested|tetgen] [--steps 5] [--overwrite]`:
// the accuracy reference (engine/models/fem_reference.hpp) of one press on the prototype's tet
// mesh: the static response on `levels` meshes — by default the prototype's mesh and its
// nested red refinements (1 -> 8 tets, h halved); --refinement tetgen: TetGen meshes of its
// surface with max tet volume halved per level (not nested) — the Richardson-extrapolated
// contact stiffness and surface displacement field, the estimated discretisation error of each
// level, and the quasi-static force-displacement curve of a slow press (`--steps` load steps,
// geometrically nonlinear FEM, --material; 0 = none) (docs/FORMATS.md "FEM reference"). Exit 0; 1
// when the curve is incomplete (a load step did not converge: the file holds the curve up to the
// last load every level reached and the reason, `curve.failure`); 2 bad input (every argument,
// --out included, is checked before the work starts: --out is never the prototype or its mesh,
// and an existing file that is not a fem reference JSON is replaced only with --overwrite).
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/IterativeLinearSolvers>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/command.hpp"
#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "common/write_file.hpp"
#include "engine/haptics/press.hpp"
#include "engine/haptics/scene_file.hpp"
#include "engine/models/fem_reference.hpp"
#include "engine/models/fem_verify.hpp"
#include "engine/models/model.hpp"
#include "prototypes/factory.hpp"

// AddressSanitizer reserves terabytes of address space for its shadow memory, so an address-space
// limit (RLIMIT_AS) makes every allocation of a sanitized child fail: there the memory limit is
// not applied (and the output says so); the CPU limit still is.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressLimitWorks = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressLimitWorks = false;
#else
constexpr bool kAddressLimitWorks = true;
#endif
#else
constexpr bool kAddressLimitWorks = true;
#endif

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
  std::string solver = "auto";
  std::string grade = "auto";
  int grade_max = 6;        // --grade auto: the most rounds tried
  double volume_scale = 1;  // level-0 max tet volume / the prototype's mean tet volume
  double force = 0;
  int levels = 3;
  int steps = 5;
  int newton_max = 30;      // full Newton iterations per load increment of the curve
  int bisections = 4;       // halvings of a curve load step that does not converge
  bool overwrite = false;   // --overwrite: replace an existing --out of another kind
  double mem_limit_gb = 0;  // address-space limit; 0 = 80 % of the machine's physical memory
  // The curve's material: the engine's default.
  std::string material = palplab::engine::to_string(palplab::engine::kDefaultCurveMaterial);
};

json num(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

// The reference problem of `fem reference` / `fem solvers` (checked arguments, the prototype's
// press and its nested-level size limit).
struct ReferenceSetup {
  palplab::engine::FemReferenceOptions o;
  std::string id, region;  // the prototype's id, the pressed node's region ("" = none)
  int node = -1;           // the pressed surface node
  // The files the reference is computed from (the prototype, its mesh files): never an --out.
  std::vector<palplab::app::CommandInput> inputs;
  // A note for stderr on the cost ("this takes minutes and GBs"), printed by the command once
  // every argument has been checked (an error is never preceded by it).
  std::string note;
};
// `built_levels`: the levels the command builds (fem solvers builds fewer than a.levels; 0 = all).
// `auto_grading`: --grade auto may add grading rounds up to --grade-max (fem reference).
ReferenceSetup reference_setup(const ReferenceArgs& a, int built_levels = 0,
                               bool auto_grading = true) {
  using namespace palplab;
  if (built_levels <= 0) built_levels = a.levels;
  if (!(a.force > 0) || !std::isfinite(a.force) || a.force > 1e3)
    throw InputError("--force: expected a force in N in (0, 1000], got " +
                     palplab::json::Checker::fmt(a.force));
  if (a.levels < 3 || a.levels > 6)
    throw InputError("--levels: expected 3 to 6 levels (3 are needed for an extrapolation), got " +
                     std::to_string(a.levels));
  if (a.refinement != "nested" && a.refinement != "tetgen")
    throw InputError("--refinement: expected nested or tetgen, got \"" + a.refinement + "\"");
  if (a.steps < 0 || a.steps > 100)
    throw InputError("--steps: expected 0 to 100 load steps, got " + std::to_string(a.steps));
  try {
    engine::parse_corot_material(a.material);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("--material: ") + e.what());
  }
  if (a.newton_max < 0 || a.newton_max > 1000)
    throw InputError("--newton-max: expected 0 to 1000 iterations, got " +
                     std::to_string(a.newton_max));
  if (a.bisections < 0 || a.bisections > 20)
    throw InputError("--bisections: expected 0 to 20 halvings, got " +
                     std::to_string(a.bisections));
  if (!(a.volume_scale > 0) || !std::isfinite(a.volume_scale) || a.volume_scale > 1e3)
    throw InputError("--volume-scale: expected a factor in (0, 1000]");
  // The values of --solver: the engine's sparse factorisations (engine::parse_sparse_solver:
  // ldlt, cholmod, auto) and pcg, which this command adds.
  if (a.solver != "ldlt" && a.solver != "cholmod" && a.solver != "pcg" && a.solver != "auto")
    throw InputError("--solver: expected one of ldlt, cholmod, pcg, auto, got \"" + a.solver +
                     "\"");
  if (a.solver == "pcg" && a.steps > 0)
    throw InputError(
        "--solver pcg: the quasi-static curve (--steps) reuses a factorisation; use --steps 0 "
        "with pcg, or ldlt / cholmod / auto");
  // Grading of level 0 around the press (fem_reference.hpp): auto (-1 here) = until the loaded
  // edges are at most the pad radius; 0 = the prototype's own mesh as level 0. Checked before
  // the prototype is loaded (which can take seconds).
  int grade_rounds = -1;
  if (a.grade != "auto") {
    size_t used = 0;
    try {
      grade_rounds = std::stoi(a.grade, &used);
    } catch (const std::exception&) {
      grade_rounds = -1;
    }
    if (used != a.grade.size() || grade_rounds < 0 || grade_rounds > 6)
      throw InputError("--grade: expected auto or 0 to 6 rounds, got \"" + a.grade + "\"");
  }
  ReferenceSetup su;
  const engine::SceneConfig cfg = prototypes::load_prototype(a.prototype);
  su.inputs.push_back({"the prototype file", a.prototype});
  for (const auto& s : engine::scene_sources(cfg))
    su.inputs.push_back({"the " + s.role + " file of the prototype", s.path});
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
    const double finest = static_cast<double>(tets) * std::pow(8.0, built_levels - 1);
    if (finest > 2e6)
      throw InputError("--levels: " + std::to_string(built_levels) + " nested levels of " + cfg.id +
                       "'s " + std::to_string(tets) + " tets give " +
                       std::to_string(static_cast<long>(finest)) +
                       " tets on the finest level (limit 2e6): use fewer levels (3 at least), "
                       "or a coarser copy of the prototype (mesh \"vertices\") with --grade 0 "
                       "(--grade auto refines its level 0 around the press again)");
    // Grading multiplies level 0 around the press (and so every finer level): a 2625-tet copy
    // of D (finest ungraded 168 000 tets, below this note's 2e5) with --levels 3 and --grade
    // auto grew past 12 GB in 13 minutes without a word (review 2026-12-07). With grading
    // possible the note comes from 2e4 tets on.
    const bool may_grade = grade_rounds > 0 || (grade_rounds < 0 && auto_grading &&
                                                a.grade == "auto" && a.grade_max > 0);
    if (finest > (may_grade ? 2e4 : 2e5)) {
      char note[1024];
      std::snprintf(note, sizeof note,
                    "note: the finest nested level of the prototype's own mesh has %.0f tets (8x "
                    "per level; a graded level 0, --grade, is larger, several times over: a "
                    "2625-tet mesh with --levels 3 and --grade auto used more than 12 GB): this "
                    "may take minutes to hours and GBs of memory (each level fewer, down to "
                    "--levels 3, is 8x "
                    "smaller; a coarser copy of the prototype is only with --grade 0: --grade "
                    "auto refines its level 0 around the press again; the command stops at "
                    "--mem-limit-gb, by default 80 %% of this machine's memory)\n",
                    finest);
      su.note = note;
    }
  }
  engine::FemReferenceOptions o = engine::reference_options_for_prototype(cfg, node, a.force);
  o.levels = a.levels;
  o.refinement =
      a.refinement == "nested" ? engine::FemRefinement::nested : engine::FemRefinement::tetgen;
  o.curve_steps = a.steps;
  o.curve_max_newton = a.newton_max;
  o.curve_bisections = a.bisections;
  o.curve_material = engine::parse_corot_material(a.material);
  o.max_volume *= a.volume_scale;
  if (a.refinement == "nested")
    o.grade_rounds = grade_rounds >= 0 ? grade_rounds : engine::auto_grade_rounds(o);
  // Levels meshed by TetGen at o.max_volume (every tetgen level; a graded nested level 0, also
  // when --grade auto may grade later) have at least volume / max_volume tets each (no tet is
  // larger than max_volume): refused here when the finest level cannot fit, not after minutes of
  // meshing and an exhausted memory. The prototype's mean tet volume is volume / tets, so level 0
  // has at least tets / volume_scale tets.
  const bool tetgen_levels = a.refinement == "tetgen" || o.grade_rounds > 0 ||
                             (auto_grading && a.grade == "auto" && a.grade_max > 0);
  if (tetgen_levels) {
    const double level0 = static_cast<double>(tets) / a.volume_scale;
    const double finest = level0 * std::pow(a.refinement == "tetgen" ? 2.0 : 8.0, built_levels - 1);
    if (finest > 2e6) {
      char msg[512];
      std::snprintf(msg, sizeof msg,
                    "--volume-scale %g: level 0 is meshed with tets of at most %.3g m^3 (%g x "
                    "the mean tet volume of %s's %ld tets), so it has at least %.3g tets and the "
                    "finest of %d %s levels at least %.3g (estimated before meshing; limit 2e6): "
                    "use a larger --volume-scale or fewer --levels",
                    a.volume_scale, o.max_volume, a.volume_scale, cfg.id.c_str(), tets, level0,
                    built_levels, a.refinement == "tetgen" ? "tetgen" : "nested", finest);
      throw InputError(msg);
    }
  }
  if (a.solver == "pcg") {
    // Static references only: Jacobi-PCG from kCholmodMinDofs free dofs (fem_reference.hpp).
    o.solver = engine::SparseSolverKind::automatic;
    o.pcg_min_dofs = engine::kCholmodMinDofs;
  } else {
    o.solver = engine::parse_sparse_solver(a.solver);
  }
  su.o = std::move(o);
  su.id = cfg.id;
  su.node = node;
  su.region = g.vertex_region[node] >= 0 ? g.region_names[g.vertex_region[node]] : "";
  return su;
}

// True when the file `path` is a JSON object whose "format" starts with `format` (e.g.
// "palplab-fem-reference/"): an output of that kind, which its command may replace.
bool json_file_of_format(const std::string& path, const std::string& format) {
  std::ifstream in(path, std::ios::binary);
  const json j = json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return false;
  const auto f = j.find("format");
  return f != j.end() && f->is_string() && f->get<std::string>().rfind(format, 0) == 0;
}

// fem reference's address-space limit (GB): --mem-limit-gb, else 80 % of physical memory (a
// graded 2625-tet copy of D at --levels 3 passed 12 GB, review 2026-12-07: without a limit the
// machine swaps or the kernel kills the process without a word).
double reference_memory_limit_gb(const ReferenceArgs& a) {
  if (a.mem_limit_gb > 0) return a.mem_limit_gb;
  const double bytes =
      static_cast<double>(::sysconf(_SC_PHYS_PAGES)) * static_cast<double>(::sysconf(_SC_PAGESIZE));
  return bytes > 0 ? 0.8 * bytes / 1073741824.0 : 0.0;
}

int run_reference(const ReferenceArgs& a) {
  using namespace palplab;
  if (a.out.empty()) throw InputError("--out: expected an output file name");
  if (a.grade_max < 0 || a.grade_max > 6)
    throw InputError("--grade-max: expected 0 to 6 rounds, got " + std::to_string(a.grade_max));
  const ReferenceSetup su = reference_setup(a);
  // --out is none of the inputs and replaces no file of another kind (a prototype, a database)
  // unless --overwrite: checked before the work, as every argument (app/command.hpp).
  app::require_replaceable_output(
      "--out", a.out, su.inputs,
      [](const std::string& p) { return json_file_of_format(p, "palplab-fem-reference/"); },
      "palplab fem reference JSON (\"format\": \"palplab-fem-reference/1\")", a.overwrite);
  std::fputs(su.note.c_str(), stderr);
  // The limit from here (the arguments, the prototype and its mesh are read): an allocation
  // beyond it is std::bad_alloc, said by the command (CHOLMOD's out of memory is too).
  if (const double gb = reference_memory_limit_gb(a); kAddressLimitWorks && gb > 0) {
    rlimit rm{};
    ::getrlimit(RLIMIT_AS, &rm);
    const rlim_t want = static_cast<rlim_t>(gb * 1073741824.0);
    if (rm.rlim_max == RLIM_INFINITY || want < rm.rlim_max) rm.rlim_cur = want;
    ::setrlimit(RLIMIT_AS, &rm);
  }
  engine::FemReferenceOptions o = su.o;
  const bool nested = a.refinement == "nested";
  // --grade auto on nested levels: the grading rounds chosen by the reference's own trust
  // verdict (engine::fem_reference_auto_grade), from the resolution rule's rounds up.
  const bool auto_grade = nested && a.grade == "auto";
  engine::FemAutoGradeResult ag;
  if (auto_grade) {
    ag = engine::fem_reference_auto_grade(o, a.grade_max);
    o.grade_rounds = ag.rounds;
  } else {
    ag.result = engine::fem_reference(o);
  }
  const engine::FemReferenceResult& r = ag.result;

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
                      {"press_h", lv.press_h},
                      {"solve_ms", lv.solve_ms},
                      {"solver", lv.solver},
                      {"factor_ms", lv.factor_ms},
                      {"factor_mb", lv.factor_mb},
                      {"pcg_iterations", lv.pcg_iterations}});
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
      {"prototype", su.id},
      {"prototype_file", a.prototype},
      {"press", a.press},
      {"node", su.node},
      {"region", su.region},
      {"force", a.force},
      {"press_radius", o.press_radius},
      {"press_point", {o.press_point.x(), o.press_point.y(), o.press_point.z()}},
      {"press_direction", {o.press_direction.x(), o.press_direction.y(), o.press_direction.z()}},
      {"load", "smooth pressure (1 - (r/a)^2)^2 over the surface within press_radius"},
      {"analysis", "static, linear elasticity"},
      {"support_modulus", o.support_modulus},
      {"refinement",
       nested ? (o.grade_rounds > 0 ? "nested red refinement (1 -> 8 tets, h halved per level) of "
                                      "a TetGen mesh of the prototype's surface graded around the "
                                      "press (grade_rounds rounds of surface refinement)"
                                    : "nested red refinement of the prototype's mesh (1 -> 8 tets, "
                                      "h halved per level; the surface stays the level-0 "
                                      "polyhedron)")
              : "TetGen, max tet volume halved per level (meshes not nested)"},
      {"refinement_kind", a.refinement},
      {"grade_rounds", nested ? o.grade_rounds : 0},
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
  if (auto_grade) {
    json att = json::array();
    for (const auto& t : ag.attempts)
      att.push_back({{"grade_rounds", t.rounds},
                     {"finest_tets", t.finest_tets},
                     {"finest_est_error", num(t.finest_error)},
                     {"trusted", t.trusted},
                     {"reason", t.reason},
                     {"seconds", t.seconds}});
    out["grade_auto"] = {
        {"rule",
         "from the rounds that bring the loaded edges to the pad radius, one more round while "
         "the reference is untrusted (finest level's estimated error <= 5 %), at most "
         "grade_max (each attempt a whole reference; the last one is reported)"},
        {"grade_max", a.grade_max},
        {"attempts", att}};
  }
  const auto failure_json = [](const engine::FemCurveFailure& fl) {
    return json{{"step", fl.step},
                {"force", fl.force},
                {"last_converged_force", fl.last_converged_force},
                {"substep_force", fl.substep_force},
                {"residual", num(fl.residual)},
                {"iterations", fl.iterations},
                {"tangent_indefinite", fl.tangent_indefinite},
                {"negative_pivots", fl.negative_pivots},
                {"converged_negative_pivots", fl.converged_negative_pivots},
                {"min_det_f", num(fl.min_det_f)},
                {"inverted_tets", fl.inverted_tets},
                {"converged_min_det_f", num(fl.converged_min_det_f)},
                {"stability",
                 {{"eigenvalues", fl.eigenvalues},
                  {"eigen_residual", num(fl.eigen_residual)},
                  {"mode_linear_stiffness", num(fl.mode_linear_stiffness)},
                  {"mode_load_cosine", num(fl.mode_load_cosine)},
                  {"mode_max_distance", num(fl.mode_max_distance)},
                  {"mode_near_press", num(fl.mode_near_press)},
                  {"mode_participation", num(fl.mode_participation)},
                  {"mode_non_elliptic", num(fl.mode_non_elliptic)},
                  {"non_elliptic_tets", fl.non_elliptic_tets},
                  {"min_ellipticity_margin", num(fl.min_ellipticity_margin)}}}};
  };
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
    json iters = json::array(), ms = json::array(), subs = json::array(), bis = json::array(),
         lsearch = json::array(), fails = json::array(), paths = json::array(),
         non_elliptic = json::array();
    for (const auto& lv : r.levels) {
      non_elliptic.push_back(lv.curve_non_elliptic);
      iters.push_back(lv.curve_iterations);
      ms.push_back(lv.curve_ms);
      subs.push_back(lv.curve_substeps);
      bis.push_back(lv.curve_bisections);
      lsearch.push_back(lv.curve_line_searches);
      json path = json::array();
      for (const auto& q : lv.curve_path) path.push_back({q[0], q[1]});
      paths.push_back(path);
      fails.push_back(lv.curve_failure.failed ? failure_json(lv.curve_failure) : json(nullptr));
    }
    json failure = nullptr;
    if (!r.curve_complete) {
      failure = failure_json(r.curve_failure);
      failure["level"] = r.curve_failure_level;
    }
    out["curve"] = {{"analysis",
                     "quasi-static: dead load ramped in equal steps, each a static equilibrium of "
                     "the geometrically nonlinear FEM (large deformations) with the material named "
                     "in material"},
                    {"steps", a.steps},
                    {"material", a.material},
                    {"complete", r.curve_complete},
                    {"failure", failure},
                    {"newton_max", a.newton_max},
                    {"bisections_max", a.bisections},
                    {"points", pts},
                    {"newton_iterations", iters},
                    {"substeps", subs},
                    {"bisections", bis},
                    {"line_searches", lsearch},
                    {"level_failure", fails},
                    {"level_path", paths},
                    {"non_elliptic_tets", non_elliptic},
                    {"solve_ms", ms}};
  }
  write_file(a.out, out.dump(1) + "\n", "the --out JSON");
  std::printf("%5s %8s %8s %12s %10s %12s %12s %10s %8s %10s %10s\n", "level", "tets", "dofs",
              "h (m)", "h_press", "k (N/m)", "u (m)", "est_error", "solver", "factor_ms",
              "factor_MB");
  for (size_t l = 0; l < r.levels.size(); ++l) {
    const auto& lv = r.levels[l];
    std::printf("%5zu %8ld %8ld %12.5g %10.4g %12.6g %12.6g %10.3g %8s %10.0f %10.0f\n", l, lv.tets,
                lv.dofs, lv.mesh_size, lv.press_h, lv.stiffness, lv.displacement, lv.est_error,
                lv.solver.c_str(), lv.factor_ms, lv.factor_mb);
  }
  std::printf(
      "extrapolated stiffness %.6g N/m, displacement %.6g m, observed order %.3g (ratio %.3g; "
      "asymptotic range [%.2g, %.2g])\n",
      r.stiffness, r.displacement, r.observed_order, r.refinement_ratio, engine::kPlausibleOrder[0],
      engine::kPlausibleOrder[1]);
  if (a.steps > 0 && !r.curve.empty()) {
    std::printf("quasi-static press (material %s):\n%10s %14s %14s %14s\n", a.material.c_str(),
                "F (N)", "u (m)", "u_linear (m)", "k_secant (N/m)");
    for (const auto& c : r.curve)
      std::printf("%10.4g %14.6g %14.6g %14.6g\n", c.force, c.displacement, c.linear_displacement,
                  c.secant_stiffness);
  }
  if (!trusted)
    std::printf(
        "WARNING: the extrapolation is not trustworthy: %s (monotone %s, order %s); add a level "
        "or refine the base mesh%s\n",
        untrusted.c_str(), r.monotone ? "yes" : "no",
        r.order_plausible ? "plausible" : "implausible",
        nested ? (auto_grade
                      ? (" (nested, --grade auto stopped at --grade-max " +
                         std::to_string(a.grade_max) + ")")
                      : (" (nested: e.g. --grade " + std::to_string(o.grade_rounds + 2) +
                         " or auto, more rounds of grading around the press; the 400-vertex D's "
                         "body press is trusted with 4, docs/PERFORMANCE.md)"))
                     .c_str()
               : "");
  if (auto_grade)
    for (const auto& t : ag.attempts)
      std::printf("grade %d: finest level %ld tets, estimated error %.3g, %.1f s: %s\n", t.rounds,
                  t.finest_tets, t.finest_error, t.seconds,
                  t.trusted ? "trusted" : t.reason.c_str());
  std::printf("written %s\n", a.out.c_str());
  if (a.steps > 0 && !r.curve_complete) {
    const auto& fl = r.curve_failure;
    std::printf(
        "CURVE INCOMPLETE: on level %d the load %.6g N (step %d of %d, increment %.4g N after "
        "at most %d bisections) did not converge: residual %.4g N after %d iterations; last "
        "equilibrium at %.6g N; the tangent %s (%ld negative pivots on the last iterate, %ld at "
        "the last equilibrium); smallest det F %.3g at the last iterate (%ld tets inverted), %.3g "
        "at "
        "the last equilibrium; the curve above ends at %.6g N (exit 1)\n",
        r.curve_failure_level, fl.force, fl.step, a.steps, fl.substep_force, a.bisections,
        fl.residual, fl.iterations, fl.last_converged_force,
        fl.negative_pivots < 0  ? "was singular"
        : fl.tangent_indefinite ? "was indefinite"
                                : "stayed positive definite",
        fl.negative_pivots, fl.converged_negative_pivots, fl.min_det_f, fl.inverted_tets,
        fl.converged_min_det_f, r.curve.empty() ? 0.0 : r.curve.back().force);
    if (!fl.eigenvalues.empty())
      std::printf(
          "at the last equilibrium: tangent eigenvalue nearest zero %.4g N/m (the same mode in "
          "the linear K: %.4g N/m), load work cosine %.3g, %.0f%% of the mode within 2 pad radii, "
          "%.0f%% on the %ld tets whose material lost strong ellipticity (smallest margin %.3g "
          "mu)\n",
          fl.eigenvalues[0], fl.mode_linear_stiffness, fl.mode_load_cosine,
          100 * fl.mode_near_press, 100 * fl.mode_non_elliptic, fl.non_elliptic_tets,
          fl.min_ellipticity_margin);
    if (fl.non_elliptic_tets > 0 && a.material == "corotated-linear")
      std::printf(
          "the co-rotated linear material lost strong ellipticity under the pad: a fine level's "
          "curve has no converged continuation there; --material neo-hookean (or "
          "fixed-corotated) stays elliptic (docs/ARCHITECTURE.md)\n");
    return 1;
  }
  return 0;
}

// `palplab fem solvers PROTOTYPE.json --press REGION --level L [--solvers LIST]`: the sparse
// solvers of fem_static.hpp (and preconditioned CG) side by side on nested level L of the
// reference problem of `fem reference` (docs/ARCHITECTURE.md "Sparse Cholesky"). Each solver
// runs in a forked child (own peak RSS from wait4, under --mem-limit-gb / --cpu-limit-s);
// the parent's RSS at the fork (mesh and assembled K) is printed alongside. The solutions are
// compared with the first solver's: max |u - u_first| / max |u_first| and the compliance f.u.
// PCG starts from the previous level's solution prolongated to level L (nested spaces).
struct SolverArgs {
  ReferenceArgs ref;
  int level = 2;
  std::string solvers = "ldlt,cholmod,pcg-jacobi,pcg-ic";
  double cg_tolerance = 1e-10;
  double mem_limit_gb = 6;
  double cpu_limit_s = 900;
  std::string out;
  bool overwrite = false;  // --overwrite: replace an existing --out of another kind
};

struct SolverRun {
  std::string name, status = "ok";
  double factor_ms = 0, solve_ms = 0, factor_mb = 0, compliance = 0;
  long iterations = 0;
  double peak_rss_mb = 0, rel_diff = 0;
  double cpu_s = 0;  // the child's user + system CPU time (the machine may be loaded: wall > CPU)
};

double rss_mb_now() {
  std::ifstream st("/proc/self/status");
  std::string key;
  while (st >> key) {
    if (key == "VmRSS:") {
      double kb = 0;
      st >> kb;
      return kb / 1024;
    }
    st.ignore(1 << 12, '\n');
  }
  return 0;
}

// In the child: solve K_ff u = f_f with `name`; writes the numbers and u_f to fd.
void solve_child(const std::string& name, const palplab::engine::SparseMatrixd& K,
                 const std::vector<std::uint8_t>& fixed_dof, const Eigen::VectorXd& f,
                 const Eigen::VectorXd& u0, double tol, int fd) {
  using namespace palplab::engine;
  double head[5] = {0, 0, 0, 0, 0};  // factor_ms, solve_ms, factor_mb, iterations, compliance
  Eigen::VectorXd u;
  const auto now = [] { return std::chrono::steady_clock::now(); };
  const auto ms = [](auto a, auto b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  if (name == "ldlt" || name == "cholmod") {
    StaticSolver ss;
    static_precompute(K, fixed_dof, ss,
                      name == "ldlt" ? SparseSolverKind::ldlt : SparseSolverKind::cholmod);
    head[0] = ss.factor_ms;
    head[2] = 8e-6 * ss.factor_nnz;
    const auto t0 = now();
    u = static_solve(ss, f);
    head[1] = ms(t0, now());
  } else {
    const DofSplit split = split_dofs(fixed_dof);
    const auto t0 = now();
    const SparseMatrixd Kff = submatrix(K, split.free, split.free);
    const Eigen::VectorXd b = gather(f, split.free);
    const Eigen::VectorXd x0 =
        name == "pcg-jacobi0" ? Eigen::VectorXd::Zero(b.size()) : gather(u0, split.free);
    Eigen::VectorXd x;
    const auto run = [&](auto& cg) {
      cg.setTolerance(tol);
      cg.setMaxIterations(50000);
      cg.compute(Kff);
      head[0] = ms(t0, now());
      const auto t1 = now();
      x = cg.solveWithGuess(b, x0);
      head[1] = ms(t1, now());
      head[3] = static_cast<double>(cg.iterations());
      if (cg.info() != Eigen::Success) throw std::runtime_error("CG did not converge");
    };
    if (name == "pcg-ic") {
      Eigen::ConjugateGradient<
          SparseMatrixd, Eigen::Lower | Eigen::Upper,
          Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>>
          cg;
      run(cg);
    } else if (name == "pcg-jacobi" || name == "pcg-jacobi0") {
      Eigen::ConjugateGradient<SparseMatrixd, Eigen::Lower | Eigen::Upper,
                               Eigen::DiagonalPreconditioner<double>>
          cg;
      run(cg);
    } else {
      throw std::invalid_argument("unknown solver " + name);
    }
    u = Eigen::VectorXd::Zero(f.size());
    scatter(x, split.free, u);
  }
  head[4] = f.dot(u);
  const auto put = [&](const void* p, size_t n) {
    const char* c = static_cast<const char*>(p);
    while (n > 0) {
      const ssize_t w = ::write(fd, c, n);
      if (w <= 0) _exit(3);
      c += w;
      n -= static_cast<size_t>(w);
    }
  };
  put(head, sizeof head);
  put(u.data(), sizeof(double) * static_cast<size_t>(u.size()));
}

int run_solvers(const SolverArgs& a) {
  using namespace palplab;
  if (a.ref.refinement != "nested")
    throw InputError("--refinement: fem solvers compares the solvers on nested levels only");
  if (a.level < 1 || a.level > 3)
    throw InputError("--level: expected 1 to 3, got " + std::to_string(a.level));
  if (!(a.cg_tolerance > 0 && a.cg_tolerance < 1))
    throw InputError("--cg-tolerance: expected a relative residual in (0, 1)");
  std::vector<std::string> names;
  for (size_t i = 0; i <= a.solvers.size();) {
    const size_t j = std::min(a.solvers.find(',', i), a.solvers.size());
    const std::string n = a.solvers.substr(i, j - i);
    if (n != "ldlt" && n != "cholmod" && n != "pcg-jacobi" && n != "pcg-jacobi0" && n != "pcg-ic")
      throw InputError(
          "--solvers: expected a comma-separated list of ldlt, cholmod, pcg-jacobi, "
          "pcg-jacobi0, pcg-ic; got \"" +
          n + "\"");
    if (std::find(names.begin(), names.end(), n) != names.end())
      throw InputError("--solvers: \"" + n + "\" is listed twice");
    names.push_back(n);
    i = j + 1;
  }
  ReferenceArgs ra = a.ref;
  ra.levels = std::max(3, a.level + 1);
  const ReferenceSetup su = reference_setup(ra, a.level + 1, false);
  if (!a.out.empty())
    app::require_replaceable_output(
        "--out", a.out, su.inputs,
        [](const std::string& p) { return json_file_of_format(p, "palplab-fem-solvers/"); },
        "palplab fem solvers JSON (\"format\": \"palplab-fem-solvers/1\")", a.overwrite);
  std::fputs(su.note.c_str(), stderr);
  const engine::FemReferenceOptions& o = su.o;
  engine::ReferenceLevelBuilder builder(o);
  Eigen::VectorXd u_coarse;
  for (int l = 0; l < a.level; ++l) {
    const engine::ReferenceLevelSystem& ls = builder.next();
    if (l == a.level - 1) {
      engine::StaticSolver ss;
      // LDL^T, not CHOLMOD: CHOLMOD starts an OpenMP thread pool, and a forked child that
      // uses OpenMP again after that deadlocks (libgomp is not fork-safe).
      engine::static_precompute(ls.K, ls.fixed_dof, ss, engine::SparseSolverKind::ldlt);
      u_coarse = engine::static_solve(ss, ls.load.f);
    }
  }
  const engine::ReferenceLevelSystem& ls = builder.next();
  const Eigen::VectorXd u0 = engine::prolongate(ls.parent, u_coarse);
  const long free_dofs = std::count(ls.fixed_dof.begin(), ls.fixed_dof.end(), std::uint8_t{0});
  const double base_rss = rss_mb_now();
  std::printf(
      "fem solvers: %s, press %s, nested level %d: %ld tets, %ld nodes, %ld free dofs, "
      "K %ld nonzeros; parent RSS at fork %.0f MB; limits %.1f GB%s, %.0f s CPU\n",
      o.surface.V.rows() ? ra.prototype.c_str() : "", ra.press.c_str(), a.level,
      static_cast<long>(ls.mesh.T.rows()), static_cast<long>(ls.mesh.V.rows()), free_dofs,
      static_cast<long>(ls.K.nonZeros()), base_rss, a.mem_limit_gb,
      kAddressLimitWorks ? "" : " (not applied: AddressSanitizer build)", a.cpu_limit_s);
  std::fflush(stdout);
  std::vector<SolverRun> runs;
  Eigen::VectorXd u_first;
  for (const std::string& n : names) {
    SolverRun run;
    run.name = n;
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("fem solvers: pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fem solvers: fork failed");
    if (pid == 0) {
      ::close(fds[0]);
      const rlim_t mem = static_cast<rlim_t>(a.mem_limit_gb * 1073741824.0);
      const rlim_t cpu = static_cast<rlim_t>(a.cpu_limit_s);
      rlimit rm{mem, mem}, rc{cpu, cpu};
      if (kAddressLimitWorks) ::setrlimit(RLIMIT_AS, &rm);
      ::setrlimit(RLIMIT_CPU, &rc);
      try {
        solve_child(n, ls.K, ls.fixed_dof, ls.load.f, u0, a.cg_tolerance, fds[1]);
      } catch (const std::bad_alloc&) {
        _exit(4);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "fem solvers: %s: %s\n", n.c_str(), e.what());
        _exit(5);
      }
      _exit(0);
    }
    ::close(fds[1]);
    double head[5];
    Eigen::VectorXd u(ls.load.f.size());
    const auto get = [&](void* p, size_t n_bytes) {
      char* c = static_cast<char*>(p);
      while (n_bytes > 0) {
        const ssize_t r = ::read(fds[0], c, n_bytes);
        if (r <= 0) return false;
        c += r;
        n_bytes -= static_cast<size_t>(r);
      }
      return true;
    };
    const bool got =
        get(head, sizeof head) && get(u.data(), sizeof(double) * static_cast<size_t>(u.size()));
    ::close(fds[0]);
    int status = 0;
    rusage ru{};
    ::wait4(pid, &status, 0, &ru);
    run.peak_rss_mb = static_cast<double>(ru.ru_maxrss) / 1024;
    run.cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
    if (WIFSIGNALED(status))
      run.status = WTERMSIG(status) == SIGXCPU
                       ? "cpu limit"
                       : "killed by signal " + std::to_string(WTERMSIG(status));
    else if (WEXITSTATUS(status) == 4)
      run.status = "out of memory (limit)";
    else if (WEXITSTATUS(status) != 0 || !got)
      run.status = "failed";
    if (run.status == "ok") {
      run.factor_ms = head[0];
      run.solve_ms = head[1];
      run.factor_mb = head[2];
      run.iterations = static_cast<long>(head[3]);
      run.compliance = head[4];
      if (u_first.size() == 0) u_first = u;
      run.rel_diff = (u - u_first).cwiseAbs().maxCoeff() / u_first.cwiseAbs().maxCoeff();
    }
    std::printf(
        "  %-12s %-22s factor/setup %9.0f ms  solve %9.0f ms (wall)  CPU %7.1f s  iters %6ld"
        "  factor %8.0f MB  peak RSS %7.0f MB  f.u %.10g  max|du|/max|u| %.2e\n",
        n.c_str(), run.status.c_str(), run.factor_ms, run.solve_ms, run.cpu_s, run.iterations,
        run.factor_mb, run.peak_rss_mb, run.compliance, run.rel_diff);
    std::fflush(stdout);
    runs.push_back(run);
  }
  if (!a.out.empty()) {
    json js = json::array();
    for (const auto& r : runs)
      js.push_back({{"solver", r.name},
                    {"status", r.status},
                    {"factor_ms", r.factor_ms},
                    {"solve_ms", r.solve_ms},
                    {"iterations", r.iterations},
                    {"factor_mb", r.factor_mb},
                    {"peak_rss_mb", r.peak_rss_mb},
                    {"cpu_s", r.cpu_s},
                    {"compliance", num(r.compliance)},
                    {"rel_diff", num(r.rel_diff)}});
    json out = {{"format", "palplab-fem-solvers/1"},
                {"prototype", ra.prototype},
                {"press", ra.press},
                {"level", a.level},
                {"tets", ls.mesh.T.rows()},
                {"nodes", ls.mesh.V.rows()},
                {"free_dofs", free_dofs},
                {"K_nonzeros", ls.K.nonZeros()},
                {"parent_rss_mb", base_rss},
                {"cg_tolerance", a.cg_tolerance},
                {"mem_limit_gb", a.mem_limit_gb},
                {"mem_limit_applied", kAddressLimitWorks},
                {"cpu_limit_s", a.cpu_limit_s},
                {"runs", js}};
    write_file(a.out, out.dump(2) + "\n", "the --out JSON");
  }
  for (const auto& r : runs)
    if (r.status != "ok") return 1;
  return 0;
}

palplab::app::CommandRegistration reg_fem{
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
          ->capture_default_str()
          ->check(palplab::app::count_range(4, 5));
      verify->callback([=] { *code = run_verify(*json_out, *levels); });
      auto* ref = fem->add_subcommand(
          "reference",
          "Static press on uniformly refined tet meshes of a prototype with the Richardson-"
          "extrapolated contact stiffness and displacement field");
      auto ra = std::make_shared<ReferenceArgs>();
      ref->add_option("prototype", ra->prototype, "Prototype JSON file (a tet mesh)")->required();
      ref->add_option("--press", ra->press, "Region name or surface node index to press")
          ->required();
      ref->add_option("--force", ra->force, "Press force (N), in (0, 1000]")->required();
      ref->add_option("--levels", ra->levels, "Refinement levels (3-6)")
          ->capture_default_str()
          ->check(palplab::app::count_range(3, 6));
      ref->add_option("--out", ra->out,
                      "Output JSON file (never the prototype or its mesh; an existing file that "
                      "is not a fem reference JSON only with --overwrite)")
          ->required();
      ref->add_flag("--overwrite", ra->overwrite,
                    "Replace an existing --out file that is not a fem reference JSON");
      ref->add_option("--mem-limit-gb", ra->mem_limit_gb,
                      "Address-space limit (GB); beyond it the command stops with exit 1 "
                      "(default: 80 % of this machine's physical memory; not applied under "
                      "AddressSanitizer)")
          ->check(palplab::app::finite_range(0.01, 1e6));
      ref->add_option("--refinement", ra->refinement,
                      "nested: red 1->8 refinements of the prototype's mesh (nested, h halved); "
                      "tetgen: TetGen meshes with max tet volume halved (not nested)")
          ->capture_default_str();
      ref->add_option("--steps", ra->steps,
                      "Load steps of the quasi-static (co-rotational) press curve; 0 = none")
          ->capture_default_str();
      auto* newton_opt =
          ref->add_option("--newton-max", ra->newton_max,
                          "Curve: full Newton iterations per load increment (each with a line "
                          "search) before the increment is halved; 0: modified Newton only")
              ->capture_default_str();
      auto* material_opt =
          ref->add_option(
                 "--material", ra->material,
                 "Curve: the material, neo-hookean (compressible neo-Hookean: elliptic, with "
                 "a barrier against inversion), corotated-linear (the linear element "
                 "rotated, as D_corot; loses strong ellipticity under large compression, "
                 "where a fine level's curve stops) or fixed-corotated (volume term in "
                 "det F, stays elliptic); all equal to first order")
              ->capture_default_str();
      auto* bisect_opt =
          ref->add_option("--bisections", ra->bisections,
                          "Curve: halvings of a load step that does not converge (0-20); below "
                          "that the curve stops at its last converged load and the command exits 1")
              ->capture_default_str();
      auto* grade_opt =
          ref->add_option("--grade", ra->grade,
                          "Nested levels: rounds of surface refinement around the press before "
                          "level 0 is meshed (auto: from loaded edges <= the pad radius, one more "
                          "round while the reference is untrusted, up to --grade-max; 0: the "
                          "prototype's mesh is level 0)")
              ->capture_default_str();
      auto* grade_max_opt = ref->add_option("--grade-max", ra->grade_max,
                                            "--grade auto: the most grading rounds tried (0-6)")
                                ->capture_default_str();
      auto* vscale_opt =
          ref->add_option(
                 "--volume-scale", ra->volume_scale,
                 "Max tet volume of TetGen levels (tetgen; graded level 0) as a multiple of "
                 "the prototype's mean tet volume")
              ->capture_default_str();
      ref->add_option("--solver", ra->solver,
                      "Sparse factorisation: ldlt (Eigen SimplicialLDLT), cholmod (supernodal), "
                      "auto (cholmod from 20000 free dofs), pcg (static only, --steps 0: the "
                      "finest level by PCG from 20000 free dofs, preconditioned by the coarser "
                      "level's factor, no factor of its own)")
          ->capture_default_str();
      ref->callback([=] {
        // Flags that another flag makes meaningless are errors, not silently ignored.
        using palplab::app::flag_only_with;
        const bool nested = ra->refinement == "nested";
        flag_only_with(grade_opt, nested, "--refinement nested");
        flag_only_with(grade_max_opt, nested && ra->grade == "auto",
                       "--refinement nested and --grade auto");
        flag_only_with(vscale_opt, !nested || ra->grade != "0",
                       "--refinement tetgen or a graded nested level 0 (--grade auto or 1-6; "
                       "--grade 0 uses the prototype's own mesh)");
        flag_only_with(newton_opt, ra->steps > 0, "--steps > 0 (the press curve)");
        flag_only_with(bisect_opt, ra->steps > 0, "--steps > 0 (the press curve)");
        flag_only_with(material_opt, ra->steps > 0, "--steps > 0 (the press curve)");
        try {
          *code = run_reference(*ra);
        } catch (const std::bad_alloc&) {
          char gb[32];
          std::snprintf(gb, sizeof gb, "%.3g", reference_memory_limit_gb(*ra));
          const bool nested = ra->refinement == "nested";
          const std::string less = std::string("fewer --levels") +
                                   (nested && ra->grade != "0" ? ", --grade 0" : "") +
                                   (nested ? " or --refinement tetgen" : "") + " need less";
          std::fprintf(stderr,
                       "fem reference: out of memory: the levels need more than the limit of %s "
                       "GB (--mem-limit-gb; the default is 80 %% of this machine's memory); %s. "
                       "Nothing written.\n",
                       gb, less.c_str());
          *code = 1;
        }
      });
      auto* sol = fem->add_subcommand(
          "solvers",
          "Time and peak memory of the sparse solvers (LDL^T, CHOLMOD, PCG) side by side on one "
          "nested level of the reference problem");
      auto sa = std::make_shared<SolverArgs>();
      sa->ref.force = 1.0;
      sol->add_option("prototype", sa->ref.prototype, "Prototype JSON file (a tet mesh)")
          ->required();
      sol->add_option("--press", sa->ref.press, "Region name or surface node index to press")
          ->required();
      sol->add_option("--grade", sa->ref.grade, "As for fem reference")->capture_default_str();
      auto* sol_vscale_opt =
          sol->add_option("--volume-scale", sa->ref.volume_scale, "As for fem reference")
              ->capture_default_str();
      sol->add_option("--level", sa->level, "Nested level to solve (1-3)")->capture_default_str();
      sol->add_option("--solvers", sa->solvers,
                      "Comma-separated: ldlt, cholmod, pcg-jacobi (from the prolongated coarse "
                      "solution), pcg-jacobi0 (from zero), pcg-ic (incomplete Cholesky)")
          ->capture_default_str();
      auto* cg_tol_opt =
          sol->add_option("--cg-tolerance", sa->cg_tolerance, "PCG relative residual")
              ->capture_default_str();
      // Converted to rlim_t (bytes, whole seconds): bounded so the conversion cannot overflow.
      sol->add_option("--mem-limit-gb", sa->mem_limit_gb, "Address-space limit per solver (GB)")
          ->capture_default_str()
          ->check(palplab::app::finite_range(0.01, 1e6));
      sol->add_option("--cpu-limit-s", sa->cpu_limit_s,
                      "CPU-time limit per solver (s, whole seconds)")
          ->capture_default_str()
          ->check(palplab::app::finite_range(1, 1e8));
      sol->add_option("--out", sa->out,
                      "Also write the table as JSON (never the prototype or its mesh; an existing "
                      "file that is not a fem solvers JSON only with --overwrite)");
      auto* sol_overwrite_opt =
          sol->add_flag("--overwrite", sa->overwrite,
                        "Replace an existing --out file that is not a fem solvers JSON");
      sol->callback([=] {
        using palplab::app::flag_only_with;
        flag_only_with(sol_vscale_opt, sa->ref.grade != "0",
                       "a graded level 0 (--grade auto or 1-6; --grade 0 uses the prototype's "
                       "own mesh)");
        flag_only_with(sol_overwrite_opt, !sa->out.empty(), "--out");
        flag_only_with(cg_tol_opt, sa->solvers.find("pcg") != std::string::npos,
                       "a PCG solver in --solvers (pcg-jacobi, pcg-jacobi0, pcg-ic)");
        *code = run_solvers(*sa);
      });
    }};

}  // namespace
