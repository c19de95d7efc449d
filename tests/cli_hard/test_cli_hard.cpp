// Issue 10, "Hard cases": every reproduced file/JSON/database case, run through the palplab
// binary. Each must end in exit 2 with a located message (or, where the issue says so, exit 0
// with a clear warning) — never a signal, a hang or exit 3.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

#include "results/store.hpp"
#include "tests/cli_support.hpp"
#include "tests/sqlite_support.hpp"

namespace fs = std::filesystem;

namespace {

struct Result {
  int code = -1;   // exit status; -1 when killed by a signal
  int signal = 0;  // the signal, if any
  std::string out, err;
  double seconds = 0;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void spit(const fs::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary) << s;
}

fs::path tmp(const std::string& name) {
  auto d = fs::temp_directory_path() / ("palplab_hard_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Runs palplab with a time limit (`timeout` turns a hang into a failure, not a stuck suite),
// prefixed by `as` (e.g. runuser) when given. 60 s; 300 s under the sanitizers, which run
// palplab ≈ 16 times slower (a resumed run here takes ≈ 1 s in Release, ≈ 20 s under them, and
// a loaded machine doubles that).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr int kCommandLimitS = 300;
#else
constexpr int kCommandLimitS = 60;
#endif
Result cli_as(const std::string& as, const std::string& args, const fs::path& dir) {
  Result r;
  auto out = dir / "stdout.txt", err = dir / "stderr.txt";
  // The repository's prototypes are found last (after the test's own copies in `dir`).
  std::string cmd = "PALPLAB_PROTOTYPE_PATH=" + std::string(PALPLAB_SOURCE_DIR) +
                    "/prototypes timeout -s KILL " + std::to_string(kCommandLimitS) + " " + as +
                    std::string(PALPLAB_BINARY) + " " + args + " >" + out.string() + " 2>" +
                    err.string();
  const auto t0 = std::chrono::steady_clock::now();
  int st = std::system(cmd.c_str());
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  if (WIFSIGNALED(st)) r.signal = WTERMSIG(st);
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

Result cli(const std::string& args, const fs::path& dir) {
  return cli_as("", args, dir);
}

bool has(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

#define EXPECT_EXIT2_WITH(r, part)                                                       \
  do {                                                                                   \
    EXPECT_EQ((r).code, 2) << (r).err << (r).out;                                        \
    EXPECT_TRUE(has((r).err, part)) << "expected \"" << (part) << "\" in:\n" << (r).err; \
  } while (0)

std::string src(const std::string& rel) {
  return (fs::path(PALPLAB_SOURCE_DIR) / rel).string();
}

// A small valid study on prototypes A and B with `body` spliced into the top-level object.
const std::string kGroups = R"([{"id": "G1", "prototype": "A", "size": 1},
                                {"id": "G2", "prototype": "B", "size": 1}])";

std::string study(const std::string& groups = kGroups, const std::string& extra = "",
                  double duration = 0.05) {
  std::ostringstream s;
  s << R"({"palplab_study": 1, "id": "hard", "title": "hard cases", "seed": 1,)" << extra << R"(
  "task": {"feature": "ovary_left", "thresholds": {"*": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}}},
  "groups": )"
    << groups << R"(,
  "phases": [{"id": "pre", "kind": "pre_training", "session_duration": )"
    << duration << R"(, "start": {"day": 0}},
             {"id": "post", "kind": "post_training", "sessions": 2, "session_duration": )"
    << duration << R"(, "start": {"after_previous": {"minutes": 1}}, "gap": {"minutes": 1}}]})";
  return s.str();
}

}  // namespace

// ------------------------------------------------------------------------------------- JSON

TEST(HardJson, DeepNestingIsALocatedErrorNotACrash) {
  auto d = tmp("deep");
  spit(d / "deep.json", std::string(200000, '[') + std::string(200000, ']'));
  Result r = cli("validate " + (d / "deep.json").string(), d);
  EXPECT_EXIT2_WITH(r, "deep.json:1:65: invalid JSON: nested deeper than 64 levels");
  // Inside a valid study too.
  std::string s = study();
  s.insert(s.find("\"task\""),
           "\"description\": " + std::string(5000, '[') + std::string(5000, ']') + ",");
  spit(d / "deep2.json", s);
  r = cli("validate " + (d / "deep2.json").string(), d);
  EXPECT_EXIT2_WITH(r, "nested deeper than 64 levels");
}

TEST(HardJson, IntegersThatWouldWrapAreRangeErrors) {
  auto d = tmp("wrap");
  for (const char* size : {"4294967296", "4294967297", "18446744073709551615",
                           "18446744073709551616", "-9223372036854775809"}) {
    std::string s = study(std::string(R"([{"id": "G1", "prototype": "A", "size": )") + size +
                          R"(}, {"id": "G2", "prototype": "B", "size": 1}])");
    spit(d / "study.json", s);
    Result r = cli("validate " + (d / "study.json").string(), d);
    EXPECT_EQ(r.code, 2) << size << ": " << r.err << r.out;
    EXPECT_TRUE(has(r.err, "$.groups[0].size:")) << size << ": " << r.err;
    EXPECT_FALSE(has(r.out, "0 participants")) << r.out;
  }
  // The same for prototype integers (mesh vertices).
  std::string a = slurp(src("prototypes/A.json"));
  a.replace(a.find("\"vertices\": 1500"), 16, "\"vertices\": 4294968796");
  spit(d / "A.json", a);
  spit(d / "study.json", study());
  Result r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.mesh.vertices: value 4294968796 out of range");
}

TEST(HardJson, HugeNumberIsExitTwoNotThree) {
  auto d = tmp("1e400");
  std::string s = study();
  s.replace(s.find("\"seed\": 1"), 9, "\"seed\": 1e400");
  spit(d / "study.json", s);
  Result r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "study.json:1:");
  EXPECT_TRUE(has(r.err, "number 1e400 is out of range")) << r.err;
  s = study(kGroups, "", 0.05);
  s.replace(s.find("\"session_duration\": 0.05"), 24, "\"session_duration\": -1e400");
  spit(d / "study.json", s);
  r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "number -1e400 is out of range");
  // An absurd but finite duration is a range error, not a run that never ends.
  s = study(kGroups, "", 1e300);
  spit(d / "study.json", s);
  r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.phases[0].session_duration: expected a duration in s of at least 0.01");
  EXPECT_TRUE(has(r.err, "and at most 86400 s (24 h), got 1e+300")) << r.err;
  // So is one shorter than a haptic step (it stored sessions of 0 steps).
  s = study(kGroups, "", 1e-300);
  spit(d / "study.json", s);
  r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "study.json:5:");
  EXPECT_TRUE(has(r.err, "$.phases[0].session_duration: expected a duration in s of at least 0.01"))
      << r.err;
  EXPECT_TRUE(has(r.err, "every session runs at least one step")) << r.err;
}

TEST(HardJson, SessionDurationBetweenTwoStepCountsIsRefused) {
  // 10.5 haptic steps: the session ran 11 and the next one started 0.5 ms before it ended.
  auto d = tmp("halfstep");
  spit(d / "study.json", study(kGroups, "", 0.0105));
  Result r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.phases[0].session_duration: expected a whole number of prototype");
  EXPECT_TRUE(has(r.err, "haptic steps (0.001 s each), got 0.0105 s = 10.5 steps (0.01 or 0.011 s"))
      << r.err;
  // A long session is held to the same whole steps (1000.0005 s passed a relative tolerance
  // and ran 1000.001 s; review 2026-12-07).
  std::string long_study = study(kGroups, "", 0.05);  // (the helper prints 6 digits)
  for (std::size_t k; (k = long_study.find("\"session_duration\": 0.05")) != std::string::npos;)
    long_study.replace(k, 24, "\"session_duration\": 1000.0005");
  spit(d / "study.json", long_study);
  r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "got 1000.0005 s = 1000000.5 steps (1000 or 1000.001 s would do");
  // A whole number of steps written with a rounding error of the decimal is a whole number.
  spit(d / "study.json", study(kGroups, "", 0.07));
  EXPECT_EQ(cli("validate " + (d / "study.json").string(), d).code, 0);
}

TEST(HardJson, AbsurdStartPositionFailsValidateWithItsRange) {
  auto d = tmp("start");
  std::string a = slurp(src("prototypes/A.json"));
  a.replace(a.find("\"haptic_step\""), 0, "\"start_position\": [0, -1e200, 0.1], ");
  spit(d / "A.json", a);
  spit(d / "study.json", study());
  Result r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "A.json:");
  EXPECT_TRUE(has(r.err,
                  "$.start_position[1]: value -1e+200 out of range: expected the device "
                  "start position (m) in [-10.0, 10.0]"))
      << r.err;
  EXPECT_LT(r.seconds, 30);
}

TEST(HardJson, StudyAndPrototypeWordErrorsTheSameWay) {
  auto d = tmp("wording");
  std::string a = slurp(src("prototypes/A.json"));
  a.replace(a.find("\"haptic_step\""), 0, "\"colour\": 1, ");
  spit(d / "A.json", a);
  std::string s = study();
  s.replace(s.find("\"seed\": 1,"), 10, "\"seed\": 1, \"colour\": 1,");
  spit(d / "study.json", s);
  Result r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EQ(r.code, 2);
  // One wording for both files: FILE:LINE:COL: $.colour: unknown key "colour"; expected one of:
  for (const char* f : {"study.json:", "A.json:"}) {
    const auto at = r.err.find(f);
    ASSERT_NE(at, std::string::npos) << r.err;
    const std::string line = r.err.substr(at, r.err.find('\n', at) - at);
    EXPECT_TRUE(has(line, ": $.colour: unknown key \"colour\"")) << line;
    EXPECT_TRUE(has(line, "; expected one of: ")) << line;
  }
}

