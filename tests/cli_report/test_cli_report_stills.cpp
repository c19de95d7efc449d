// The report's stills end to end: a small study with prototypes A and B is run and reported;
// the report shows a still per prototype under the same press (the study's feature at its MPF),
// each PNG exists at the size asked, the prototypes' stills differ, and each pressed still
// differs from the same view at rest near the contact and nowhere far from it. Without EGL (or
// with --no-stills) the report is still written and says in one line why it has no stills.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "../cli_support.hpp"
#include "../render_support.hpp"
#include "../sqlite_support.hpp"
#include "engine/haptics/press.hpp"
#include "engine/render/camera.hpp"
#include "engine/render/image.hpp"
#include "prototypes/factory.hpp"

namespace fs = std::filesystem;
namespace pr = palplab::render;
using palplab::testing::CliResult;
using palplab::testing::run_shell;
using palplab::testing::slurp;

namespace {

const char* kStillsStudy = R"({
  "palplab_study": 1,
  "id": "cli_report_stills",
  "title": "Report stills check",
  "seed": 3,
  "prototype_dirs": ["@PROTOTYPES@"],
  "task": {"feature": "ovary_left", "thresholds": {"*": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}}},
  "groups": [
    {"id": "GA", "prototype": "A", "size": 1},
    {"id": "GB", "prototype": "B", "size": 1}
  ],
  "phases": [{"id": "test", "kind": "post_training", "sessions": 1, "session_duration": 1}]
})";

std::string proto(const std::string& id) {
  return std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + id + ".json";
}

Eigen::Vector3d vec(const nlohmann::json& j) {
  return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()};
}

// One database for every test of this file (the run is the slow part).
class ReportStills : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = palplab::testing::scratch_dir("cli_report_stills");
    std::string study = kStillsStudy;
    study.replace(study.find("@PROTOTYPES@"), 12, std::string(PALPLAB_SOURCE_DIR) + "/prototypes");
    std::ofstream(dir_ / "study.json") << study;
    run_ = run_shell(std::string(PALPLAB_BINARY) + " run " + (dir_ / "study.json").string() +
                         " --quiet --db " + (dir_ / "s.db").string(),
                     dir_);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  void SetUp() override { ASSERT_EQ(run_.code, 0) << run_.err; }
  static CliResult report(const std::string& out, const std::string& extra,
                          const std::string& env = "") {
    return run_shell(env + std::string(PALPLAB_BINARY) + " report " + (dir_ / "s.db").string() +
                         " --out " + (dir_ / out).string() + " " + extra,
                     dir_);
  }
  static inline fs::path dir_;
  static inline CliResult run_;
};

}  // namespace

