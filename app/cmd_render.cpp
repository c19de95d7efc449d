// `palplab render PROTOTYPE.json [--press REGION --force N] [--camera az,el[,dist]]
//  [--size WxH] [--wireframe] [--alpha REGION=A ...] [--transparent TISSUE[,..]] --out FILE.png`: a
//  headless (EGL) still of
// a prototype's organ, shaded with per-region colours.
#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "app/command.hpp"
#include "app/stills.hpp"
#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "engine/render/headless.hpp"
#include "engine/render/still.hpp"
#include "prototypes/factory.hpp"

namespace {

struct RenderArgs {
  std::string file, out, camera, size = "800x600", press, look_at;
  double force = 0.0, hold = 0.5;
  bool wireframe = false, overwrite = false;
  std::vector<std::string> alpha;
  std::string transparent;
  double transparent_alpha = 0.15;
};

std::vector<double> parse_numbers(const std::string& flag, const std::string& text, char sep,
                                  size_t min_n, size_t max_n, const std::string& expected) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, sep)) {
    size_t used = 0;
    double x = 0.0;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || !std::isfinite(x))
      throw palplab::InputError(flag + ": \"" + text + "\": expected " + expected);
    v.push_back(x);
  }
  // getline drops an empty last item: "30,25," was read as "30,25".
  if (v.size() < min_n || v.size() > max_n || (!text.empty() && text.back() == sep))
    throw palplab::InputError(flag + ": \"" + text + "\": expected " + expected);
  return v;
}

int run_render(const RenderArgs& a) {
  using namespace palplab;
  // --out is never the prototype read, nor a file of another kind without --overwrite.
  app::require_replaceable_output(
      "--out", a.out, {{"the prototype file", a.file}},
      [](const std::string& p) { return app::file_starts_with(p, "\x89PNG\r\n\x1a\n"); },
      "PNG image", a.overwrite);
  const auto [width, height] = app::parse_image_size("--size", a.size);
  render::Camera cam;
  if (!a.camera.empty()) {
    const auto c = parse_numbers("--camera", a.camera, ',', 2, 3,
                                 "AZIMUTH,ELEVATION[,DISTANCE] (degrees, degrees, m)");
    if (c[1] < -90 || c[1] > 90)
      throw InputError("--camera: elevation " + palplab::json::Checker::fmt(c[1]) +
                       " outside [-90, 90] degrees");
    // Azimuth in one turn either way; a distance the organ (≤ 10 m across, the prototype
    // check) is still visible from (review 2026-12-06, second: 1e300 drew a white image, exit 0).
    if (c[0] < -360 || c[0] > 360)
      throw InputError("--camera: azimuth " + palplab::json::Checker::fmt(c[0]) +
                       " outside [-360, 360] degrees");
    cam.azimuth_deg = c[0];
    cam.elevation_deg = c[1];
    if (c.size() == 3) {
      if (!(c[2] > 0.0) || c[2] > 100.0)
        throw InputError("--camera: distance " + palplab::json::Checker::fmt(c[2]) +
                         " m outside (0, 100] m (omit it to fit the organ in view)");
      cam.distance = c[2];
    }
  }
  // --force (0 = not given), --hold and --transparent-alpha are range-checked by their
  // validators (app/command.hpp).
  if (a.press.empty() != (a.force == 0.0))
    throw InputError("--press and --force go together (REGION_OR_NODE and a force in N)");
  engine::Scene scene = prototypes::build_scene(a.file);
  const auto& g = scene.geometry();
  std::string region_list;  // for the messages on unknown regions
  for (const auto& n : g.region_names) region_list += (region_list.empty() ? "" : ", ") + n;
  render::StillOptions opt;
  if (!a.press.empty()) {
    render::PressedStill p;
    try {
      p = render::press_for_still(scene, a.press, a.force, a.hold);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("--press: ") + e.what());
    }
    opt.device_position = p.device;
    opt.contact = p.contact;
    if (!p.force_reached)
      std::cerr << "palplab render: warning: the press did not reach " << a.force
                << " N (force at the still " << p.force << " N)\n";
    std::cout << "pressed node " << p.node << " to " << p.force << " N for " << a.hold
              << " s; visible deformation " << p.visible_deformation * 1e3 << " mm\n";
  }
  if (!a.look_at.empty()) {
    if (g.region_index(a.look_at) < 0)
      throw InputError("--look-at: unknown region \"" + a.look_at + "\" (regions: " + region_list +
                       ")");
    cam.target = g.region_centroid(a.look_at);
  }
  opt.wireframe = a.wireframe;
  for (const auto& s : a.alpha) {
    const auto eq = s.find('=');
    if (eq == std::string::npos || eq == 0)
      throw InputError("--alpha: \"" + s + "\": expected REGION=OPACITY, e.g. body=0.4");
    // The region and the opacity are checked here, so that the message names the flag (the
    // renderer's own check, render::region_alpha_vector, does not know where they came from).
    const std::string region = s.substr(0, eq);
    const auto v = parse_numbers("--alpha", s.substr(eq + 1), ',', 1, 1, "an opacity in [0, 1]");
    if (v[0] < 0.0 || v[0] > 1.0)
      throw InputError("--alpha: \"" + s + "\": expected an opacity in [0, 1], got " +
                       app::shown_number(v[0]));
    if (region != "*" && g.region_index(region) < 0)
      throw InputError("--alpha: \"" + s + "\": unknown region \"" + region +
                       "\" (regions: " + region_list + ", or * for every region)");
    if (opt.region_alpha.count(region))
      throw InputError("--alpha: region \"" + region + "\" given twice (give each region once)");
    opt.region_alpha[region] = static_cast<float>(v[0]);
  }
  // --transparent TISSUE[,..]: those regions see-through ("soft" = a needle scene's soft
  // tissues, what the transparency cue shows), so bone and target show through (--alpha wins).
  if (!a.transparent.empty()) {
    std::stringstream ss(a.transparent);
    std::string name;
    while (std::getline(ss, name, ',')) {
      if (name == "soft") {
        if (!g.tissues)
          throw InputError("--transparent soft: prototype " + scene.prototype() +
                           " is not a layered tissue scene (model \"" + scene.model_kind() +
                           "\"); name its regions instead");
        for (int r : g.tissues->soft_regions)
          opt.region_alpha.emplace(g.region_names[r], static_cast<float>(a.transparent_alpha));
        continue;
      }
      if (g.region_index(name) < 0)
        throw InputError("--transparent: unknown tissue/region \"" + name +
                         "\" (regions: " + region_list + (g.tissues ? ", or soft" : "") + ")");
      opt.region_alpha.emplace(name, static_cast<float>(a.transparent_alpha));
    }
  }
  render::Image img;
  try {
    img = render::render_still(scene, cam, width, height, opt);
  } catch (const render::NoDisplayError& e) {
    std::cerr << "palplab render: " << e.what() << "\n";
    return 3;
  }
  render::write_png(a.out, img);
  std::cout << "wrote " << a.out << " (" << img.width << "x" << img.height << ", prototype "
            << scene.prototype() << ")\n";
  return 0;
}