TEST(HardJson, ValidateTimeIsLinearInTheNumberOfGroups) {
  // 4000 groups took minutes when every value's line/column was found by rescanning the text.
  auto d = tmp("groups");
  std::string g = "[";
  for (int i = 0; i < 4000; ++i)
    g += std::string(i ? "," : "") + "\n{\"id\": \"G" + std::to_string(i) +
         "\", \"prototype\": \"A\", \"size\": 1}";
  g += "]";
  std::string s = study(g);
  s.replace(s.find("\"seed\": 1,"), 10, "\"seed\": 1, \"sed\": 1,");  // one error: no plan
  spit(d / "study.json", s);
  Result r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.sed: unknown key");
  EXPECT_LT(r.seconds, 10) << "validate of 4000 groups";
}

// ------------------------------------------------------------------------------------- meshes

namespace {

// A closed sphere surface as OBJ text (from palplab itself).
std::string sphere_obj(const fs::path& d) {
  EXPECT_EQ(cli("mesh generate sphere --vertices 162 --out " + (d / "s.obj").string(), d).code, 0);
  return slurp(d / "s.obj");
}

void expect_no_crash_tet(const fs::path& d, const fs::path& in, const std::string& part) {
  Result r = cli("mesh tetrahedralize " + in.string() + " --out " + (d / "out").string(), d);
  EXPECT_EQ(r.signal, 0) << in;
  EXPECT_EXIT2_WITH(r, part);
}

}  // namespace

TEST(HardMesh, TetrahedralizeRejectsBrokenSurfacesWithoutDying) {
  auto d = tmp("tet");
  const std::string obj = sphere_obj(d);
  // Empty OBJ, an OBJ with vertices only.
  spit(d / "empty.obj", "");
  expect_no_crash_tet(d, d / "empty.obj", "empty.obj: no geometry");
  spit(d / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  expect_no_crash_tet(d, d / "points.obj", "no geometry");
  // A duplicated face.
  const auto f = obj.find("\nf ");
  const std::string face = obj.substr(f, obj.find('\n', f + 1) - f);
  spit(d / "dupface.obj", obj + face.substr(1) + "\n");
  expect_no_crash_tet(d, d / "dupface.obj", "cannot tetrahedralize: the surface has");
  // Coincident triangles: a second triangle on new vertices at the same place as face 1.
  {
    std::istringstream fs(face.substr(3));
    int a, b, c;
    fs >> a >> b >> c;
    std::istringstream all(obj);
    std::vector<std::string> v;
    for (std::string l; std::getline(all, l);)
      if (l.rfind("v ", 0) == 0) v.push_back(l);
    const int n = static_cast<int>(v.size());
    spit(d / "coincident.obj", obj + v[a - 1] + "\n" + v[b - 1] + "\n" + v[c - 1] + "\nf " +
                                   std::to_string(n + 1) + " " + std::to_string(n + 2) + " " +
                                   std::to_string(n + 3) + "\n");
    expect_no_crash_tet(d, d / "coincident.obj", "cannot tetrahedralize: the surface has");
  }
  // NaN coordinates.
  std::string nan = obj;
  nan.replace(nan.find("\nv ") + 3, 0, "nan ");
  nan.erase(nan.find("nan ") + 4, nan.find(' ', nan.find("nan ") + 4) - nan.find("nan ") - 4 + 1);
  spit(d / "nan.obj", nan);
  Result r =
      cli("mesh tetrahedralize " + (d / "nan.obj").string() + " --out " + (d / "out").string(), d);
  EXPECT_EQ(r.signal, 0);
  EXPECT_EQ(r.code, 2) << r.err;
  // A degenerate (flat) closed surface: two triangles on top of each other.
  spit(d / "flat.off",
       "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 0 2 1\n3 1 3 2\n3 1 2 3\n");
  expect_no_crash_tet(d, d / "flat.off", "cannot tetrahedralize");
  // Out-of-range indices.
  spit(d / "index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n");
  expect_no_crash_tet(d, d / "index.obj", "index.obj:4:");
}

TEST(HardMesh, BitFlippedBinaryStlNeverKillsPalplab) {
  auto d = tmp("stl");
  ASSERT_EQ(
      cli("mesh generate sphere --vertices 162 --out " + (d / "s.stl").string() + " --binary", d)
          .code,
      0);
  const std::string good = slurp(d / "s.stl");
  ASSERT_GT(good.size(), 200u);
  int refused = 0;
  // Flip single bits in the count, in coordinates (exponent bits make huge/NaN values) and in
  // the attribute bytes.
  for (std::size_t off : {80ul, 83ul, 84ul + 12 + 3, 84ul + 12 + 7, 84ul + 50 + 24 + 3,
                          good.size() - 2, good.size() / 2 + 3, good.size() / 3 + 11}) {
    for (int bit : {6, 7}) {
      std::string bad = good;
      bad[off] = static_cast<char>(bad[off] ^ (1 << bit));
      spit(d / "flip.stl", bad);
      Result r = cli(
          "mesh tetrahedralize " + (d / "flip.stl").string() + " --out " + (d / "out").string(), d);
      EXPECT_EQ(r.signal, 0) << "offset " << off << " bit " << bit;
      EXPECT_TRUE(r.code == 0 || r.code == 2) << "offset " << off << " bit " << bit << r.err;
      if (r.code == 2) {
        ++refused;
        EXPECT_FALSE(r.err.empty());
      }
      Result c = cli("mesh check " + (d / "flip.stl").string(), d);
      EXPECT_TRUE(c.code == 0 || c.code == 1 || c.code == 2) << c.err;
    }
  }
  EXPECT_GT(refused, 0);
}

TEST(HardMesh, ObjWithoutGeometryFailsCheckAndValidate) {
  auto d = tmp("emptyobj");
  spit(d / "organ.obj", "# nothing here\ng body\n");
  Result r = cli("mesh check " + (d / "organ.obj").string(), d);
  EXPECT_EXIT2_WITH(r, "organ.obj: no geometry");
  std::string a = slurp(src("prototypes/A.json"));
  const std::string gen = "{\"generator\": \"tract\", \"vertices\": 1500, \"seed\": 0}";
  a.replace(a.find(gen), gen.size(), "{\"file\": \"organ.obj\"}");
  spit(d / "A.json", a);
  spit(d / "study.json", study());
  r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "organ.obj: no geometry");
}

// Review finding (2026-12-06, second): a prototype's mesh 1e150 m across (or 1e308) overflowed
// the contact search into "internal error" (exit 3), and one in millimetres ran silently (mass
// 4e8 kg). A prototype's mesh is refused where it is named unless it is 1e-4 to 10 m across.
TEST(HardMesh, APrototypesMeshOutsideTissueSizesIsRefusedNamingTheFile) {
  auto d = tmp("meshsize");
  Result r = cli("mesh generate model-a --out " + (d / "organ.obj").string(), d);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string metres = slurp(d / "organ.obj");
  std::string a = slurp(src("prototypes/A.json"));
  const std::string gen = "{\"generator\": \"tract\", \"vertices\": 1500, \"seed\": 0}";
  a.replace(a.find(gen), gen.size(), "{\"file\": \"organ.obj\"}");
  spit(d / "A.json", a);
  const std::string probe =
      "probe " + (d / "A.json").string() + " --press 0 --force 1 --duration 0.05";
  ASSERT_EQ(cli(probe, d).code, 0);
  for (const double scale : {1e3, 1e150, 1e-6}) {
    std::istringstream in(metres);
    std::string out, line;
    while (std::getline(in, line)) {
      if (line.rfind("v ", 0) == 0) {
        std::istringstream v(line.substr(2));
        double x, y, z;
        v >> x >> y >> z;
        std::ostringstream o;
        o.precision(17);
        o << "v " << x * scale << " " << y * scale << " " << z * scale;
        line = o.str();
      }
      out += line + "\n";
    }
    spit(d / "organ.obj", out);
    SCOPED_TRACE(scale);
    r = cli(probe, d);
    EXPECT_EXIT2_WITH(r, "organ.obj: the mesh is ");
    EXPECT_TRUE(has(r.err, " m across, expected a piece of tissue in metres (0.0001 to 10 m"))
        << r.err;
    // The size to 3 digits, and the hint that fits it (review 2026-12-06, second: 17 digits,
    // and a mesh too small was told it was in millimetres).
    EXPECT_TRUE(has(r.err, scale > 1 ? "1000 times too large" : "1000 times too small")) << r.err;
    const auto at = r.err.find("the mesh is ") + 12;
    EXPECT_LE(r.err.find(' ', at) - at, 9u) << r.err;
  }
}

// Review finding (2026-12-06, second): a named region whose vertices all belong to another
// region (a vertex takes the first region of its faces) was "internal error" (exit 3) when
// pressed or made a study's feature, and `validate` passed the study. Refused naming the file.
TEST(HardMesh, ARegionWithoutVerticesOfItsOwnIsRefusedNamingTheFile) {
  auto d = tmp("lump");
  ASSERT_EQ(cli("mesh generate sphere --vertices 642 --out " + (d / "s.obj").string(), d).code, 0);
  const std::string obj = slurp(d / "s.obj");
  const auto first_face = obj.find("\nf ") + 1, last_face = obj.rfind("\nf ") + 1;
  spit(d / "organ.obj", obj.substr(0, first_face) + "g skin\n" +
                            obj.substr(first_face, last_face - first_face) + "g lump\n" +
                            obj.substr(last_face));
  std::string a = slurp(src("prototypes/A.json"));
  const std::string gen = "{\"generator\": \"tract\", \"vertices\": 1500, \"seed\": 0}";
  a.replace(a.find(gen), gen.size(), "{\"file\": \"organ.obj\"}");
  spit(d / "A.json", a);
  const Result r =
      cli("probe " + (d / "A.json").string() + " --press lump --force 1 --duration 0.05", d);
  EXPECT_EXIT2_WITH(r, "organ.obj: region \"lump\" has no vertex of its own");
}