TEST_F(ReportStills, EveryPrototypeUnderTheSamePressSideBySide) {
  const int W = 240, H = 180;
  const CliResult r = report("rep", "--still-size 240x180");
  ASSERT_EQ(r.code, 0) << r.err;
  if (r.err.find("stills skipped: no headless OpenGL") != std::string::npos)
    GTEST_SKIP() << "no EGL device on this machine: " << r.err;
  EXPECT_NE(r.out.find(", 2 stills"), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("still"), std::string::npos) << r.err;  // nothing skipped
  const fs::path rep = dir_ / "rep";
  const std::string md = slurp(rep / "report.md");
  EXPECT_NE(md.find("## Prototypes under the same press"), std::string::npos);
  // The press is named: the study's feature at its target force (the MPF, 2.5 N).
  EXPECT_NE(md.find("region ovary_left (the feature of phase test) with the target force 2.5 N"),
            std::string::npos)
      << md.substr(0, 3000);
  // Side by side: one Markdown table row of pressed stills, one of rest stills.
  EXPECT_NE(md.find("| ![A under 2.5 N](stills/A_pressed.png) | ![B under 2.5 N]"
                    "(stills/B_pressed.png) |"),
            std::string::npos);
  EXPECT_NE(md.find("| ![A at rest](stills/A_rest.png) | ![B at rest](stills/B_rest.png) |"),
            std::string::npos);
  // report.html stays self-contained: the four PNGs inline, in one row of two figures.
  const std::string html = slurp(rep / "report.html");
  long inline_png = 0;
  for (size_t at = 0;
       (at = html.find("src=\"data:image/png;base64,iVBORw0KGgo", at)) != std::string::npos; ++at)
    ++inline_png;
  EXPECT_EQ(inline_png, 4);
  EXPECT_NE(html.find("<div class=\"stills\">\n<figure class=\"still\">"), std::string::npos);

  const auto side = nlohmann::json::parse(slurp(rep / "stills" / "stills.json"));
  EXPECT_EQ(side["press"]["region"], "ovary_left");
  EXPECT_EQ(side["press"]["force"], 2.5);
  EXPECT_EQ(side["width"], W);
  ASSERT_EQ(side["stills"].size(), 2u);
  std::map<std::string, pr::Image> pressed;
  for (const auto& s : side["stills"]) {
    const std::string id = s["prototype"];
    SCOPED_TRACE("prototype " + id);
    ASSERT_FALSE(s.contains("skipped")) << s.dump();
    EXPECT_EQ(s["groups"], "G" + id);
    const pr::Image p = pr::read_png((rep / s["pressed"].get<std::string>()).string());
    const pr::Image a = pr::read_png((rep / s["rest"].get<std::string>()).string());
    ASSERT_EQ(p.width, W);
    ASSERT_EQ(p.height, H);
    ASSERT_EQ(a.width, W);
    ASSERT_EQ(a.height, H);
    EXPECT_TRUE(s["force_reached"].get<bool>());
    EXPECT_NEAR(s["force_at_still"].get<double>(), 2.5, 0.1);

    // The press is where the study says: the node of ovary_left the press script picks, and
    // the stored camera puts it at the image centre with the whole organ in view.
    const auto scene = palplab::prototypes::build_scene(proto(id));
    const auto& g = scene.geometry();
    const int node = palplab::engine::press_node(g, "ovary_left");
    EXPECT_EQ(s["node"], node);
    const Eigen::Vector3d point = g.V.row(node).transpose();
    EXPECT_LT((vec(s["camera"]["pressed_point"]) - point).norm(), 1e-9);
    Eigen::Vector3d centre;
    double radius = 0.0;
    pr::bounding_sphere(g.V, centre, radius);
    pr::Camera cam;
    cam.azimuth_deg = s["camera"]["azimuth_deg"];
    cam.elevation_deg = s["camera"]["elevation_deg"];
    cam.distance = s["camera"]["distance"];
    cam.target = vec(s["camera"]["target"]);
    const pr::CameraMatrices m = pr::camera_matrices(cam, centre, radius, W, H);
    const Eigen::Vector2d at = m.project(point);
    EXPECT_NEAR(at.x(), W / 2.0, 0.5);
    EXPECT_NEAR(at.y(), H / 2.0, 0.5);
    // Seen from outside: the camera is on the side the outward normal points to.
    EXPECT_GT((m.eye - point).dot(vec(s["camera"]["normal"])), 0.0);
    EXPECT_GT(palplab::testing::coverage(a).count, W * H / 20);

    // Pressed vs at rest: changes near the contact (B's dent, A's contact marker only), none
    // more than 3 cm from it.
    const double px_3cm = palplab::testing::pixels_spanned(m, point, 0.03);
    ASSERT_GT(px_3cm, 3.0);
    const auto changed = palplab::testing::changed_pixels(a, p, at, px_3cm);
    EXPECT_GT(changed.near, id == "B" ? 10 : 0);
    EXPECT_EQ(changed.far, 0) << "pixels changed more than 3 cm (" << px_3cm << " px) away";
    if (id == "A") {
      EXPECT_EQ(s["visible_deformation"], 0.0);  // A draws no deformation
    } else {
      EXPECT_GT(s["visible_deformation"].get<double>(), 1e-3);
    }
    pressed[id] = p;
  }
  // The prototypes' stills are not the same picture.
  EXPECT_GT(palplab::testing::changed_pixels(pressed["A"], pressed["B"]).total(), 100);
}

TEST_F(ReportStills, SwitchedOffOrWithoutEglTheReportSaysWhy) {
  CliResult r = report("off", "--no-stills");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find(", 0 stills"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("palplab report: stills skipped: switched off (--no-stills)\n"),
            std::string::npos)
      << r.err;
  EXPECT_NE(slurp(dir_ / "off" / "report.md").find("Stills skipped: switched off (--no-stills)."),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "off" / "stills"));

  // No EGL vendor for libglvnd: rendering cannot start, the report is written all the same.
  r = report("noegl", "", "__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json ");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("palplab report: stills skipped: no headless OpenGL 3.3 core context (EGL)"),
            std::string::npos)
      << r.err;
  const std::string md = slurp(dir_ / "noegl" / "report.md");
  EXPECT_NE(md.find("Stills skipped: no headless OpenGL 3.3 core context (EGL)"),
            std::string::npos);
  EXPECT_NE(md.find("## Example force traces"), std::string::npos);  // the rest is there

  EXPECT_EQ(report("bad", "--still-size 10x10").code, 2);
  EXPECT_EQ(report("bad", "--still-size wide").code, 2);
}

