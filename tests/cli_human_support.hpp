#pragma once
// What the end-to-end tests of human sessions share (tests/cli_run_human, tests/cli_needle):
// the `palplab run --human` command line (a fixed PALPLAB_NOW, participant P01), the same under
// Xvfb with a scripted mouse, the pixel where the window's default camera sees a prototype
// head-on, and the rows of a query on the study database.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "engine/render/camera.hpp"
#include "engine/render/pick.hpp"
#include "prototypes/factory.hpp"
#include "tests/cli_support.hpp"

namespace palplab::testing {

// The clock of every scripted human session: P01's first session is due then.
inline const std::string kHumanNow = "2026-11-24T10:00:00Z";

// `palplab run STUDY --db DB --human --participant P01 --device DEVICE EXTRA` at PALPLAB_NOW =
// `now`; `wrapper` (ending in a space) runs the binary under another command (xvfb-run).
inline std::string human_run(const std::string& study, const std::filesystem::path& db,
                             const std::string& device, const std::string& extra = "",
                             const std::string& now = kHumanNow, const std::string& wrapper = "") {
  return "PALPLAB_NOW=" + now + " " + wrapper + std::string(PALPLAB_BINARY) + " run " + study +
         " --db " + db.string() + " --human --participant P01 --device " + device +
         (extra.empty() ? "" : " " + extra);
}

// xvfb-run is installed (the mouse sessions skip without it).
inline bool have_xvfb() {
  return std::system("command -v xvfb-run >/dev/null 2>&1") == 0;
}
inline const char* const kNoXvfb = "xvfb-run not installed (.ci/install-deps installs xvfb)";

// The palpation window (w x h pixels) under Xvfb, no sound, driven by the mouse script.
inline std::string mouse_run(const std::string& study, const std::filesystem::path& db,
                             const std::filesystem::path& script, int w, int h) {
  return human_run(
      study, db, "mouse",
      "--size " + std::to_string(w) + "x" + std::to_string(h) + " --mouse-script " +
          script.string(),
      kHumanNow,
      "PALPLAB_AUDIO_DEVICE=null " + xvfb_run("640x480x24", db.parent_path() / "Xauthority"));
}

// The pixel where the window's default camera (the renderer centres the rest bounding sphere)
// sees the prototype `name` (prototypes/<name>.json) most nearly head-on in a w x h window.
inline std::optional<render::HeadOnPixel> head_on_pixel_of(const std::string& name, int w, int h) {
  const auto scene =
      prototypes::build_scene(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/" + name + ".json");
  Eigen::Vector3d c;
  double r = 0;
  render::bounding_sphere(scene.geometry().V, c, r);
  return render::head_on_pixel(scene.geometry(),
                               render::camera_matrices(render::Camera{}, c, r, w, h));
}

// The rows of `sql` on the database `db` (read-only), each column as text ("NULL" for null).
inline std::vector<std::map<std::string, std::string>> db_rows(const std::filesystem::path& db,
                                                               const std::string& sql) {
  sqlite3* h = nullptr;
  sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr);
  sqlite3_stmt* s = nullptr;
  const int rc = sqlite3_prepare_v2(h, sql.c_str(), -1, &s, nullptr);
  EXPECT_EQ(rc, SQLITE_OK) << sql << ": " << sqlite3_errmsg(h);
  std::vector<std::map<std::string, std::string>> out;
  while (s && sqlite3_step(s) == SQLITE_ROW) {
    std::map<std::string, std::string> row;
    for (int i = 0; i < sqlite3_column_count(s); ++i) {
      const auto* t = sqlite3_column_text(s, i);
      row[sqlite3_column_name(s, i)] = t ? reinterpret_cast<const char*>(t) : "NULL";
    }
    out.push_back(row);
  }
  sqlite3_finalize(s);
  sqlite3_close(h);
  return out;
}

}  // namespace palplab::testing