// Review finding (2026-12-06, second): a palpation study whose feature is a tissue inside a tet
// mesh (prototype N's joint capsule) passed `validate`; `run` stopped at its first session with
// a database made. `validate` and `run` refuse it before anything is stored; a needle's target
// is such a tissue and stays valid.
TEST(HardMesh, APalpationFeatureInsideTheBodyIsRefusedByValidate) {
  auto d = tmp("inner_feature");
  const std::string study = R"({
  "palplab_study": 1, "id": "inner_feature", "title": "t", "seed": 1,
  "task": {"feature": "membrane", "thresholds": {"*": {"ST": 6.0, "MPF": 7.0, "SFT": 8.0}}},
  "groups": [{"id": "N", "prototype": "N", "size": 2}],
  "phases": [{"id": "training", "kind": "training", "sessions": 1, "session_duration": 5}]
})";
  spit(d / "s.json", study);
  const std::string says =
      "$.task.feature: region \"membrane\" of prototype(s) N is a tissue inside the body (no "
      "vertex on its surface)";
  EXPECT_EXIT2_WITH(cli("validate " + (d / "s.json").string(), d), says);
  EXPECT_EXIT2_WITH(
      cli("run " + (d / "s.json").string() + " --db " + (d / "r.db").string() + " --quiet", d),
      says);
  EXPECT_FALSE(fs::exists(d / "r.db"));
  std::string skin = study;
  skin.replace(skin.find("membrane"), 8, "skin");
  spit(d / "skin.json", skin);
  EXPECT_EQ(cli("validate " + (d / "skin.json").string(), d).code, 0);
  EXPECT_EQ(cli("validate " + src("protocols/studies/needle_insertion.json"), d).code, 0);
}

namespace {

// A surface VTU written by palplab, with its regions (Model-A).
std::string tract_vtu(const fs::path& d) {
  Result r = cli("mesh generate model-a --out " + (d / "a.vtu").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  return slurp(d / "a.vtu");
}

// Replaces the first value of the DataArray named `name`.
std::string set_first(std::string vtu, const std::string& name, const std::string& value) {
  auto p = vtu.find("Name=\"" + name + "\"");
  EXPECT_NE(p, std::string::npos) << name;
  p = vtu.find('>', p) + 1;
  while (std::isspace(static_cast<unsigned char>(vtu[p]))) ++p;
  const auto e = vtu.find_first_of(" \n", p);
  return vtu.replace(p, e - p, value);
}

}  // namespace

TEST(HardMesh, RepairOfAHugeRegionIdIsAnError) {
  auto d = tmp("region");
  const std::string vtu = tract_vtu(d);
  for (const char* id : {"1000000000", "1e9", "-5", "nan", "2.5"}) {
    spit(d / "r.vtu", set_first(vtu, "region", id));
    Result r =
        cli("mesh repair " + (d / "r.vtu").string() + " --out " + (d / "fixed.obj").string(), d);
    EXPECT_EQ(r.signal, 0) << id;
    EXPECT_EXIT2_WITH(r, "r.vtu");
    EXPECT_TRUE(has(r.err, "region id")) << id << ": " << r.err;
  }
}

TEST(HardMesh, NanCoordinatesAreReportedByCheck) {
  auto d = tmp("nan");
  const std::string vtu = tract_vtu(d);
  auto p = vtu.find("<Points>");
  p = vtu.find('>', vtu.find("<DataArray", p)) + 1;
  while (std::isspace(static_cast<unsigned char>(vtu[p]))) ++p;
  std::string bad = vtu;
  bad.replace(p, bad.find(' ', p) - p, "nan");
  spit(d / "nan.vtu", bad);
  Result r = cli("mesh check " + (d / "nan.vtu").string() + " --json", d);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_TRUE(has(r.out, "\"non_finite_vertex\": 1")) << r.out;
  r = cli("mesh tetrahedralize " + (d / "nan.vtu").string() + " --out " + (d / "t").string(), d);
  EXPECT_EXIT2_WITH(r, "vertex 0 has a coordinate that is not a finite number");
  r = cli("mesh repair " + (d / "nan.vtu").string() + " --out " + (d / "f.obj").string(), d);
  EXPECT_EXIT2_WITH(r, "cannot repair: vertex 0");
  // As a prototype's mesh (review 2026-12-06, second: `probe` was "internal error", exit 3;
  // `render` drew it with exit 0): refused where it is named.
  std::string a = slurp(src("prototypes/A.json"));
  const std::string gen = "{\"generator\": \"tract\", \"vertices\": 1500, \"seed\": 0}";
  a.replace(a.find(gen), gen.size(), "{\"file\": \"nan.vtu\"}");
  spit(d / "A.json", a);
  for (const std::string& cmd :
       {"probe " + (d / "A.json").string() + " --press 0 --force 1 --duration 0.05",
        "scene build " + (d / "A.json").string() + " --out " + (d / "A.psim").string()}) {
    r = cli(cmd, d);
    EXPECT_EXIT2_WITH(r, "nan.vtu: a vertex has a coordinate that is not a finite number");
  }
  EXPECT_FALSE(fs::exists(d / "A.psim"));
}

TEST(HardMesh, TetGenTimeoutIsAnErrorNotAHang) {
  auto d = tmp("timeout");
  ASSERT_EQ(cli("mesh generate sphere --vertices 2562 --out " + (d / "s.obj").string(), d).code, 0);
  // A tiny max volume (≈ 2e7 tetrahedra, just inside what palplab meshes) makes TetGen work for
  // long; the limit stops it.
  Result r = cli("mesh tetrahedralize " + (d / "s.obj").string() + " --out " + (d / "t").string() +
                     " --max-volume 3e-11 --timeout 0.5",
                 d);
  EXPECT_EXIT2_WITH(r, "TetGen did not finish within 0.5 s");
  EXPECT_LT(r.seconds, 20);
}

// ------------------------------------------------------------------------------------- DB

namespace {

fs::path incomplete_db(const fs::path& d) {
  spit(d / "study.json", study());
  const fs::path db = d / "r.db";
  Result r = cli(
      "run " + (d / "study.json").string() + " --db " + db.string() + " --max-sessions 1 --quiet",
      d);
  EXPECT_EQ(r.code, 0) << r.err;
  return db;
}

// A permission test's set-up: the prefix that runs palplab unprivileged
// (palplab::testing::unprivileged()), a scratch directory `d` with an incomplete run's database
// `db`, and d/out, which "nobody" can write (its stdout/stderr and outputs). Nothing when palplab
// cannot run unprivileged.
struct AsNobody {
  std::string as;
  fs::path d, db;
};
std::optional<AsNobody> as_nobody(const std::string& name) {
  const std::optional<std::string> as = palplab::testing::unprivileged();
  if (!as) return std::nullopt;
  AsNobody s{*as, tmp(name), {}};
  s.db = incomplete_db(s.d);
  fs::create_directories(s.d / "out");
  ::chmod((s.d / "out").c_str(), 0777);
  return s;
}

}  // namespace

TEST(HardDb, SecondWriterIsToldTheDatabaseIsInUse) {
  auto d = tmp("inuse");
  const fs::path db = incomplete_db(d);
  // This process holds the writer's lock as a running `run --resume` would.
  palplab::results::Store writer = palplab::results::Store::open(db.string(), true);
  Result r = cli("run " + (d / "study.json").string() + " --db " + db.string() + " --resume", d);
  EXPECT_EXIT2_WITH(r, "the database is in use by another palplab process");
  r = cli("run " + (d / "study.json").string() + " --db " + db.string() + " --force", d);
  EXPECT_EXIT2_WITH(r, "in use");
  // Readers still work while it is written.
  EXPECT_EQ(cli("export " + db.string() + " --csv " + (d / "csv").string(), d).code, 0);
}

TEST(HardDb, ForceReplacesOnlyAPalplabDatabase) {
  auto d = tmp("force");
  spit(d / "study.json", study());
  spit(d / "notes.txt", "my thesis, chapter 3\n");
  Result r = cli("run " + (d / "study.json").string() + " --db " + (d / "notes.txt").string() +
                     " --force --quiet",
                 d);
  EXPECT_EXIT2_WITH(r, "refusing to replace it: not a palplab results database");
  EXPECT_EQ(slurp(d / "notes.txt"), "my thesis, chapter 3\n");
  fs::create_directories(d / "somedir");
  r = cli("run " + (d / "study.json").string() + " --db " + (d / "somedir").string() +
              " --force --quiet",
          d);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_TRUE(fs::is_directory(d / "somedir"));
  // A palplab database is replaced.
  const fs::path db = incomplete_db(d);
  r = cli("run " + (d / "study.json").string() + " --db " + db.string() + " --force --quiet", d);
  EXPECT_EQ(r.code, 0) << r.err;
}

TEST(HardDb, ReadOnlyDirectoryIsSaidAsSuch) {
  const std::optional<AsNobody> s = as_nobody("ro");
  if (!s) GTEST_SKIP() << "root ignores permissions and runuser is not available";
  const auto& [as, d, db] = *s;
  fs::create_directories(d / "ro");
  fs::copy_file(db, d / "ro" / "r.db");
  ::chmod((d / "ro").c_str(), 0555);
  Result r = cli_as(
      as,
      "run " + (d / "study.json").string() + " --db " + (d / "ro" / "r.db").string() + " --resume",
      d / "out");
  EXPECT_EXIT2_WITH(r, "is read-only");
  EXPECT_FALSE(has(r.err, "not a palplab")) << r.err;
  // --force said "not a palplab results database" there (it could not open the WAL database).
  r = cli_as(
      as,
      "run " + (d / "study.json").string() + " --db " + (d / "ro" / "r.db").string() + " --force",
      d / "out");
  EXPECT_EXIT2_WITH(r, "is read-only");
  EXPECT_FALSE(has(r.err, "not a palplab")) << r.err;
  EXPECT_TRUE(fs::exists(d / "ro" / "r.db"));
  // Reading from a read-only place works (an archived run).
  r = cli_as(as,
             "export " + (d / "ro" / "r.db").string() + " --csv " + (d / "out" / "csv").string(),
             d / "out");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(d / "out" / "csv" / "measures.csv"));
  ::chmod((d / "ro").c_str(), 0755);
}