// A prototype file that is gone since the run is drawn from the JSON stored with the results
// (it alone defines prototype A: no mesh file); a stored copy that is not the file the run used
// (its SHA-256 differs) is not drawn, and the report says why.
TEST_F(ReportStills, PrototypeFileGoneIsDrawnFromTheStoredCopyOrSkippedWithWhy) {
  const fs::path db = dir_ / "moved.db";
  fs::copy_file(dir_ / "s.db", db, fs::copy_options::overwrite_existing);
  auto sql = [&](const std::string& q) { palplab::testing::sql_exec(db, q); };
  sql("UPDATE prototypes SET path = '/nonexistent/A.json' WHERE prototype = 'A'");
  CliResult r = run_shell(std::string(PALPLAB_BINARY) + " report " + db.string() + " --out " +
                              (dir_ / "moved").string() + " --still-size 160x120",
                          dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  if (r.err.find("stills skipped: no headless OpenGL") != std::string::npos)
    GTEST_SKIP() << "no EGL device on this machine: " << r.err;
  EXPECT_NE(r.out.find(", 2 stills"), std::string::npos) << r.out << r.err;
  auto side = nlohmann::json::parse(slurp(dir_ / "moved" / "stills" / "stills.json"));
  ASSERT_EQ(side["stills"].size(), 2u);
  EXPECT_EQ(side["stills"][0]["note"],
            "drawn from the prototype JSON stored with the results: its file /nonexistent/A.json "
            "no longer exists");
  EXPECT_EQ(pr::read_png((dir_ / "moved" / "stills" / "A_pressed.png").string()).width, 160);

  sql("UPDATE prototypes SET json = json || ' ' WHERE prototype = 'A'");
  r = run_shell(std::string(PALPLAB_BINARY) + " report " + db.string() + " --out " +
                    (dir_ / "moved2").string() + " --still-size 160x120",
                dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find(", 1 still ("), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("palplab report: no still of prototype A: its file /nonexistent/A.json no "
                       "longer exists, and the JSON stored with the results is not the whole "
                       "prototype as run"),
            std::string::npos)
      << r.err;
  EXPECT_NE(slurp(dir_ / "moved2" / "report.md").find("No still of prototype A: its file"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "moved2" / "stills" / "A_pressed.png"));
}

// A report written into a directory that holds an earlier report leaves only its own figures
// and stills: the earlier report's figures and the stills its stills.json listed that this
// report does not write are removed and named on stdout (review 2026-12-06: another study's
// report kept its figures and stills beside the new one); the user's files are never touched.
TEST_F(ReportStills, AnEarlierReportsFiguresAndStillsDoNotStayBesideTheNewOne) {
  const fs::path rep = dir_ / "again";
  CliResult r = report("again", "--still-size 64x48");
  ASSERT_EQ(r.code, 0) << r.err;
  if (r.err.find("stills skipped: no headless OpenGL") != std::string::npos)
    GTEST_SKIP() << "no EGL device on this machine: " << r.err;
  EXPECT_EQ(r.out.find("removed"), std::string::npos) << r.out;  // nothing earlier
  // An earlier report of another study: a figure and a prototype Z this one does not have.
  fs::copy_file(rep / "figures" / "force_traces.svg", rep / "figures" / "other_study.svg");
  fs::copy_file(rep / "stills" / "A_pressed.png", rep / "stills" / "Z_pressed.png");
  fs::copy_file(rep / "stills" / "A_rest.png", rep / "stills" / "Z_rest.png");
  auto side = nlohmann::json::parse(slurp(rep / "stills" / "stills.json"));
  side["stills"].push_back({{"prototype", "Z"},
                            {"pressed", "stills/Z_pressed.png"},
                            {"rest", "stills/Z_rest.png"},
                            {"escape", "stills/../report.md"}});
  side["stills"].push_back({{"prototype", "Y"}, {"pressed", "../report.md"}});
  // A listing may name only stills: the user's file it lists is not one (review 2026-12-06).
  side["stills"].push_back({{"prototype", "N"}, {"pressed", "stills/readme.txt"}});
  std::ofstream(rep / "stills" / "stills.json") << side.dump(2);
  // The user's own files there, and a file named like a still that no listing names.
  std::ofstream(rep / "figures" / "notes.txt") << "mine\n";
  std::ofstream(rep / "stills" / "readme.txt") << "mine\n";
  fs::copy_file(rep / "stills" / "A_rest.png", rep / "stills" / "X_rest.png");

  // X_rest.png is refused as not palplab's (no listing names it) unless --overwrite.
  r = report("again", "--still-size 64x48");
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("X_rest.png"), std::string::npos) << r.err;
  r = report("again", "--still-size 64x48 --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("removed 3 files of an earlier report in " + rep.string() +
                       " that this report does not have:\n  " +
                       (rep / "figures" / "other_study.svg").string()),
            std::string::npos)
      << r.out;
  for (const char* gone : {"figures/other_study.svg", "stills/Z_pressed.png", "stills/Z_rest.png"})
    EXPECT_FALSE(fs::exists(rep / gone)) << gone;
  for (const char* kept :
       {"figures/notes.txt", "stills/readme.txt", "stills/X_rest.png", "stills/A_pressed.png",
        "stills/B_rest.png", "figures/force_traces.svg", "report.md"})
    EXPECT_TRUE(fs::exists(rep / kept)) << kept;

  // A report without stills leaves none of the earlier report's stills, nor their listing.
  r = report("again", "--no-stills");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("removed 5 files of an earlier report"), std::string::npos) << r.out;
  for (const char* gone : {"stills/A_pressed.png", "stills/A_rest.png", "stills/B_pressed.png",
                           "stills/B_rest.png", "stills/stills.json"})
    EXPECT_FALSE(fs::exists(rep / gone)) << gone;
  for (const char* kept : {"stills/readme.txt", "stills/X_rest.png", "figures/force_traces.svg"})
    EXPECT_TRUE(fs::exists(rep / kept)) << kept;

  // figures/ or stills/ a link to a directory elsewhere: refused (the report would write and
  // remove files outside --out), nothing there touched.
  const fs::path elsewhere = dir_ / "elsewhere";
  fs::create_directories(elsewhere);
  fs::copy_file(rep / "figures" / "force_traces.svg", elsewhere / "old.svg");
  fs::create_directories(dir_ / "linked");
  fs::create_directory_symlink(elsewhere, dir_ / "linked" / "figures");
  r = report("linked", "--no-stills");
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find((dir_ / "linked" / "figures").string() +
                       "\" is a symbolic link; the report writes its figures there and never "
                       "through a link"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::exists(elsewhere / "old.svg"));
}

