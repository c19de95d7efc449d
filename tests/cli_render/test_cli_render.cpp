// `palplab render` and `palplab view` end to end: a press changes the still at the contact and
// nowhere far from it; the view window renders frames under Xvfb; bad input exits 2. Skipped only
// when the machine has no EGL device (render exits 3) or no xvfb-run (view).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include "tests/cli_support.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "engine/haptics/press.hpp"
#include "engine/render/camera.hpp"
#include "engine/render/image.hpp"
#include "engine/render/pick.hpp"
#include "prototypes/factory.hpp"
#include "tests/render_support.hpp"

namespace fs = std::filesystem;
namespace pr = palplab::render;

namespace {
using Result = palplab::testing::CliResult;
Result run(const std::string& cmdline) {
  return palplab::testing::run_command(cmdline);
}
Result cli(const std::string& args) {
  return run(std::string(PALPLAB_BINARY) + " " + args);
}
std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}
fs::path tmp(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("palplab_cli_render_" + std::to_string(getpid()));
  fs::create_directories(d);
  return d / name;
}
}  // namespace

TEST(CliRender, PressChangesTheStillOnlyNearTheContact) {
  const std::string cam = " --camera 0,20 --size 480x360";
  const fs::path still = tmp("rest.png"), pressed = tmp("pressed.png");
  Result r = cli("render " + proto("B") + cam + " --out " + still.string());
  if (r.code == 3) GTEST_SKIP() << "no EGL device: " << r.out;
  ASSERT_EQ(r.code, 0) << r.out;
  r = cli("render " + proto("B") + cam + " --press ovary_left --force 2.5 --out " +
          pressed.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const pr::Image a = pr::read_png(still.string()), b = pr::read_png(pressed.string());
  ASSERT_EQ(a.width, 480);
  ASSERT_EQ(a.height, 360);
  ASSERT_EQ(b.width, a.width);

  // Where the camera puts the pressed point, and how many pixels 3 cm there span.
  const palplab::engine::Scene scene = palplab::prototypes::build_scene(proto("B"));
  const auto& g = scene.geometry();
  const Eigen::Vector3d p = g.V.row(palplab::engine::press_node(g, "ovary_left")).transpose();
  Eigen::Vector3d centre;
  double radius = 0.0;
  pr::bounding_sphere(g.V, centre, radius);
  pr::Camera c;
  c.azimuth_deg = 0;
  c.elevation_deg = 20;
  const pr::CameraMatrices m = pr::camera_matrices(c, centre, radius, a.width, a.height);
  const Eigen::Vector2d at = m.project(p);
  const double px_3cm = palplab::testing::pixels_spanned(m, p, 0.03);
  ASSERT_GT(px_3cm, 5.0);

  // The organ is in view; the press point is on it.
  EXPECT_GT(palplab::testing::coverage(a).count, 2000);
  const auto changed = palplab::testing::changed_pixels(a, b, at, px_3cm);
  EXPECT_GT(changed.near, 10) << "no visible change at the contact (" << at.transpose() << ")";
  EXPECT_EQ(changed.far, 0) << "pixels changed more than 3 cm (" << px_3cm
                            << " px) from the contact";
}

TEST(CliRender, PrototypeAShowsOnlyTheMarkerWhenPressed) {
  // Prototype A draws no deformation: the press changes just the contact marker.
  const std::string cam = " --camera 0,20 --size 320x240";
  const fs::path still = tmp("a_rest.png"), pressed = tmp("a_pressed.png");
  Result r = cli("render " + proto("A") + cam + " --out " + still.string());
  if (r.code == 3) GTEST_SKIP() << "no EGL device: " << r.out;
  ASSERT_EQ(r.code, 0) << r.out;
  r = cli("render " + proto("A") + cam + " --press ovary_left --force 2 --out " + pressed.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("visible deformation 0 mm"), std::string::npos) << r.out;
  const pr::Image a = pr::read_png(still.string()), b = pr::read_png(pressed.string());
  const long changed = palplab::testing::changed_pixels(a, b).total();
  EXPECT_GT(changed, 0);
  EXPECT_LT(changed, 60);  // a marker of 1.2% of the organ's radius
}

TEST(CliRender, BadInputExitsTwo) {
  const std::string out = " --out " + tmp("x.png").string();
  EXPECT_EQ(cli("render " + proto("A") + " --size 12x" + out).code, 2);
  EXPECT_EQ(cli("render " + proto("A") + " --size 10x10" + out).code, 2);
  EXPECT_EQ(cli("render " + proto("A") + " --camera 10" + out).code, 2);
  EXPECT_EQ(cli("render " + proto("A") + " --camera 0,95" + out).code, 2);
  // Review 2026-12-06 (second): a camera 1e300 m away drew a white image with exit 0.
  // "30,25,": the empty last item was dropped (review 2026-12-06, second).
  for (const char* camera :
       {"30,20,1e300", "30,20,101", "30,20,0", "1e10,20", "-361,0", "30,25,", "30,,1"}) {
    const Result r = cli("render " + proto("A") + " --camera " + camera + out);
    EXPECT_EQ(r.code, 2) << camera << r.out;
    EXPECT_NE(r.out.find("--camera: "), std::string::npos) << r.out;
  }
  EXPECT_EQ(cli("render " + proto("A") + " --press liver --force 2" + out).code, 2);
  EXPECT_EQ(cli("render " + proto("A") + " --press ovary_left" + out).code, 2);
  EXPECT_EQ(cli("render " + proto("A") + " --alpha body" + out).code, 2);
  EXPECT_EQ(cli("render " + proto("A") + " --alpha spleen=0.5" + out).code, 2);
  EXPECT_EQ(cli("render " + proto("A") + " --out /nonexistent/dir/x.png").code, 2);
  // Flags another flag makes meaningless were silently ignored: exit 2 naming both.
  const Result hold = cli("render " + proto("A") + " --hold 1" + out);
  EXPECT_EQ(hold.code, 2) << hold.out;
  EXPECT_NE(hold.out.find("--hold: applies only with --press"), std::string::npos) << hold.out;
  const Result ta = cli("render " + proto("A") + " --transparent-alpha 0.3" + out);
  EXPECT_EQ(ta.code, 2) << ta.out;
  EXPECT_NE(ta.out.find("--transparent-alpha: applies only with --transparent"), std::string::npos)
      << ta.out;
}

// Review finding: `render P.json --out P.json` replaced the prototype with a PNG. Checked before
// the still, so no EGL is needed for the refusals.
TEST(CliRender, OutNeverReplacesThePrototypeOrAFileOfAnotherKind) {
  const fs::path p = tmp("own_A.json");
  fs::copy_file(proto("A"), p, fs::copy_options::overwrite_existing);
  const auto bytes = fs::file_size(p);
  Result r = cli("render " + p.string() + " --out " + p.string() + " --overwrite");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("is the prototype file this command reads"), std::string::npos) << r.out;
  EXPECT_EQ(fs::file_size(p), bytes);
  const fs::path other = tmp("other.json");
  fs::copy_file(proto("B"), other, fs::copy_options::overwrite_existing);
  r = cli("render " + p.string() + " --out " + other.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("exists and is a JSON file, not a PNG image"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--overwrite"), std::string::npos) << r.out;
  EXPECT_EQ(fs::file_size(other), fs::file_size(proto("B")));
}

// An --alpha opacity out of [0, 1] or an unknown region was refused by the renderer with
// "opacity of region ..." / "unknown region ..." (no flag named), and a region given twice took
// the last value silently. Checked before the still, so no EGL is needed. --force and
// --transparent-alpha said "got null" for NaN.
TEST(CliRender, AlphaAndNumericErrorsNameTheFlag) {
  namespace t = palplab::testing;
  const fs::path png = tmp("alpha.png");
  const std::string base = "render " + proto("A") + " --out " + png.string() + " ";
  struct Case {
    std::string args;
    std::vector<std::string> shown;
  };
  const std::vector<Case> cases = {
      {"--alpha body=2", {"--alpha: \"body=2\"", "[0, 1]", "got 2"}},
      {"--alpha body=-0.5", {"--alpha: \"body=-0.5\"", "got -0.5"}},
      {"--alpha body=nan", {"--alpha:", "nan"}},
      {"--alpha spleen=0.5",
       {"--alpha: \"spleen=0.5\"", "unknown region \"spleen\"", "ovary_left"}},
      {"--alpha body=0.5 --alpha body=0.4", {"--alpha:", "\"body\" given twice"}},
      {"--press ovary_left --force nan", {"--force:", "got 'nan'"}},
      {"--press ovary_left --force 2 --hold inf", {"--hold:", "got 'inf'"}},
      {"--transparent body --transparent-alpha nan", {"--transparent-alpha:", "got 'nan'"}},
      {"--transparent body --transparent-alpha 1", {"--transparent-alpha:", "[0, 1)", "got '1'"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args);
    const t::CliResult r = t::run_palplab(base + c.args);
    EXPECT_EQ(r.code, 2) << r.err;
    for (const auto& s : c.shown) EXPECT_TRUE(t::has(r.err, s)) << r.err << "\nmissing: " << s;
    EXPECT_FALSE(t::has(r.err, "null")) << r.err;
    EXPECT_FALSE(fs::exists(png));
  }
}

TEST(CliView, FramesAndScreenshotUnderXvfb) {
  if (std::system("command -v xvfb-run >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "xvfb-run not installed (.ci/install-deps installs xvfb)";
  const fs::path shot = tmp("view.png");
  const Result r = run(palplab::testing::xvfb_run("1024x768x24", tmp("Xauthority")) +
                       std::string(PALPLAB_BINARY) + " view " + proto("A") +
                       " --frames 30 --size 640x480 --screenshot " + shot.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const pr::Image img = pr::read_png(shot.string());
  ASSERT_EQ(img.width, 640);
  ASSERT_EQ(img.height, 480);
  // The organ (coloured) and the panel (dark) are both drawn.
  long organ = 0, dark = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const auto* p = img.pixel(x, y);
      const int mx = std::max({p[0], p[1], p[2]}), mn = std::min({p[0], p[1], p[2]});
      organ += y > 300 && mx - mn > 40;  // below the panel
      dark += x < 300 && y < 200 && mx < 60;
    }
  EXPECT_GT(organ, 1000);
  EXPECT_GT(dark, 5000);
  EXPECT_EQ(cli("view " + proto("A") + " --screenshot " + shot.string()).code, 2);
}

TEST(CliView, SlowUdpDeviceIsRefusedBeforeAnyWindowOpens) {
  // No bridge on this port: 0 Hz < 900 Hz. Needs no display.
  const Result r = cli("view " + proto("A") + " --device udp:" +
                       std::to_string(palplab::testing::free_udp_port()) + " --frames 1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("below the required 900 Hz"), std::string::npos) << r.out;
  EXPECT_EQ(cli("view " + proto("A") + " --device serial:1 --frames 1").code, 2);
  EXPECT_EQ(cli("view " + proto("A") + " --device trace:/nonexistent.trace --frames 1").code, 2);
}

TEST(CliView, NoDisplayExits2) {
  const Result r = run("env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(PALPLAB_BINARY) +
                       " view " + proto("A") + " --frames 1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("view needs a window"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("DISPLAY"), std::string::npos) << r.out;
}

// --screenshot and --record-trace replaced any file, a results database too (review 2026-12-06,
// eighth): a file of another kind is refused before any window opens (no display needed), as by
// render, report and trace-export; --overwrite replaces it; an input is never an output.
TEST(CliView, OutputsNeverReplaceAFileOfAnotherKindOrAnInput) {
  const fs::path db = tmp("victim.db");
  {
    std::ofstream o(db, std::ios::binary);
    o << std::string("SQLite format 3\0", 16) << std::string(4080, '\0');
  }
  const std::string before = palplab::testing::slurp(db);
  const std::string headless = "env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(PALPLAB_BINARY);
  for (const std::string flag : {"--screenshot", "--record-trace"}) {
    Result r = run(headless + " view " + proto("A") + " --frames 1 " + flag + " " + db.string());
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_TRUE(palplab::testing::has(
        r.out, flag + ": \"" + db.string() + "\" exists and is an SQLite database, not a "))
        << r.out;
    EXPECT_TRUE(palplab::testing::has(r.out, "give --overwrite to replace it")) << r.out;
    EXPECT_EQ(palplab::testing::slurp(db), before);
    // With --overwrite the check passes (the run then needs a window: no display here).
    r = run(headless + " view " + proto("A") + " --frames 1 --overwrite " + flag + " " +
            db.string());
    EXPECT_TRUE(palplab::testing::has(r.out, "view needs a window")) << r.out;
  }
  Result r = run(headless + " view " + proto("A") + " --frames 1 --screenshot " + proto("A"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(palplab::testing::has(r.out, "the prototype file")) << r.out;
  r = run(headless + " view " + proto("A") + " --frames 1 --screenshot " + tmp("s.png").string() +
          " --record-trace " + tmp("s.png").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_TRUE(palplab::testing::has(r.out, "is the --screenshot file too")) << r.out;
}

TEST(CliView, RecordTraceThenReplayItUnderXvfb) {
  if (std::system("command -v xvfb-run >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "xvfb-run not installed (.ci/install-deps installs xvfb)";
  const fs::path trace = tmp("view.trace"), shot = tmp("replay.png");
  const std::string xvfb =
      palplab::testing::xvfb_run("800x600x24", tmp("Xauthority")) + std::string(PALPLAB_BINARY);
  Result r = run(xvfb + " view " + proto("B") + " --frames 20 --size 320x240 --record-trace " +
                 trace.string());
  ASSERT_EQ(r.code, 0) << r.out;
  std::FILE* f = std::fopen(trace.c_str(), "r");
  ASSERT_TRUE(f);
  char line[64] = {};
  ASSERT_TRUE(std::fgets(line, sizeof line, f));
  std::fclose(f);
  EXPECT_EQ(std::string(line), "# palplab-trace/1\n");
  EXPECT_NE(r.out.find("samples)"), std::string::npos) << r.out;
  r = run(xvfb + " view " + proto("B") + " --frames 10 --size 320x240 --device trace:" +
          trace.string() + " --screenshot " + shot.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(pr::read_png(shot.string()).width, 320);
}

// The ST cue is always a visible flash: prototype A (audio cue on, ST 2 N, 500 N/m) pressed
// through the scripted mouse past ST lights the window border; the same window without the press
// leaves it as drawn. The tone goes to ALSA's null device (no sound card needed).
TEST(CliView, StCueFlashesTheBorderWhenTheForceCrossesSt) {
  if (std::system("command -v xvfb-run >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "xvfb-run not installed (.ci/install-deps installs xvfb)";
  const int W = 400, H = 300;
  const auto scene = palplab::prototypes::build_scene(proto("A"));
  const auto& g = scene.geometry();
  Eigen::Vector3d c;
  double rad = 0;
  pr::bounding_sphere(g.V, c, rad);
  // Where the surface faces the camera: the press along the view ray goes straight in.
  const auto px = pr::head_on_pixel(g, pr::camera_matrices(pr::Camera{}, c, rad, W, H));
  ASSERT_TRUE(px && px->cosine > 0.95);
  long tone_ms = -1;
  auto shot_with = [&](int notches, const std::string& name) {
    const fs::path script = tmp(name + ".json"), shot = tmp(name + ".png");
    {
      std::ofstream o(script);
      o << "{\"palplab_mouse_script\": 1, \"events\": [{\"t\": 0, \"x\": " << px->x
        << ", \"y\": " << px->y << ", \"left\": true}, {\"t\": 0.05, \"wheel\": " << notches
        << "}]}";
    }
    const Result r = run("PALPLAB_AUDIO_DEVICE=null " +
                         palplab::testing::xvfb_run("640x480x24", tmp("Xauthority")) +
                         std::string(PALPLAB_BINARY) + " view " + proto("A") + " --size " +
                         std::to_string(W) + "x" + std::to_string(H) + " --mouse-script " +
                         script.string() + " --frames 20 --screenshot " + shot.string());
    EXPECT_EQ(r.code, 0) << r.out << r.err;
    // How long the tone sounded (the haptic thread switches it; ALSA's null device plays it).
    const auto at = r.out.find("ST tone: ");
    EXPECT_NE(at, std::string::npos) << r.out;
    tone_ms = at == std::string::npos ? -1 : std::atol(r.out.c_str() + at + 9);
    return pr::read_png(shot.string());
  };
  // The bottom border strip (12 px), right of the panel: flash yellow (255, 217, 26) at 85%.
  auto flash_share = [&](const pr::Image& img) {
    long n = 0, yellow = 0;
    for (int y = img.height - 10; y < img.height; ++y)
      for (int x = img.width / 2; x < img.width; ++x, ++n) {
        const auto* p = img.pixel(x, y);
        yellow += p[0] > 200 && p[1] > 160 && p[2] < 110;
      }
    return static_cast<double>(yellow) / n;
  };
  const pr::Image pressed = shot_with(8, "st_pressed");  // 6 mm in, head-on: ~3 N > ST
  const long pressed_tone_ms = tone_ms;
  const pr::Image light = shot_with(0, "st_light");  // 2 mm outside: no force
  EXPECT_GT(pressed_tone_ms, 50);  // the press lasts from ~0.05 s to the last of 20 frames
  EXPECT_EQ(tone_ms, 0);
  ASSERT_EQ(pressed.width, W);
  ASSERT_EQ(light.width, W);
  EXPECT_GT(flash_share(pressed), 0.95);
  EXPECT_LT(flash_share(light), 0.05);
}