// A run killed before its checkpoint leaves its last writes in PATH-wal. Read from a read-only
// place, the database was opened immutable and those writes silently dropped (a session missing
// from export and report); now they are read through the existing -shm, or, without it, refused.
TEST(HardDb, ReadOnlyDatabaseWithUncheckpointedWritesLosesNothing) {
  const std::optional<AsNobody> s = as_nobody("rowal");
  if (!s) GTEST_SKIP() << "root ignores permissions and runuser is not available";
  const auto& [as, d, db] = *s;
  fs::create_directories(d / "ro");
  const fs::path w = d / "ro" / "w.db";
  fs::copy_file(db, w);
  {  // One write left in the WAL only (no checkpoint on close), as a killed run leaves it.
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(w.c_str(), &h), SQLITE_OK);
    ASSERT_EQ(sqlite3_db_config(h, SQLITE_DBCONFIG_NO_CKPT_ON_CLOSE, 1, nullptr), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(h,
                           "PRAGMA journal_mode=WAL; PRAGMA wal_autocheckpoint=0; UPDATE measures "
                           "SET value = 12.375 WHERE rowid = (SELECT min(rowid) FROM measures "
                           "WHERE name = 'palpations');",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(h);
  }
  ASSERT_GT(fs::file_size(fs::path(w.string() + "-wal")), 0u);
  ASSERT_TRUE(fs::exists(w.string() + "-shm"));
  ::chmod((d / "ro").c_str(), 0555);
  Result r =
      cli_as(as, "export " + w.string() + " --csv " + (d / "out" / "csv").string(), d / "out");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(slurp(d / "out" / "csv" / "measures.csv"), ",12.375,")) << "the WAL's write";
  // Without the -shm the WAL cannot be read in a read-only place: refused, not dropped.
  ::chmod((d / "ro").c_str(), 0755);
  fs::remove(w.string() + "-shm");
  ::chmod((d / "ro").c_str(), 0555);
  r = cli_as(as, "report " + w.string() + " --out " + (d / "out" / "rep").string(), d / "out");
  EXPECT_EXIT2_WITH(r, "w.db-wal, which cannot be read in a read-only place");
  EXPECT_FALSE(fs::exists(d / "out" / "rep"));
  ::chmod((d / "ro").c_str(), 0755);
}

// A refused resume of a read-only database file left PATH-wal and PATH-shm behind: the probe's
// read-only open created them (the directory is writable) before the write check refused. The
// writers' opens (Store::open(path, true), Store::remove_empty_leftover: `run --resume` and
// `run --human`) refuse before anything is opened now.
TEST(HardDb, RefusedResumeOfAReadOnlyFileLeavesNoWalOrShm) {
  const std::optional<AsNobody> s = as_nobody("roresume");
  if (!s) GTEST_SKIP() << "root ignores permissions and runuser is not available";
  const auto& [as, d, db] = *s;
  ASSERT_FALSE(fs::exists(db.string() + "-wal"));
  ASSERT_FALSE(fs::exists(db.string() + "-shm"));
  ::chmod(d.c_str(), 0777);
  ::chmod(db.c_str(), 0444);
  Result r = cli_as(as, "run " + (d / "study.json").string() + " --db " + db.string() + " --resume",
                    d / "out");
  EXPECT_EXIT2_WITH(r, "the file is read-only");
  EXPECT_FALSE(fs::exists(db.string() + "-wal"));
  EXPECT_FALSE(fs::exists(db.string() + "-shm"));
  ::chmod(db.c_str(), 0644);
  ::chmod(d.c_str(), 0755);
}

// An interrupted virtual run (SIGTERM; SIGINT alike) said nothing: it now says that the
// completed sessions are stored and prints the command that continues it, exits 128 + signal,
// and that command completes the run (keeping the run's --samples none). SIGHUP (a closed
// terminal, a dropped ssh session) ended it silently with 129 until 2026-12-07.
TEST(HardDb, InterruptedRunSaysHowToContinue) {
  for (const auto& [sig, code] : {std::pair{"TERM", "143\n"}, std::pair{"HUP", "129\n"}}) {
    SCOPED_TRACE(sig);
    auto d = tmp(std::string("interrupt_") + sig);
    spit(d / "study.json",
         study(R"([{"id": "G1", "prototype": "A", "size": 2}])", "", 300.0));  // ≈ 1 s of A
    const fs::path db = d / "r.db";
    const std::string cmd = "PALPLAB_PROTOTYPE_PATH=" + std::string(PALPLAB_SOURCE_DIR) +
                            "/prototypes " + std::string(PALPLAB_BINARY) + " run " +
                            (d / "study.json").string() + " --db " + db.string() +
                            " --samples none 2>" + (d / "err.txt").string() + " >/dev/null";
    // The signal after the first session is stored (its progress line; the sanitizer build
    // is slow enough that a fixed wait could come before it).
    const std::string script = "(" + cmd +
                               ") & pid=$!; i=0; while ! grep -q \"session 1/6 done\" " +
                               (d / "err.txt").string() +
                               " 2>/dev/null && [ $i -lt 3000 ]; do sleep 0.01; i=$((i+1)); done; "
                               "kill -" +
                               sig + " $pid; wait $pid; echo $? > " + (d / "rc.txt").string();
    ASSERT_EQ(std::system(("bash -c '" + script + "'").c_str()), 0);
    const std::string err = slurp(d / "err.txt");
    if (slurp(d / "rc.txt") == "0\n") GTEST_SKIP() << "the run finished before the signal";
    EXPECT_EQ(slurp(d / "rc.txt"), code) << err;
    EXPECT_TRUE(has(err, "interrupted: the sessions completed before this are stored in")) << err;
    const std::string resume =
        "run " + (d / "study.json").string() + " --db " + db.string() + " --resume";
    EXPECT_TRUE(has(err, "palplab " + resume + "\n")) << err;
    Result r = cli(resume + " --quiet", d);
    EXPECT_EQ(r.code, 0) << r.err;
    const auto st = palplab::results::Store::open(db.string());
    ASSERT_EQ(st.read_sessions().size(), 6u);
    for (const auto& s : st.read_sessions()) EXPECT_EQ(st.read_samples(s.session).size(), 0u);
  }
}

// Interrupted before its first session was stored, a run said "the sessions completed before
// this are stored" (review 2026-12-07): it now says that none is. It offers --resume (not
// --force: a session stored in the moment before the signal would be deleted by it), which
// completes the run.
TEST(HardDb, RunInterruptedBeforeItsFirstSessionSaysNoneIsStored) {
  auto d = tmp("interrupt_first");
  // One session of 60 s on C: seconds of work, the signal comes within it.
  spit(d / "study.json",
       R"({"palplab_study": 1, "id": "hard", "title": "hard cases", "seed": 1,
  "task": {"feature": "ovary_left", "thresholds": {"*": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}}},
  "groups": [{"id": "G1", "prototype": "C", "size": 1}],
  "phases": [{"id": "pre", "kind": "pre_training", "session_duration": 60, "start": {"day": 0}}]})");
  const fs::path db = d / "r.db";
  const std::string cmd = "PALPLAB_PROTOTYPE_PATH=" + std::string(PALPLAB_SOURCE_DIR) +
                          "/prototypes " + std::string(PALPLAB_BINARY) + " run " +
                          (d / "study.json").string() + " --db " + db.string() +
                          " --samples none 2>" + (d / "err.txt").string() + " >/dev/null";
  const std::string script =
      "(" + cmd + ") & pid=$!; i=0; while [ ! -s " + db.string() +
      " ] && [ $i -lt 3000 ]; do sleep 0.01; i=$((i+1)); done; sleep 0.05; kill -TERM $pid; "
      "wait $pid; echo $? > " +
      (d / "rc.txt").string();
  ASSERT_EQ(std::system(("bash -c '" + script + "'").c_str()), 0);
  const std::string err = slurp(d / "err.txt");
  if (slurp(d / "rc.txt") == "0\n" || has(err, "session 1/1 done"))
    GTEST_SKIP() << "the session finished before the signal";
  EXPECT_EQ(slurp(d / "rc.txt"), "143\n") << err;
  EXPECT_FALSE(has(err, "completed before this are stored")) << err;
  EXPECT_TRUE(has(
      err, "interrupted before any session was complete: no session is stored in " + db.string()))
      << err;
  const std::string again =
      "run " + (d / "study.json").string() + " --db " + db.string() + " --resume";
  EXPECT_TRUE(has(err, "palplab " + again + "\n")) << err;
  Result r = cli(again + " --quiet", d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(palplab::results::Store::open(db.string()).read_sessions().size(), 1u);
}

// An export interrupted by SIGTERM left its NAME.partial files in --csv (review 2026-12-06; the
// next export replaced them, but a user saw cut-off CSVs): they are removed on the signal, the
// earlier export's files stay as they were, and the export still ends by the signal (143).
TEST(HardDb, AnInterruptedExportLeavesNoPartialFiles) {
  auto d = tmp("exportkill");
  spit(d / "study.json", study(R"([{"id": "G1", "prototype": "A", "size": 2}])", "", 60.0));
  const fs::path db = d / "r.db", csv = d / "csv";
  Result r = cli("run " + (d / "study.json").string() + " --db " + db.string() + " --quiet", d);
  ASSERT_EQ(r.code, 0) << r.err;
  r = cli("export " + db.string() + " --csv " + csv.string(), d);  // the earlier export
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string measures = slurp(csv / "measures.csv");
  // 360 000 samples: the signal comes while samples.csv.partial is being written.
  const std::string cmd = std::string(PALPLAB_BINARY) + " export " + db.string() + " --csv " +
                          csv.string() + " --samples 2>" + (d / "err.txt").string() + " >/dev/null";
  const std::string script = "(" + cmd + ") & pid=$!; i=0; while [ ! -e " +
                             (csv / "samples.csv.partial").string() +
                             " ] && [ $i -lt 2000 ]; do sleep 0.005; i=$((i+1)); done; "
                             "kill -TERM $pid; wait $pid; echo $? > " +
                             (d / "rc.txt").string();
  ASSERT_EQ(std::system(("bash -c '" + script + "'").c_str()), 0);
  if (slurp(d / "rc.txt") == "0\n") GTEST_SKIP() << "the export finished before the signal";
  EXPECT_EQ(slurp(d / "rc.txt"), "143\n") << slurp(d / "err.txt");
  for (const auto& e : fs::directory_iterator(csv))
    EXPECT_EQ(e.path().extension(), ".csv") << e.path() << " left behind";
  EXPECT_FALSE(fs::exists(csv / "samples.csv"));
  EXPECT_EQ(slurp(csv / "measures.csv"), measures);
}