// A still that cannot be written (a full disk; here a file-size limit of 64 KiB, below the
// PNGs at 800×600) is named with the system's reason, without libpng's own "libpng error: Write
// Error" line, and no cut-off PNG is left; the report is written without stills and says why
// (review 2026-12-06). A limit below SQLite's 32 KiB -shm file stops the report at the
// database, said as an I/O failure (it was "not a palplab results database"). sh's `ulimit -f`
// counts 512-byte blocks.
TEST_F(ReportStills, AStillThatCannotBeWrittenIsNamedWithTheReason) {
  const fs::path out = dir_ / "full";
  auto limited = [&](int blocks) {
    return run_shell("trap '' XFSZ; ulimit -f " + std::to_string(blocks) + "; " +
                         std::string(PALPLAB_BINARY) + " report " + (dir_ / "s.db").string() +
                         " --out " + out.string() + " --still-size 800x600",
                     dir_);
  };
  CliResult r = limited(128);
  if (r.err.find("stills skipped: no headless OpenGL") != std::string::npos)
    GTEST_SKIP() << "no EGL device on this machine: " << r.err;
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  for (const char* id : {"A", "B"}) {
    EXPECT_NE(r.err.find("palplab report: no still of prototype " + std::string(id) + ": " +
                         (out / "stills" / (std::string(id) + "_pressed.png")).string() +
                         ": cannot write the PNG (File too large)\n"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(out / "stills" / (std::string(id) + "_pressed.png"))) << id;
  }
  EXPECT_EQ(r.err.find("libpng"), std::string::npos) << r.err;
  EXPECT_NE(slurp(out / "report.md").find("## Example force traces"), std::string::npos);

  r = limited(1);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find((dir_ / "s.db").string() +
                       ": cannot read the database (disk I/O error: File too large)"),
            std::string::npos)
      << r.err;
}