palplab::app::CommandRegistration reg_render{
    "render", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand("render", "Headless still of a prototype's organ (PNG)");
      auto a = std::make_shared<RenderArgs>();
      cmd->add_option("prototype", a->file, "Prototype JSON file")->required();
      cmd->add_option("--out", a->out, "PNG file to write")->required();
      cmd->add_flag("--overwrite", a->overwrite, "Replace an existing --out that is not a PNG");
      cmd->add_option("--camera", a->camera,
                      "AZIMUTH,ELEVATION[,DISTANCE]: degrees about +z in [-360, 360], degrees "
                      "above the xy plane in [-90, 90], m from the organ's centre in (0, 100] "
                      "(default 30,25 and fit to view)");
      cmd->add_option("--size", a->size, "Image size WIDTHxHEIGHT in pixels (default 800x600)");
      cmd->add_option("--look-at", a->look_at,
                      "Region whose centroid the camera aims at (default: the organ's centre)");
      cmd->add_flag("--wireframe", a->wireframe, "Draw the mesh edges over the surface");
      cmd->add_option("--alpha", a->alpha,
                      "REGION=OPACITY (0..1, '*' = every region); transparent regions are drawn "
                      "back to front. Repeatable");
      cmd->add_option("--transparent", a->transparent,
                      "TISSUE[,TISSUE..]: draw these regions see-through (needle scenes: 'soft' "
                      "= the soft tissues), so the bone and target inside show");
      auto* talpha_opt = cmd->add_option("--transparent-alpha", a->transparent_alpha,
                                         "Opacity of the --transparent regions (default 0.15)")
                             ->check(palplab::app::finite_range(0, 1, false, true));
      cmd->add_option("--press", a->press, "Region name or surface node index to press");
      cmd->add_option("--force", a->force, "Target device force of the press (N), in (0, 100]")
          ->check(palplab::app::finite_range(0, 100, true));
      auto* hold_opt =
          cmd->add_option("--hold", a->hold,
                          "Time the press holds the force before the still (s, default 0.5)")
              ->check(palplab::app::finite_range(0, 60));
      cmd->callback([a, talpha_opt, hold_opt, code] {
        palplab::app::flag_only_with(talpha_opt, !a->transparent.empty(), "--transparent");
        palplab::app::flag_only_with(hold_opt, !a->press.empty(), "--press and --force");
        *code = run_render(*a);
      });
    }};

}  // namespace