// `--samples` was not stored: a resume with the default stored 1 kHz samples for the rest of
// the sessions only. A resume now keeps the run's setting and refuses another one.
TEST(HardDb, ResumeKeepsTheRunsSamplesSetting) {
  auto d = tmp("samplesresume");
  spit(d / "study.json", study());
  const fs::path db = d / "r.db";
  const std::string run = "run " + (d / "study.json").string() + " --db " + db.string();
  Result r = cli(run + " --samples none --max-sessions 2 --quiet", d);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err, "INCOMPLETE (2 sessions run; continue with --resume)")) << r.err;
  r = cli(run + " --resume --samples full", d);
  EXPECT_EXIT2_WITH(r, "the run started with --samples none, this one asks for --samples full");
  r = cli(run + " --resume --samples none --max-sessions 2", d);  // the same value: fine
  EXPECT_EQ(r.code, 0) << r.err;
  r = cli(run + " --resume", d);
  EXPECT_EQ(r.code, 0) << r.err;
  const auto st = palplab::results::Store::open(db.string());
  ASSERT_EQ(st.read_sessions().size(), 6u);
  for (const auto& s : st.read_sessions()) EXPECT_EQ(st.read_samples(s.session).size(), 0u);
  EXPECT_EQ(st.read_meta("samples").value_or("?"), "none");
  // Its export with --samples says that there are none (a header-only samples.csv said nothing).
  r = cli("export " + db.string() + " --csv " + (d / "csv").string() + " --samples", d);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err, "the run stored no device samples (it ran with --samples none)")) << r.err;
  // A run with samples keeps them too.
  r = cli(run + " --force --max-sessions 1 --quiet", d);
  ASSERT_EQ(r.code, 0) << r.err;
  r = cli(run + " --resume --samples none", d);
  EXPECT_EXIT2_WITH(r, "the run started with --samples full");
  // The warning follows the data, not the meta row (one edited to "none" over stored samples).
  palplab::testing::sql_exec(db, "UPDATE meta SET value = 'none' WHERE key = 'samples'");
  r = cli("export " + db.string() + " --csv " + (d / "csv").string() + " --samples --overwrite", d);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(has(r.err, "stored no device samples")) << r.err;
  EXPECT_GT(slurp(d / "csv" / "samples.csv").size(), 1000u);
  // A run that stored samples whose rows are gone is damaged: said, without the warning that
  // there were none to store.
  palplab::testing::sql_exec(db, "UPDATE meta SET value = 'full' WHERE key = 'samples'");
  palplab::testing::sql_exec(db, "DELETE FROM samples");
  r = cli("export " + db.string() + " --csv " + (d / "csv2").string() + " --samples", d);
  EXPECT_EXIT2_WITH(r, "the database is damaged");
  EXPECT_FALSE(has(r.err, "stored no device samples")) << r.err;
}

// An interruption while `run` created its database left an empty file (or an SQLite file
// without tables) that --resume ("not a palplab results database") and --force ("refusing to
// replace it") both refused: the user had to delete it by hand. Nothing is in it to keep or to
// lose: --resume starts the run there, --force replaces it. A palplab database whose start
// stopped before its study record is started in as well.
TEST(HardDb, AnInterruptedStartIsStartedInOrReplaced) {
  auto d = tmp("emptystart");
  spit(d / "study.json", study());
  const fs::path db = d / "r.db";
  const std::string run = "run " + (d / "study.json").string() + " --db " + db.string();
  auto sessions = [&] { return palplab::results::Store::open(db.string()).read_sessions().size(); };
  spit(db, "");
  Result r = cli(run + " --resume", d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err, "holds no run yet (its start was interrupted): starting the run"))
      << r.err;
  EXPECT_EQ(sessions(), 6u);
  // An SQLite file without tables (what a start stopped inside its schema transaction leaves).
  auto empty_sqlite = [&] {
    fs::remove(db);
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
    sqlite3_exec(h, "PRAGMA journal_mode=WAL; CREATE TABLE t(x); DROP TABLE t;", nullptr, nullptr,
                 nullptr);
    sqlite3_close(h);
    ASSERT_GT(fs::file_size(db), 0u);
  };
  empty_sqlite();
  r = cli(run + " --force --quiet", d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(sessions(), 6u);
  empty_sqlite();
  r = cli(run + " --resume --quiet", d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(sessions(), 6u);
  // A start killed inside its schema transaction, before the switch to WAL: the database's
  // uncommitted first page and a hot rollback journal beside it (tests/data/interrupted_start,
  // what `run` left when killed after 30 ms; review finding 2026-12-06: --resume said "not a
  // palplab results database" and --force refused, because the read-only probes cannot read the
  // file until the journal is rolled back).
  const fs::path killed = fs::path(PALPLAB_SOURCE_DIR) / "tests" / "data" / "interrupted_start";
  for (const std::string how : {" --resume", " --force"}) {
    SCOPED_TRACE(how);
    fs::remove(db);
    fs::copy_file(killed / "killed_start.db", db);
    fs::copy_file(killed / "killed_start.db-journal", db.string() + "-journal");
    r = cli(run + how, d);
    EXPECT_EQ(r.code, 0) << r.err;
    if (how == " --resume") {
      EXPECT_TRUE(has(r.err, "holds no run yet")) << r.err;
    }
    EXPECT_EQ(sessions(), 6u);
    EXPECT_FALSE(fs::exists(db.string() + "-journal"));
  }
  // The schema written, the study record not yet.
  fs::remove(db);
  { palplab::results::Store::create(db.string()); }
  r = cli(run + " --resume", d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err, "holds no run yet")) << r.err;
  EXPECT_EQ(sessions(), 6u);
  // A file with something in it is still never taken for a leftover.
  spit(d / "notes.db", "my notes");
  r = cli("run " + (d / "study.json").string() + " --db " + (d / "notes.db").string() + " --force",
          d);
  EXPECT_EXIT2_WITH(r, "refusing to replace it: not a palplab results database");
  EXPECT_EQ(slurp(d / "notes.db"), "my notes");
  // An empty file behind a symbolic link is not deleted through the link: refused, saying why.
  spit(d / "target.db", "");
  fs::create_symlink(d / "target.db", d / "link.db");
  r = cli("run " + (d / "study.json").string() + " --db " + (d / "link.db").string() + " --resume",
          d);
  EXPECT_EXIT2_WITH(r, "link.db: is empty: not a palplab results database (expected schema");
  EXPECT_TRUE(fs::exists(d / "target.db"));
  EXPECT_TRUE(fs::is_symlink(d / "link.db"));
}

// Resuming with another study file named neither study.
// SQLite URIs decode %HH and end a path at '?' or '#': the probes of a database named x%41.db
// looked at xA.db (an empty SQLite file beside it made --resume delete the complete run, and
// --force a foreign one), and a.b#c.db could be created but never opened again.
TEST(HardDb, PathsWithUriCharactersNameTheirOwnFile) {
  auto d = tmp("uripath");
  spit(d / "study.json", study());
  auto empty_sqlite = [](const fs::path& p) {
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(p.c_str(), &h), SQLITE_OK);
    sqlite3_exec(h, "PRAGMA journal_mode=WAL; CREATE TABLE t(x); DROP TABLE t;", nullptr, nullptr,
                 nullptr);
    sqlite3_close(h);
  };
  const std::string run = "run " + (d / "study.json").string() + " --db ";
  const fs::path pct = d / "x%41.db";
  Result r = cli(run + "'" + pct.string() + "' --quiet", d);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string started = palplab::results::Store::open(pct.string()).read_study().started_at;
  empty_sqlite(d / "xA.db");
  r = cli(run + "'" + pct.string() + "' --resume", d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(has(r.err, "holds no run yet")) << r.err;
  EXPECT_EQ(palplab::results::Store::open(pct.string()).read_study().started_at, started)
      << "the complete run was started over";
  EXPECT_EQ(palplab::results::Store::open(pct.string()).read_sessions().size(), 6u);
  // --force keeps refusing a foreign SQLite file whatever lies beside it.
  const fs::path thesis = d / "thesis%41.db";
  {
    sqlite3* h = nullptr;
    ASSERT_EQ(sqlite3_open(thesis.c_str(), &h), SQLITE_OK);
    sqlite3_exec(h, "CREATE TABLE chapters(x); INSERT INTO chapters VALUES (1);", nullptr, nullptr,
                 nullptr);
    sqlite3_close(h);
  }
  empty_sqlite(d / "thesisA.db");
  r = cli(run + "'" + thesis.string() + "' --force", d);
  EXPECT_EXIT2_WITH(r, "not a palplab results database");
  EXPECT_TRUE(fs::exists(thesis));
  for (const std::string name : {"a#b.db", "q?x.db", "p%2.db"}) {
    const fs::path db = d / name;
    r = cli(run + "'" + db.string() + "' --max-sessions 2 --quiet", d);
    ASSERT_EQ(r.code, 0) << name << r.err;
    r = cli(run + "'" + db.string() + "' --resume --quiet", d);
    EXPECT_EQ(r.code, 0) << name << r.err;
    r = cli(
        "report '" + db.string() + "' --no-stills --out '" + (d / ("rep_" + name)).string() + "'",
        d);
    EXPECT_EQ(r.code, 0) << name << r.err;
  }
}

// A resume wrote samples for the rest of a run that started with --samples none when the
// database came from before "samples" was stored (meta row missing): the first session tells.
TEST(HardDb, ResumeOfARunWithoutTheSamplesRowKeepsWhatItsSessionsHold) {
  auto d = tmp("oldsamples");
  spit(d / "study.json", study());
  const fs::path db = d / "r.db";
  const std::string run = "run " + (d / "study.json").string() + " --db " + db.string();
  Result r = cli(run + " --samples none --max-sessions 3 --quiet", d);
  ASSERT_EQ(r.code, 0) << r.err;
  palplab::testing::sql_exec(db, "DELETE FROM meta WHERE key = 'samples'");
  r = cli(run + " --resume --quiet", d);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto st = palplab::results::Store::open(db.string());
  ASSERT_EQ(st.read_sessions().size(), 6u);
  for (const auto& s : st.read_sessions()) EXPECT_EQ(st.read_samples(s.session).size(), 0u);
  EXPECT_EQ(st.read_meta("samples").value_or("?"), "none");
}

// A database whose study row was deleted but whose sessions remain was taken for an interrupted
// start ("holds no run yet"), then died on a UNIQUE constraint (exit 3): it is damaged, exit 2.
TEST(HardDb, RowsWithoutAStudyRecordAreDamagedNotAFreshStart) {
  auto d = tmp("nostudy");
  spit(d / "study.json", study());
  const fs::path db = d / "r.db";
  const std::string run = "run " + (d / "study.json").string() + " --db " + db.string();
  Result r = cli(run + " --quiet", d);
  ASSERT_EQ(r.code, 0) << r.err;
  palplab::testing::sql_exec(db, "DELETE FROM study");
  r = cli(run + " --resume", d);
  EXPECT_EXIT2_WITH(r, "damaged database: it has no study record but");
  EXPECT_FALSE(has(r.err, "holds no run yet")) << r.err;
}

TEST(HardDb, ResumeWithAnotherStudyNamesBoth) {
  auto d = tmp("otherstudy");
  const fs::path db = incomplete_db(d);
  std::string s = study();
  s.replace(s.find("\"id\": \"hard\""), 12, "\"id\": \"soft\"");
  spit(d / "other.json", s);
  Result r = cli("run " + (d / "other.json").string() + " --db " + db.string() + " --resume", d);
  EXPECT_EXIT2_WITH(r, "the database holds a run of another study file: study \"hard\" (SHA-256 ");
  EXPECT_TRUE(has(r.err, "this file is study \"soft\" (SHA-256 ")) << r.err;
}

// --force replaced another study's run without a word: it now says what it replaces.
TEST(HardDb, ForceSaysWhatItReplaces) {
  auto d = tmp("forcesay");
  const fs::path db = incomplete_db(d);
  Result r = cli("run " + (d / "study.json").string() + " --db " + db.string() + " --force", d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err, "replaced " + db.string() +
                             " (--force): it held a run of study \"hard\", 1 session, INCOMPLETE"))
      << r.err;
}

TEST(HardDb, ReportAndExportOfAnIncompleteDatabaseSaySo) {
  auto d = tmp("incomplete");
  const fs::path db = incomplete_db(d);
  Result r = cli("report " + db.string() + " --out " + (d / "rep").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err, "is INCOMPLETE")) << r.err;
  // The participants with sessions stored, not the planned ones (1 session of 1 participant).
  // (Which group's participant ran first is the plan's randomised order.)
  const std::string md = slurp(d / "rep" / "report.md");
  EXPECT_TRUE(has(md,
                  "| participants per group (with sessions stored, of planned) | "
                  "G1: 0 of 1, G2: 1 of 1 |") ||
              has(md,
                  "| participants per group (with sessions stored, of planned) | "
                  "G1: 1 of 1, G2: 0 of 1 |"))
      << md;
  EXPECT_TRUE(
      has(r.out, "report: 4 analyses (none declared: the study's measures in the last phase)"))
      << r.out;
  r = cli("export " + db.string() + " --csv " + (d / "csv").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err, "is INCOMPLETE")) << r.err;
}

// Review finding (2026-12-06, third): an input named like an output's FILE.partial (where the
// output is written before it is renamed) was overwritten and renamed away, exit 0: the results
// database as DIR/report.md.partial, the study as st.json.partial of `calibrate --out st.json`.
// Refused before any work, the input left byte for byte.
TEST(HardDb, AnInputNamedLikeAnOutputsPartialFileIsRefused) {
  auto d = tmp("partial_input");
  const fs::path db = incomplete_db(d);
  fs::create_directories(d / "rep");
  fs::copy_file(db, d / "rep" / "report.md.partial");
  const std::string bytes = slurp(d / "rep" / "report.md.partial");
  Result r = cli("report " + (d / "rep" / "report.md.partial").string() + " --out " +
                     (d / "rep").string() + " --no-stills",
                 d);
  EXPECT_EXIT2_WITH(r,
                    "report.md.partial\" is the results database this command reads; "
                    "writing report.md (written there first, then renamed) would destroy it");
  EXPECT_EQ(slurp(d / "rep" / "report.md.partial"), bytes);
  EXPECT_FALSE(fs::exists(d / "rep" / "report.md"));
  spit(d / "st.json.partial", study());
  r = cli("calibrate " + (d / "st.json.partial").string() + " --human " +
              src("tests/data/calibration/exp2_human.csv") + " --params weber_fraction --out " +
              (d / "st.json").string(),
          d);
  EXPECT_EXIT2_WITH(r, "st.json.partial\" is the study file this command reads; writing");
  EXPECT_EQ(slurp(d / "st.json.partial"), study());
}

TEST(HardDb, MeshFileChangedBetweenRunAndResumeIsRefused) {
  auto d = tmp("meshpin");
  ASSERT_EQ(cli("mesh generate model-a --out " + (d / "organ.obj").string(), d).code, 0);
  std::string a = slurp(src("prototypes/A.json"));
  const std::string gen = "{\"generator\": \"tract\", \"vertices\": 1500, \"seed\": 0}";
  a.replace(a.find(gen), gen.size(), "{\"file\": \"organ.obj\"}");
  spit(d / "A.json", a);
  const fs::path db = incomplete_db(d);
  std::ofstream(d / "organ.obj", std::ios::app) << "# edited after the run started\n";
  Result r = cli("run " + (d / "study.json").string() + " --db " + db.string() + " --resume", d);
  EXPECT_EXIT2_WITH(r, "differs from the file the run started with, or its mesh.file does");
}

TEST(HardDb, EscapeSequencesInNamesAreNeverEchoedRaw) {
  auto d = tmp("esc");
  const std::string esc = "\\u001b]0;pwned\\u0007\\u001b[31m";
  // In a valid study: the plan summary shows the title escaped.
  std::string s = study();
  s.replace(s.find("\"title\": \"hard cases\""), 21, "\"title\": \"hard" + esc + "\"");
  spit(d / "study.json", s);
  Result r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(has(r.out, "\x1b")) << r.out;
  EXPECT_TRUE(has(r.out, "\\x1b[31m")) << r.out;
  // Ids (file names, database text) may not hold control characters (nor anything outside the id
  // grammar, docs/FORMATS.md "Ids"): a located error, itself escaped.
  s = study(R"([{"id": "G)" + esc + R"(", "prototype": "A", "size": 1},
                           {"id": "G2", "prototype": "B", "size": 1}])");
  spit(d / "study.json", s);
  r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.groups[0].id: expected an id of 1 to 64 ASCII letters");
  EXPECT_EXIT2_WITH(r, "U+001B at character 2");
  EXPECT_FALSE(has(r.err, "\x1b")) << r.err;
  s = study();
  s.replace(s.find("\"id\": \"hard\""), 12, "\"id\": \"ha\\u0000rd\"");
  spit(d / "study.json", s);
  r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.id: expected an id of 1 to 64 ASCII letters");
  EXPECT_EXIT2_WITH(r, "U+0000 at character 3");
  // In an error message: an unknown key with escapes.
  s = study();
  s.replace(s.find("\"seed\": 1,"), 10, "\"seed\": 1, \"k" + esc + "\": 1,");
  spit(d / "study.json", s);
  r = cli("validate " + (d / "study.json").string(), d);
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(has(r.err, "\x1b")) << r.err;
  EXPECT_FALSE(has(r.err, "\x07")) << r.err;
  EXPECT_TRUE(has(r.err, "\\x1b]0;pwned\\x07")) << r.err;
}

// Review finding (2026-12-06): output that could not be written (a full disk: /dev/full) was lost
// and the command exited 0 (`lmm`, `validate`, `version`, `stats --json`, ...). It is exit 2 with
// the reason.
TEST(HardOutput, AFailedWriteToStandardOutputIsAnError) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "this system has no /dev/full";
  auto d = tmp("devfull");
  spit(d / "study.json", study());
  // `version` fails at the last flush (its reason known); `validate` of this study also warns on
  // stderr (0.05 s sessions are shorter than identify_dwell), which flushes stdout first: the
  // write fails earlier, and its reason, lost then, is asked again by one more byte written
  // ("a write failed", no reason, before: review 2026-12-06, third).
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"version",
       "(No space left on device); the output is lost (files the command wrote are not "
       "affected)"},
      {"validate " + (d / "study.json").string(), "(No space left on device); the output is lost"},
      // A verdict of 1 (defects found) is not what a script may read from lost output (review
      // 2026-12-06, second: it stayed 1).
      {"mesh check " + (d / "flat.obj").string(), "(No space left on device); the output is lost"},
      // Help and version, which CLI11 prints itself, exited 0 (review 2026-12-06, second).
      {"--help", "(No space left on device); the output is lost"},
      {"run --help", "(No space left on device); the output is lost"},
      {"--version", "(No space left on device); the output is lost"}};
  spit(d / "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
  ASSERT_EQ(cli("mesh check " + (d / "flat.obj").string(), d).code, 1);
  for (const auto& [args, why] : cases) {
    SCOPED_TRACE(args);
    const std::string cmd = "{ " + std::string(PALPLAB_BINARY) + " " + args +
                            " > /dev/full; } 2> " + (d / "err.txt").string();
    const int st = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(st));
    EXPECT_EQ(WEXITSTATUS(st), 2);
    EXPECT_TRUE(has(slurp(d / "err.txt"), "error: cannot write to standard output " + why))
        << slurp(d / "err.txt");
  }
}

// Review finding (2026-12-06): a full disk during `run` was "internal error: sqlite: cannot
// rollback - no transaction is active" (exit 3): SQLite had rolled back already, and the second
// ROLLBACK's error replaced the first. A file-size limit stands in for the full disk (the write
// fails alike, EFBIG for ENOSPC): exit 2 saying what failed and how to go on; what was stored is
// kept, and --resume completes the run with the measures of an uninterrupted one.
TEST(HardDb, AFailedWriteDuringARunIsSaidAndResumable) {
  auto d = tmp("fsize");
  spit(d / "study.json", study(kGroups, "", 2.0));
  const std::string env =
      "PALPLAB_PROTOTYPE_PATH=" + std::string(PALPLAB_SOURCE_DIR) + "/prototypes ";
  auto run = [&](const fs::path& db) {
    return env + PALPLAB_BINARY + " run " + (d / "study.json").string() + " --db " + db.string() +
           " --quiet";
  };
  ASSERT_EQ(std::system((run(d / "full.db") + " 2> " + (d / "e0.txt").string()).c_str()), 0)
      << slurp(d / "e0.txt");
  const auto full = fs::file_size(d / "full.db");
  // The limit in 512-byte blocks (POSIX sh): 1.5 x the finished database. The -wal file, where a
  // run writes, outgrows the database (each transaction appends every page it touched): this
  // limit stops the run after 2 of its 6 sessions (1.2 x: 1, 2 x: 4, 3 x: none).
  const auto blocks = full * 3 / 2 / 512;
  const fs::path db = d / "r.db";
  const int st = std::system(("(trap '' XFSZ; ulimit -f " + std::to_string(blocks) + "; " +
                              run(db) + ") 2> " + (d / "e1.txt").string())
                                 .c_str());
  ASSERT_TRUE(WIFEXITED(st));
  EXPECT_EQ(WEXITSTATUS(st), 2);
  const std::string err = slurp(d / "e1.txt");
  EXPECT_TRUE(
      has(err, db.string() + ": cannot write the database: an input/output error (sqlite: "))
      << err;
  EXPECT_TRUE(has(err, "make room, then continue the run with `palplab run STUDY --db " +
                           db.string() + " --resume`"))
      << err;
  EXPECT_FALSE(has(err, "internal error")) << err;
  const long long kept =
      palplab::testing::sql_int(db, "SELECT count(*) FROM sessions WHERE status = 'complete'");
  EXPECT_GE(kept, 1);
  EXPECT_LT(kept, 6);
  ASSERT_EQ(std::system((run(db) + " --resume 2> " + (d / "e2.txt").string()).c_str()), 0)
      << slurp(d / "e2.txt");
  EXPECT_EQ(palplab::testing::sql_int(db, "SELECT count(*) FROM sessions"), 6);
  const std::string same =
      "SELECT count(*) FROM measures m JOIN sessions s USING (session) WHERE m.value IS NOT NULL";
  EXPECT_EQ(palplab::testing::sql_int(db, same), palplab::testing::sql_int(d / "full.db", same));
}

// Review findings (2026-12-06): `palplab nosuch` said only "A subcommand is required", and
// `validate ""` "cannot open file" with no name; a missing file now gives the system's reason.
// Review finding (2026-12-07): an option given twice was CLI11's "--sim-n: At Most 1 required
// but received 2".
TEST(HardCli, AnOptionGivenTwiceIsSaidAsSuch) {
  auto d = tmp("twice");
  spit(d / "s.json", study());
  const Result r = cli("power " + (d / "s.json").string() +
                           " --replicates 2 --replicates 3 --out " + (d / "p").string(),
                       d);
  EXPECT_EXIT2_WITH(r, "error: palplab power: --replicates given more than once (give it once)");
  EXPECT_FALSE(has(r.err, "At Most")) << r.err;
  EXPECT_FALSE(fs::exists(d / "p"));
  // A flag too (review 2026-12-07: `--json --json` was taken, a value option twice refused).
  const std::string probe =
      "probe " + std::string(PALPLAB_SOURCE_DIR) +
      "/prototypes/A.json --press ovary_left --force 1 --duration 0.05 --json";
  const Result f = cli(probe + " --json", d);
  EXPECT_EXIT2_WITH(f, "error: palplab probe: --json given more than once (give it once)");
  EXPECT_EQ(cli(probe, d).code, 0);
}

TEST(HardCli, UnknownCommandsAndEmptyPathsAreSaidAsSuch) {
  auto d = tmp("cli_words");
  Result r = cli("nosuch", d);
  EXPECT_EXIT2_WITH(r, "error: unknown command 'nosuch'; the commands are: bench, calibrate,");
  r = cli("validate ''", d);
  EXPECT_EXIT2_WITH(r, "error: an empty file name, expected the path of a JSON study file");
  r = cli("validate " + (d / "none.json").string(), d);
  EXPECT_EXIT2_WITH(r,
                    "none.json: cannot open file: No such file or directory (expected a "
                    "readable JSON study file)");
  EXPECT_EQ(cli("version", d).code, 0);
}

// Review finding (2026-12-06): a touch needed to identify the feature longer than every session
// validated without a word; the study then runs with every exploration time undefined. Valid
// (exit 0), with a warning naming the key and the longest session.
TEST(HardCli, AnIdentificationLongerThanEverySessionIsWarnedOf) {
  auto d = tmp("dwell");
  std::string s = study(kGroups, "", 20.0);
  s.replace(s.find("\"feature\": \"ovary_left\","), 24,
            "\"feature\": \"ovary_left\", \"identify_dwell\": 50,");
  spit(d / "dwell.json", s);
  Result r = cli("validate " + (d / "dwell.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err,
                  "warning: $.task.identify_dwell: 50 s of contact on the feature "
                  "identifies it, longer than every session (the longest is 20 s)"))
      << r.err;
  spit(d / "ok.json", study(kGroups, "", 20.0));
  r = cli("validate " + (d / "ok.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(has(r.err, "warning")) << r.err;
  // The gap of a phase cut to one session has no effect (review 2026-12-06, fourth): valid,
  // with a warning at it.
  std::string one = study(kGroups, "", 20.0);
  one.replace(one.find("\"sessions\": 2,"), 14, "\"sessions\": 1,");
  spit(d / "one.json", one);
  r = cli("validate " + (d / "one.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err,
                  "warning: $.phases[1].gap: the phase has one session, so the gap "
                  "between its sessions has no effect"))
      << r.err;
}

// Review finding (2026-12-06): a palpation onset above the feature's target force validated
// without a word; `palpations` then counts only presses beyond the target. Valid, with a warning.
TEST(HardCli, APalpationOnsetAboveTheTargetForceIsWarnedOf) {
  auto d = tmp("onset");
  std::string s = study(kGroups, "", 20.0);
  s.replace(s.find("\"feature\": \"ovary_left\","), 24,
            "\"feature\": \"ovary_left\", \"palpation_onset\": 3,");
  spit(d / "onset.json", s);
  Result r = cli("validate " + (d / "onset.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err,
                  "warning: $.task.palpation_onset: 3 N is above the feature's target force "
                  "(MPF 2.5 N, SFT 3.5 N): a press to the target is not counted as a palpation"))
      << r.err;
  s.replace(s.find("\"palpation_onset\": 3"), 20, "\"palpation_onset\": 2.5");  // at the MPF
  spit(d / "at.json", s);
  r = cli("validate " + (d / "at.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(has(r.err, "warning")) << r.err;
  // Every digit that matters; the default named as such when the study does not set it.
  s.replace(s.find("\"palpation_onset\": 2.5"), 22, "\"palpation_onset\": 2.5000000001");
  spit(d / "just.json", s);
  r = cli("validate " + (d / "just.json").string(), d);
  EXPECT_TRUE(has(r.err, "$.task.palpation_onset: 2.5000000001 N is above")) << r.err;
  std::string low = study(kGroups, "", 20.0);
  low.replace(low.find("\"MPF\": 2.5"), 10, "\"MPF\": 0.4");
  spit(d / "low.json", low);
  r = cli("validate " + (d / "low.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err,
                  "warning: $.task: the default palpation_onset 0.5 N is above the "
                  "feature's target force (MPF 0.4 N, SFT 3.5 N)"))
      << r.err;
  EXPECT_FALSE(has(r.err, "has no \"*\" entry")) << r.err;
}

// Review finding (2026-12-07): a misspelt prototype id or region got no hint (keys did).
TEST(HardCli, MisspeltPrototypesAndRegionsGetADidYouMean) {
  auto d = tmp("didyoumean");
  spit(d / "s.json", study(R"([{"id": "G1", "prototype": "A", "size": 1},
                                {"id": "G2", "prototype": "Bb", "size": 1}])"));
  Result r = cli("validate " + (d / "s.json").string(), d);
  EXPECT_EXIT2_WITH(r, "unresolved prototype \"Bb\": no Bb.json in ");
  EXPECT_TRUE(has(r.err, "(did you mean \"B\"?)")) << r.err;
  std::ifstream in(std::string(PALPLAB_SOURCE_DIR) + "/prototypes/C.json");
  std::string c((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string fz = "\"fixed_z_below\": 0.02,";
  ASSERT_NE(c.find(fz), std::string::npos);
  c.replace(c.find(fz), fz.size(), fz + " \"fixed_region\": \"cervx\",");
  spit(d / "Cx.json", c);
  r = cli("probe " + (d / "Cx.json").string() + " --press 0 --force 1 --duration 0.01", d);
  EXPECT_EXIT2_WITH(r,
                    "$.model.fixed_region: unknown region \"cervx\" of the mesh (did you mean "
                    "\"cervix\"?)");
}

// Review finding (2026-12-07): thresholds for the feature only left every other region with each
// prototype's own "*" (group A's sound and events at 0.1 N, say), which the database's thresholds
// table does not hold. Valid, with a warning naming each prototype's.
TEST(HardCli, ThresholdsWithoutAStarSayWhatTheOtherRegionsKeep) {
  auto d = tmp("nostar");
  std::string s = study();
  const std::string star = R"({"*": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}})";
  ASSERT_NE(s.find(star), std::string::npos);
  s.replace(s.find(star), star.size(), R"({"ovary_left": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}})");
  spit(d / "nostar.json", s);
  const Result r = cli("validate " + (d / "nostar.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.err,
                  "warning: $.task.thresholds has no \"*\" entry: the regions it does not list "
                  "keep each prototype's own thresholds and sound at ST (A ST 2, MPF 2.5, SFT 3 "
                  "N; B ST 2, MPF 2.5, SFT 3 N), which the results database does not store"))
      << r.err;
  // Every region listed: nothing is left to the prototypes, no warning (review of the fix).
  std::string all = "{";
  for (const char* region :
       {"ovary_left", "ovary_right", "horn_left", "horn_right", "body", "cervix"})
    all += std::string(all.size() > 1 ? ", " : "") + "\"" + region +
           "\": {\"ST\": 2.3, \"MPF\": 2.5, \"SFT\": 3.5}";
  s.replace(s.find(R"({"ovary_left": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}})"),
            std::string(R"({"ovary_left": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}})").size(),
            all + "}");
  spit(d / "all.json", s);
  const Result a = cli("validate " + (d / "all.json").string(), d);
  EXPECT_EQ(a.code, 0) << a.err;
  EXPECT_FALSE(has(a.err, "has no \"*\" entry")) << a.err;
}

// Review finding (2026-12-06): the same analysis declared twice (a copy-paste) validated and was
// run, reported and counted in power twice. Exit 2 naming both entries; so is the same test with
// another option (Student instead of Welch), which the report's one section could not hold.
TEST(HardCli, TheSameAnalysisTwiceIsRefused) {
  auto d = tmp("dupanalysis");
  const std::string one =
      R"({"kind": "pairwise_t", "measure": "palpation_force", "phase": "post"})";
  spit(d / "dup.json",
       study(kGroups,
             R"( "analyses": [)" + one +
                 R"(, {"kind": "anova_oneway", "measure": "palpation_force", "phase": "post"}, )" +
                 one + "],"));
  Result r = cli("validate " + (d / "dup.json").string(), d);
  EXPECT_EXIT2_WITH(r,
                    "$.analyses[2]: the same analysis as $.analyses[0] (\"pairwise_t\" of "
                    "palpation_force in phase post, with the same options): remove one");
  spit(
      d / "other.json",
      study(
          kGroups,
          R"( "analyses": [)" + one +
              R"(, {"kind": "pairwise_t", "measure": "palpation_force", "phase": "post", "welch": false}],)"));
  r = cli("validate " + (d / "other.json").string(), d);
  // The report makes one section per measure, phase and pooling: the Welch test vanished from
  // it (the last "welch" won), as did a margin or a Student t declared beside another (review
  // 2026-12-07). Options of one section are declared once or agree.
  EXPECT_EXIT2_WITH(r,
                    "$.analyses[1].welch: false here but true (the default) in $.analyses[0], "
                    "an analysis of the same measure and phase: the report makes one section "
                    "of them, and welch is that section's option");
  spit(d / "margins.json",
       study(kGroups,
             R"( "analyses": [{"kind": "descriptives", "measure": "palpation_force", "phase": )"
             R"("post", "margin": 0.5}, {"kind": "pairwise_t", "measure": "palpation_force", )"
             R"("phase": "post", "margin": 0.2}],)"));
  // An ANOVA's section has the pairwise t-tests too (review of the fix: its "welch": false made
  // a declared pairwise_t Student's without a word).
  spit(d / "anova.json",
       study(kGroups,
             R"( "analyses": [{"kind": "anova_oneway", "measure": "palpation_force", "phase": )"
             R"("post", "welch": false}, {"kind": "pairwise_t", "measure": "palpation_force", )"
             R"("phase": "post"}],)"));
  r = cli("validate " + (d / "anova.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.analyses[1].welch: true (the default) here but false in $.analyses[0]");
  r = cli("validate " + (d / "margins.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.analyses[1].margin: 0.2 here but 0.5 in $.analyses[0]");
  // Set once, or the same in both, is one section with that option; another phase is another
  // section.
  spit(d / "agree.json",
       study(kGroups,
             R"( "analyses": [{"kind": "descriptives", "measure": "palpation_force", "phase": )"
             R"("post", "margin": 0.5}, {"kind": "pairwise_t", "measure": "palpation_force", )"
             R"("phase": "post", "welch": false}, {"kind": "anova_oneway", "measure": )"
             R"("palpation_force", "phase": "post", "margin": 0.5, "welch": false}],)"));
  r = cli("validate " + (d / "agree.json").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("anova_oneway(palpation_force @ post, pooled variance, margin 0.5)"),
            std::string::npos)
      << r.out;
  // pool_sessions by its value: the default beside true made validate show participant means
  // where the report pooled every session (review 2026-12-07).
  spit(d / "pool.json",
       study(kGroups,
             R"( "analyses": [{"kind": "descriptives", "measure": "palpation_force", "phase": )"
             R"("post", "pooled": true}, {"kind": "anova_oneway", "measure": )"
             R"("palpation_force", "phase": "post", "pooled": true, "pool_sessions": true}],)"));
  r = cli("validate " + (d / "pool.json").string(), d);
  EXPECT_EXIT2_WITH(r,
                    "$.analyses[1].pool_sessions: true here but false (the default) in "
                    "$.analyses[0]");
  // A margin with no test of its section is refused (the report ran no TOST for it).
  spit(d / "lone.json",
       study(kGroups,
             R"( "analyses": [{"kind": "descriptives", "measure": "palpation_force", "phase": )"
             R"("post", "margin": 0.5}],)"));
  r = cli("validate " + (d / "lone.json").string(), d);
  EXPECT_EXIT2_WITH(r,
                    "$.analyses[0].margin: a margin is that of the equivalence test (TOST) the "
                    "report runs beside an anova_oneway or pairwise_t");
  // Named by their places in the file, also after an entry that is no analysis.
  spit(d / "after.json", study(kGroups, R"( "analyses": ["oops", )" + one + ", " + one + "],"));
  r = cli("validate " + (d / "after.json").string(), d);
  EXPECT_EXIT2_WITH(r, "$.analyses[2]: the same analysis as $.analyses[1]");
}

// Review finding (2026-12-06): `run STUDY --seed -1` (run has no --seed) was CLI11's "The
// following arguments were not expected: -1 --seed", the words reversed. An unknown option is
// named as such with its command; other extra words in the order given; a command group with
// a word that is none of its commands lists them (it was "A subcommand is required").
TEST(HardCli, UnexpectedArgumentsAreSaidInTheOrderGiven) {
  auto d = tmp("extras");
  Result r = cli("run study.json --seed -1 --db x.db", d);
  EXPECT_EXIT2_WITH(r,
                    "error: palplab run: unknown option --seed (`palplab run --help` lists "
                    "its options)");
  r = cli("validate a.json b.json c.json", d);
  EXPECT_EXIT2_WITH(r,
                    "error: palplab validate: unexpected argument(s): b.json c.json (more "
                    "arguments than the command takes");
  r = cli("scene info x.psim y.psim", d);
  EXPECT_EXIT2_WITH(r, "error: palplab scene info: unexpected argument(s): y.psim");
  r = cli("--bogus validate f.json", d);
  EXPECT_EXIT2_WITH(r, "error: palplab: unknown option --bogus");
  r = cli("mesh bogus", d);
  EXPECT_EXIT2_WITH(r, "error: palplab mesh: unknown command 'bogus' — its commands are: ");
  EXPECT_FALSE(has(r.err, "A subcommand is required")) << r.err;
  r = cli("scene", d);
  EXPECT_EXIT2_WITH(r, "error: palplab scene: which command? — its commands are: ");
}

// A named FIFO as an input file (a study here; every JSON, CSV and mesh input is read by
// common/read_file): read when a writer holds it open (a pipe, `<(command)`); with no writer it
// blocked for ever, then (review 2026-12-06, third) read as an empty file, "empty study". Now
// exit 2 at once saying that nothing was written to the FIFO.
TEST(HardInput, AFifoWithoutAWriterIsSaidSoAndAPipeIsRead) {
  auto d = tmp("fifo_in");
  std::ofstream(d / "s.json") << palplab::testing::tiny_study_json("fifo", 3);
  ASSERT_EQ(::mkfifo((d / "s_fifo.json").c_str(), 0644), 0);
  Result r = cli("validate " + (d / "s_fifo.json").string(), d);
  EXPECT_EXIT2_WITH(r,
                    "s_fifo.json: is a FIFO and nothing was written to it (its writer wrote "
                    "nothing, or no writer had it open when it was read: start the writer "
                    "first); expected a ");
  const auto piped = palplab::testing::run_shell(
      "cat " + (d / "s.json").string() + " | PALPLAB_PROTOTYPE_PATH=" +
          std::string(PALPLAB_SOURCE_DIR) + "/prototypes timeout -s KILL " +
          std::to_string(kCommandLimitS) + " " + PALPLAB_BINARY + " validate /dev/stdin",
      d);
  EXPECT_EQ(piped.code, 0) << piped.err;
}

// Review finding (2026-12-06): a FIFO given as the database hung the command (its first read
// blocks). Exit 2 at once.
TEST(HardDb, AFifoAsTheDatabaseIsRefusedWithoutWaiting) {
  auto d = tmp("fifo");
  ASSERT_EQ(::mkfifo((d / "x.db").c_str(), 0644), 0);
  for (const std::string& cmd :
       {"report " + (d / "x.db").string() + " --out " + (d / "r").string(),
        "export " + (d / "x.db").string() + " --csv " + (d / "c").string()}) {
    Result r = cli(cmd, d);
    EXPECT_EXIT2_WITH(r,
                      "x.db: is not a regular file (a FIFO or a device; expected a results "
                      "database file)");
  }
}
