// End-to-end tests of `palplab mesh ...`: exit codes, JSON keys, files written.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include "tests/cli_support.hpp"
#include "tests/sqlite_support.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

using Result = palplab::testing::CliResult;
using palplab::testing::slurp;

Result run(const std::string& args) {
  return palplab::testing::run_palplab(args);
}
std::string p(const std::string& name) {
  return palplab::testing::scratch_file(name);
}

}  // namespace

TEST(CliMesh, GenerateThenInfoJsonHasTheContractKeys) {
  ASSERT_EQ(run("mesh generate model-a --out " + p("a.obj")).code, 0);
  Result r = run("mesh info " + p("a.obj") + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const json j = json::parse(r.out);
  for (const char* k : {"vertices", "faces", "edges", "tets", "boundary_faces", "boundary_loops",
                        "genus", "bbox", "regions"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_NEAR(j["vertices"].get<double>(), 1500, 150);
  EXPECT_NEAR(j["faces"].get<double>(), 3000, 300);
  EXPECT_EQ(j["tets"], 0);
  EXPECT_EQ(j["genus"], 0);
  EXPECT_EQ(j["boundary_loops"], 0);
  EXPECT_NEAR(j["bbox"][1][2].get<double>() - j["bbox"][0][2].get<double>(), 0.355, 0.0355);
  for (const char* reg : {"ovary_left", "ovary_right", "horn_left", "horn_right", "body", "cervix"})
    EXPECT_GT(j["regions"][reg].get<int>(), 0) << reg;
}

TEST(CliMesh, ModelCAndRegionsSurviveTetrahedralization) {
  ASSERT_EQ(run("mesh generate model-c --out " + p("c") + " --vtu").code, 0);
  for (const char* ext : {".node", ".ele", ".face", ".neigh", ".names", ".vtu"})
    EXPECT_TRUE(fs::exists(p(std::string("c") + ext))) << ext;
  Result r = run("mesh info " + p("c.ele") + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_NEAR(j["vertices"].get<double>(), 2487, 248.7);
  EXPECT_NEAR(j["tets"].get<double>(), 8744, 874.4);
  // A quality mesh (issue 9): fewer surface faces than the original work's skin mesh (4974),
  // interior nodes, bounded angles and mass spread.
  EXPECT_EQ(j["boundary_faces"], 3204);
  EXPECT_GT(j["interior_nodes"].get<double>(), 0.25 * j["vertices"].get<double>());
  EXPECT_GT(j["dihedral_angle"]["min"].get<double>(), 7.0);
  EXPECT_LE(j["radius_edge_ratio"]["max"].get<double>(), 2.0);
  EXPECT_LT(j["node_mass_ratio"].get<double>(), 250.0);
  EXPECT_EQ(j["genus"], 0);
  EXPECT_EQ(j["regions"].size(), 6u);
  EXPECT_EQ(run("mesh check " + p("c.node")).code, 0);
  // The VTU copy reads back with the same counts.
  const json v = json::parse(run("mesh info " + p("c.vtu") + " --json").out);
  EXPECT_EQ(v["tets"], j["tets"]);
  EXPECT_EQ(v["regions"], j["regions"]);
}

TEST(CliMesh, GenerateIsDeterministic) {
  for (const char* name : {"model-b", "stomach", "sphere"}) {
    ASSERT_EQ(
        run(std::string("mesh generate ") + name + " --out " + p("d1.ply") + " --binary").code, 0);
    ASSERT_EQ(
        run(std::string("mesh generate ") + name + " --out " + p("d2.ply") + " --binary").code, 0);
    EXPECT_EQ(slurp(p("d1.ply")), slurp(p("d2.ply"))) << name;
  }
  // Model-C (TetGen with quality refinement): same arguments, same bytes.
  ASSERT_EQ(run("mesh generate model-c --vertices 750 --out " + p("mc1")).code, 0);
  ASSERT_EQ(run("mesh generate model-c --vertices 750 --out " + p("mc2")).code, 0);
  for (const char* ext : {".node", ".ele", ".face", ".names"})
    EXPECT_EQ(slurp(p(std::string("mc1") + ext)), slurp(p(std::string("mc2") + ext))) << ext;
  ASSERT_EQ(run("mesh generate model-a --seed 5 --out " + p("s5.obj")).code, 0);
  ASSERT_EQ(run("mesh generate model-a --out " + p("s0.obj")).code, 0);
  EXPECT_NE(slurp(p("s5.obj")), slurp(p("s0.obj")));
  const json j = json::parse(run("mesh info " + p("s5.obj") + " --json").out);
  EXPECT_EQ(j["genus"], 0);
}

// A vertex count the generator cannot come near is said, not silently replaced (review
// 2026-12-06, second); a count it meets is not.
TEST(CliMesh, GenerateSaysWhenTheCountIsFarFromTheOneAskedFor) {
  Result r = run("mesh generate model-a --vertices 200 --out " + p("few.obj"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("model-a: 478 vertices"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("note: model-a has 478 vertices, the closest to --vertices 200 this "
                       "generator makes"),
            std::string::npos)
      << r.err;
  r = run("mesh generate model-a --vertices 1500 --out " + p("many.obj"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("note:"), std::string::npos) << r.err;
  // The shoulder's layers and model-c's surface too (review 2026-12-06, second: no note).
  r = run("mesh generate shoulder --vertices 700 --out " + p("sh700"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("note: shoulder has 642 vertices per skin layer, the closest to "
                       "--vertices 700"),
            std::string::npos)
      << r.err;
  r = run("mesh generate model-c --vertices 1000 --out " + p("c1000.node"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("surface vertices, the closest to --vertices 1000"), std::string::npos)
      << r.err;
}

TEST(CliMesh, CheckExitCodesAndJson) {
  // Clean: 0.
  ASSERT_EQ(run("mesh generate sphere --vertices 2562 --out " + p("sp.stl")).code, 0);
  Result r = run("mesh check " + p("sp.stl") + " --json");
  EXPECT_EQ(r.code, 0) << r.err;
  json j = json::parse(r.out);
  EXPECT_EQ(j["clean"], true);
  EXPECT_TRUE(j["defects"].empty());
  // Defects: 1, with located entries of the contract kinds.
  {
    std::ofstream f(p("hole.off"));
    f << "OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n";
  }
  r = run("mesh check " + p("hole.off") + " --json");
  EXPECT_EQ(r.code, 1);
  j = json::parse(r.out);
  EXPECT_EQ(j["clean"], false);
  ASSERT_EQ(j["defects"].size(), 3u);
  for (auto& d : j["defects"]) {
    EXPECT_EQ(d["kind"], "open_edge");
    EXPECT_EQ(d["vertices"].size(), 2u);
    EXPECT_EQ(d["points"].size(), 2u);
  }
  // The stomach is open by design.
  ASSERT_EQ(run("mesh generate stomach --out " + p("st.obj")).code, 0);
  EXPECT_EQ(run("mesh check " + p("st.obj")).code, 1);
  EXPECT_EQ(run("mesh check " + p("st.obj") + " --allow-open").code, 0);
  // Unreadable: 2, with the file and line on stderr.
  {
    std::ofstream f(p("bad.obj"));
    f << "v 0 0 0\nf 1 2 3\n";
  }
  r = run("mesh check " + p("bad.obj"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.obj:2:"), std::string::npos) << r.err;
  EXPECT_EQ(run("mesh check " + p("does-not-exist.obj")).code, 2);
}

TEST(CliMesh, RepairMakesTheMeshClean) {
  {
    std::ofstream f(p("broken.obj"));
    // Tetrahedron with one face flipped, one missing, and a duplicated corner.
    f << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 2 3 5\n";
  }
  EXPECT_EQ(run("mesh check " + p("broken.obj")).code, 1);
  Result r = run("mesh repair " + p("broken.obj") + " --out " + p("fixed.obj"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("duplicate vertices merged"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("holes filled"), std::string::npos) << r.out;
  EXPECT_EQ(run("mesh check " + p("fixed.obj")).code, 0);
  EXPECT_EQ(r.out.find("left as they are"), std::string::npos) << r.out;
  const json j = json::parse(run("mesh info " + p("fixed.obj") + " --json").out);
  EXPECT_EQ(j["genus"], 0);
  // Two tetrahedra sharing an edge: nothing a safe repair changes, and that is not all it says
  // (it printed "no changes" alone; review 2026-12-07).
  std::ofstream(p("nonman.obj")) << "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nv 0.1 0.1 0\n"
                                    "v 0.1 0 -0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 1 2 5\n"
                                    "f 1 6 2\nf 2 6 5\nf 1 5 6\n";
  r = run("mesh repair " + p("nonman.obj") + " --out " + p("nonman_r.obj"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("no changes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("left as they are (not safe to repair automatically): non_manifold_edge 1 "
                       "non_manifold_vertex 2"),
            std::string::npos)
      << r.out;
  r = run("mesh repair " + p("nonman.obj") + " --out " + p("nonman_r.obj") + " --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(json::parse(r.out)["remaining_defects"]["non_manifold_edge"], 1) << r.out;
}

TEST(CliMesh, TetrahedralizeWithRegionsFile) {
  ASSERT_EQ(run("mesh generate sphere --out " + p("ball.stl")).code, 0);
  {
    std::ofstream f(p("ball.regions"));  // side file next to the STL: picked up
    f << "1\n1 0 0 0 103 0\n";
  }
  Result r =
      run("mesh tetrahedralize " + p("ball.stl") + " --out " + p("ball_t") + " --quality 1.5");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("ball.regions"), std::string::npos);
  json j = json::parse(run("mesh info " + p("ball_t.node") + " --json").out);
  EXPECT_EQ(j["tissues"].size(), 1u);
  EXPECT_EQ(j["tissues"]["103"]["tissue"], "arteries");
  // .vtu output by extension; bad flags and files are exit 2.
  EXPECT_EQ(run("mesh tetrahedralize " + p("ball.stl") + " --out " + p("ball_t.vtu")).code, 0);
  EXPECT_TRUE(fs::exists(p("ball_t.vtu")));
  EXPECT_EQ(
      run("mesh tetrahedralize " + p("ball.stl") + " --out " + p("x") + " --quality 0.5").code, 2);
  EXPECT_EQ(run("mesh tetrahedralize " + p("st.obj") + " --out " + p("x")).code, 2);  // open
  EXPECT_EQ(run("mesh generate nothing --out " + p("x.obj")).code, 2);
  EXPECT_EQ(run("mesh generate sphere").code, 2);  // --out missing
  EXPECT_EQ(run("mesh generate model-a --out " + p("x.xyz")).code, 2);
}

// A long token in a mesh file is shown cut (a 1 MB one made a 1 MB message; review 2026-12-07).
TEST(CliMesh, ALongBadTokenIsShownCut) {
  {
    std::ofstream f(p("longtok.obj"));
    f << "v 0 0 " << std::string(100000, '7') << "x\n";
  }
  const Result r = run("mesh info " + p("longtok.obj"));
  EXPECT_EQ(r.code, 2) << r.err.substr(0, 300);
  EXPECT_NE(r.err.find("got '" + std::string(40, '7') + "\u2026 (100001 bytes)'"),
            std::string::npos)
      << r.err.substr(0, 300);
  EXPECT_LT(r.err.size(), 400u);
}

// --max-volume is TetGen's target, and the surface is kept as given: a 4 cm cube of 12 faces met
// a bound of 1e-6 m³ with tets of up to 7e-6 m³ and said nothing (review 2026-12-07). The tets
// above the bound are counted with the largest; a bound the mesh meets says nothing.
TEST(CliMesh, TetrahedralizeSaysWhenTetsStayAboveMaxVolume) {
  {
    std::ofstream f(p("cube12.obj"));
    f << "v 0 0 0\nv 0.04 0 0\nv 0.04 0.04 0\nv 0 0.04 0\nv 0 0 0.04\nv 0.04 0 0.04\n"
         "v 0.04 0.04 0.04\nv 0 0.04 0.04\nf 1 4 3\nf 1 3 2\nf 1 2 6\nf 1 6 5\nf 2 3 7\n"
         "f 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\nf 5 6 7\nf 5 7 8\n";
  }
  Result r = run("mesh tetrahedralize " + p("cube12.obj") + " --out " + p("cube12_t") +
                 " --max-volume 1e-6 --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find(" tets are above --max-volume 1e-06 m³ (the largest "), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("the surface is kept as given (TetGen -Y)"), std::string::npos) << r.err;
  r = run("mesh tetrahedralize " + p("cube12.obj") + " --out " + p("cube12_u") +
          " --max-volume 1e-4 --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("above --max-volume"), std::string::npos) << r.err;
}

TEST(CliMesh, MaterialsTable) {
  Result r = run("mesh materials");
  ASSERT_EQ(r.code, 0);
  const json j = json::parse(r.out);
  EXPECT_EQ(j["materials"].size(), 11u);
  ASSERT_EQ(run("mesh materials --out " + p("m.json")).code, 0);
  EXPECT_EQ(run("mesh materials --check " + p("m.json")).code, 0);
  {
    std::ofstream f(p("badm.json"));
    f << R"({"materials": [{"first": 1}]})";
  }
  r = run("mesh materials --check " + p("badm.json"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("$.materials[0]"), std::string::npos) << r.err;
  // --check writes nothing: an --out beside it was silently ignored.
  r = run("mesh materials --check " + p("m.json") + " --out " + p("m2.json"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--out excludes --check"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(p("m2.json")));
}

// Flags that the mesh ignores (--vtu of a surface, --seed of the sphere, --binary of .obj) were
// accepted silently; a tet-mesh output that cannot be written (or is a surface format) was found
// after TetGen or the generator had run.
TEST(CliMesh, IgnoredFlagsAndUnwritableOutputsAreInputErrors) {
  struct Case {
    std::string args, flag, needed;
  };
  for (const Case& c : std::vector<Case>{
           {"mesh generate sphere --vtu --out " + p("f1.obj"), "--vtu", "model-c"},
           {"mesh generate sphere --seed 3 --out " + p("f2.obj"), "--seed", "stomach"},
           {"mesh generate model-a --binary --out " + p("f3.obj"), "--binary", ".stl or .ply"},
           {"mesh generate model-c --binary --out " + p("f4"), "--binary", ".stl or .ply"}}) {
    const Result r = run(c.args);
    EXPECT_EQ(r.code, 2) << c.args << ": " << r.out << r.err;
    EXPECT_NE(r.err.find(c.flag + ": applies only with"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.needed), std::string::npos) << r.err;
  }
  for (const char* f : {"f1.obj", "f2.obj", "f3.obj", "f4.node"}) EXPECT_FALSE(fs::exists(p(f)));
  const Result m = run("mesh generate model-c --out /nonexistent_dir_palplab/c");
  EXPECT_EQ(m.code, 2) << m.out << m.err;
  EXPECT_NE(m.err.find("/nonexistent_dir_palplab/c.node"), std::string::npos) << m.err;
  EXPECT_EQ(m.out.find("model-c:"), std::string::npos) << m.out;
  ASSERT_EQ(run("mesh generate sphere --vertices 162 --out " + p("s162.obj")).code, 0);
  const Result t =
      run("mesh tetrahedralize " + p("s162.obj") + " --out /nonexistent_dir_palplab/t");
  EXPECT_EQ(t.code, 2) << t.out << t.err;
  EXPECT_NE(t.err.find("--out"), std::string::npos) << t.err;
  EXPECT_NE(t.err.find("/nonexistent_dir_palplab/t.node"), std::string::npos) << t.err;
  const Result s = run("mesh tetrahedralize " + p("s162.obj") + " --out " + p("t.obj"));
  EXPECT_EQ(s.code, 2) << s.out << s.err;
  EXPECT_NE(s.err.find("TetGen files"), std::string::npos) << s.err;
  EXPECT_EQ(s.out.find("TetGen -"), std::string::npos) << s.out;
}

// Option values: each flag's range in one readable message (--max-defects printed its range as
// "0.000000 to 179769313486231570814527..." and refused 0, which is in it), 0 / negative /
// non-finite values refused alike instead of silently meaning "default" or "none".
TEST(CliMesh, OptionValuesAreCheckedWithTheirRange) {
  ASSERT_EQ(run("mesh generate sphere --vertices 162 --out " + p("o162.obj")).code, 0);
  // --max-defects 0: counts only (the defects are still counted: exit 1 on a defect).
  Result r = run("mesh check " + p("o162.obj") + " --max-defects 0");
  EXPECT_EQ(r.code, 0) << r.err;
  {
    std::ofstream f(p("open.obj"));
    f << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  }
  r = run("mesh check " + p("open.obj") + " --max-defects 0 --json");
  EXPECT_EQ(r.code, 1) << r.err;
  const json j = json::parse(r.out);
  EXPECT_FALSE(j["clean"].get<bool>());
  EXPECT_TRUE(j["defects"].empty());
  EXPECT_TRUE(j["truncated"].get<bool>());
  struct Case {
    std::string args, says;
  };
  const std::string tet = "mesh tetrahedralize " + p("o162.obj") + " --out " + p("ot");
  for (const Case& c : std::vector<Case>{
           {"mesh check " + p("o162.obj") + " --max-defects -1",
            "expected an integer in [0, 2147483647], got '-1'"},
           {"mesh check " + p("o162.obj") + " --max-defects 1e99", "got '1e99'"},
           {"mesh repair " + p("o162.obj") + " --out " + p("or.obj") + " --max-hole-edges -3",
            "expected an integer in [0, 2147483647], got '-3'"},
           {"mesh generate sphere --vertices 0 --out " + p("v0.obj"),
            "--vertices: expected an integer in [1, 2147483647], got '0'"},
           {"mesh generate sphere --vertices -5 --out " + p("v5.obj"), "got '-5'"},
           {"mesh generate model-a --vertices 0 --out " + p("v0a.obj"), "got '0'"},
           {tet + " --timeout -1", "--timeout: expected a finite number in [0, 1e+09], got '-1'"},
           {tet + " --timeout nan", "got 'nan'"},
           {tet + " --timeout inf", "got 'inf'"},
           {tet + " --max-volume 0",
            "--max-volume: expected a finite number in (0, 1e+18], got '0'"},
           {tet + " --max-volume -1", "got '-1'"},
           {tet + " --max-volume nan", "got 'nan'"},
           // Review 2026-12-06 (second): CLI11's bare "Could not convert: --quality = x".
           {tet + " --quality x", "--quality: expected a finite number in [0, 1e+06], got 'x'"},
           {tet + " --attribute 1e99",
            "--attribute: expected an integer in [0, 1000000000], got '1e99'"},
           // Review 2026-12-06 (second): 1e-30 grew TetGen by ~55 MB/s until --timeout.
           {tet + " --max-volume 1e-30",
            "--max-volume 1e-30 m^3 asks for at least 5.06e+26 tetrahedra (the surface encloses "
            "0.000506 m^3)"},
           {tet + " --max-volume 4.9e-324",
            "--max-volume 4.94e-324 m^3 asks for more than 1e308 tetrahedra"}}) {
    r = run(c.args);
    EXPECT_EQ(r.code, 2) << c.args << ": " << r.out << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << c.args << ": " << r.err;
    EXPECT_EQ(r.err.find("17976931348623157"), std::string::npos) << r.err;
  }
  for (const char* f : {"v0.obj", "v5.obj", "v0a.obj", "ot.node", "or.obj"})
    EXPECT_FALSE(fs::exists(p(f))) << f;
  // In range: accepted.
  EXPECT_EQ(run(tet + " --timeout 0 --max-volume 1e-5").code, 0);
}

// A --materials file that does not exist (or is invalid) is an error whatever the mesh (a
// surface's info does not use the table, but a typo must not pass silently).
TEST(CliMesh, NamedMaterialsFileMustExist) {
  ASSERT_EQ(run("mesh generate sphere --vertices 162 --out " + p("m162.obj")).code, 0);
  Result r = run("mesh info " + p("m162.obj") + " --materials /nonexistent_palplab/m.json");
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("/nonexistent_palplab/m.json"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  {
    std::ofstream f(p("badm2.json"));
    f << R"({"materials": [{"first": 1}]})";
  }
  r = run("mesh info " + p("m162.obj") + " --materials " + p("badm2.json"));
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("$.materials[0]"), std::string::npos) << r.err;
  // A directory is said as such (it read as an empty JSON text: "unexpected end of input").
  std::filesystem::create_directories(p("mdir"));
  r = run("mesh materials --check " + p("mdir"));
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("is a directory"), std::string::npos) << r.err;
  ASSERT_EQ(run("mesh materials --out " + p("m2.json")).code, 0);
  EXPECT_EQ(run("mesh info " + p("m162.obj") + " --materials " + p("m2.json")).code, 0);
  // A directory and a file without an extension as the mesh (both were "unknown surface format
  // ''": review 2026-12-06, seventh); a missing .regions file is not "a mesh file".
  r = run("mesh info " + p("mdir"));
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("is a directory (expected a mesh file"), std::string::npos) << r.err;
  std::ofstream(p("noext")) << "v 0 0 0\n";
  r = run("mesh info " + p("noext"));
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("the file name has no extension, which tells the mesh format"),
            std::string::npos)
      << r.err;
  r = run("mesh tetrahedralize " + p("m162.obj") + " --regions " + p("none.regions") + " --out " +
          p("t.node"));
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("(expected a readable .regions file)"), std::string::npos) << r.err;
  // A TetGen mesh's .face or .neigh given alone points to its .ele (it was "unknown surface
  // format '.face'" with the surface formats only: 2026-12-06, noticed); the .ele is read.
  ASSERT_EQ(run("mesh generate model-c --out " + p("tg")).code, 0);
  for (const char* e : {".face", ".neigh", ".names"}) {
    r = run("mesh check " + p("tg") + e);
    EXPECT_EQ(r.code, 2) << r.out << r.err;
    EXPECT_NE(r.err.find(p("tg") + e + ": a TetGen mesh's " + e +
                         " file is read with the mesh: give its .ele (" + p("tg") +
                         ".ele) or .node (expected a mesh file"),
              std::string::npos)
        << r.err;
  }
  EXPECT_EQ(run("mesh info " + p("tg.ele")).code, 0);
  r = run("mesh check " + p("nothere.face"));
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find(p("nothere.face") + ": no such file; a TetGen mesh's .face file"),
            std::string::npos)
      << r.err;
}

// A tissue attribute the material table does not define (--attribute 999, a seed's region_id
// 150, anything with an empty table) was written as NaN material cell data with exit 0. SPEC §4's
// 0-99 "undefined" tissue is a table entry of its own: --attribute 50 is fine.
TEST(CliMesh, TetrahedralizeRefusesTissueAttributesTheMaterialTableLacks) {
  using palplab::testing::expect_exit2;
  ASSERT_EQ(run("mesh generate sphere --vertices 162 --out " + p("u162.obj")).code, 0);
  const std::string tet = "mesh tetrahedralize " + p("u162.obj");
  Result r = run(tet + " --out " + p("u999.vtu") + " --attribute 999");
  expect_exit2(r, {"--attribute 999: tissue attribute 999 is not defined by the material table "
                   "<built-in materials>, which defines 0-99 undefined, 100 skin",
                   "300-399 muscle", "entry covering 999"});
  EXPECT_FALSE(fs::exists(p("u999.vtu")));
  EXPECT_EQ(r.out.find("TetGen -"), std::string::npos) << r.out;  // refused before TetGen
  const std::string empty = palplab::testing::write_temp("u_empty.json", R"({"materials": []})");
  r = run(tet + " --out " + p("uempty") + " --vtu --materials " + empty);
  expect_exit2(r, {"--attribute 0 (the default): tissue attribute 0 is not defined",
                   "material table " + empty, "no tissue at all"});
  for (const char* f : {"uempty.node", "uempty.ele", "uempty.vtu"}) EXPECT_FALSE(fs::exists(p(f)));
  const std::string seeds = palplab::testing::write_temp("u150.regions", "1\n1 0 0 0 150 0\n");
  r = run(tet + " --out " + p("u150") + " --regions " + seeds);
  expect_exit2(r, {seeds + ": region seed 1 (region_id): tissue attribute 150 is not defined"});
  EXPECT_FALSE(fs::exists(p("u150.node")));
  // Undefined tissue (0-99) is defined: its values, never NaN.
  r = run(tet + " --out " + p("u50") + " --vtu --attribute 50");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string vtu = slurp(p("u50.vtu"));
  EXPECT_NE(vtu.find("Name=\"youngs_modulus\""), std::string::npos);
  EXPECT_EQ(vtu.find("nan"), std::string::npos);

  // Nested closed surfaces, the humerus's seed (200) left out: its tets get --attribute (TetGen
  // numbered them 301 = muscle), and an undefined default is found after TetGen.
  ASSERT_EQ(run("mesh generate shoulder --vertices 162 --out " + p("ush")).code, 0);
  std::ifstream in(p("ush.regions"));
  std::string line, kept;
  int n = 0;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    double i, x, y, z;
    int id;
    ASSERT_TRUE(ls >> i >> x >> y >> z >> id) << line;
    if (id == 200) continue;
    kept += line + "\n";
    ++n;
  }
  ASSERT_GT(n, 0);
  const std::string part =
      palplab::testing::write_temp("ush_part.regions", std::to_string(n) + "\n" + kept);
  const std::string sh = "mesh tetrahedralize " + p("ush.obj") + " --regions " + part;
  r = run(sh + " --out " + p("ush5") + " --attribute 5");
  ASSERT_EQ(r.code, 0) << r.err;
  const json j = json::parse(run("mesh info " + p("ush5.node") + " --json").out);
  EXPECT_TRUE(j["tissues"].contains("5")) << j["tissues"].dump();
  EXPECT_FALSE(j["tissues"].contains("301")) << j["tissues"].dump();
  EXPECT_FALSE(j["tissues"].contains("200")) << j["tissues"].dump();
  json table = json::parse(run("mesh materials").out);
  json no_undefined = json::array();
  for (auto& m : table["materials"])
    if (m["first"] != 0) no_undefined.push_back(m);
  table["materials"] = no_undefined;
  const std::string t = palplab::testing::write_temp("u_no0.json", table.dump());
  r = run(sh + " --out " + p("ush0") + " --materials " + t);
  expect_exit2(r, {"--attribute 0 (the default), the tissue of the tets outside every region of " +
                       part + ": tissue attribute 0 is not defined by the material table " + t,
                   "which defines 100 skin"});
  EXPECT_FALSE(fs::exists(p("ush0.node")));
}

// Review: the .regions parser took `12abc` as 12, a missing attribute, NaN and `1abc` as the
// count with exit 0, and blamed the wrong field for `101.5`. Now every token is parsed whole.
TEST(CliMesh, RegionsFileIsParsedStrictly) {
  ASSERT_EQ(run("mesh generate sphere --out " + p("rs.obj")).code, 0);
  struct Case {
    std::string text, where, expected;
  };
  for (const Case& c : std::vector<Case>{
           {"1\n1 0 0 0 12abc 0\n", "rs.regions:2:", "region_id (field 5"},
           {"1\n1 0 0 0 101\n", "rs.regions:2:", "the attribute is missing"},
           {"1\n1 0 0 0 101 nan\n", "rs.regions:2:", "attribute (field 6"},
           {"1abc\n1 0 0 0 101 0\n", "rs.regions:1:", "the number of regions"},
           {"1\n1 0 0 0 101.5 0\n", "rs.regions:2:", "region_id (field 5"},
           {"2\n1 0 0 0 101 0\n1 0 0 0.001 102 0\n",
            "rs.regions:3:", "index 1 is given twice (also on line 2"},
           // Review 2026-12-06 (second): a seed's bound let TetGen grow until --timeout.
           {"1\n1 0 0 0 101 1e-12\n",
            "rs.regions:2:", "region seed 1's volume bound 1e-12 m^3 asks for up to"},
           {"1\n1 0 0x 0 101 0\n", "rs.regions:2:", "y (field 3)"},
           {"1\n1 0 0 0 101 0 7\n", "rs.regions:2:", "unexpected text '7' after the attribute"},
           {"-1\n", "rs.regions:1:", "the number of regions"},
           {"2\n1 0 0 0 101 0\n", "rs.regions:2:", "announces 2 regions but 1 follow"},
       }) {
    {
      std::ofstream f(p("rs.regions"));
      f << c.text;
    }
    Result r = run("mesh tetrahedralize " + p("rs.obj") + " --out " + p("rs_t"));
    EXPECT_EQ(r.code, 2) << c.text << r.err;
    EXPECT_NE(r.err.find(c.where), std::string::npos) << c.text << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.text << r.err;
  }
  {
    std::ofstream f(p("rs.regions"));
    f << "# seeds\n1\n1 0 0 0 101 0  # soft tissue\n";
  }
  Result r = run("mesh tetrahedralize " + p("rs.obj") + " --out " + p("rs_t"));
  EXPECT_EQ(r.code, 0) << r.err;
}

// Review: a seed outside the surface crashed TetGen and the message blamed the surface.
TEST(CliMesh, RegionSeedOutsideTheSurfaceIsNamed) {
  ASSERT_EQ(run("mesh generate sphere --out " + p("ro.obj")).code, 0);
  {
    std::ofstream f(p("ro.regions"));
    f << "2\n1 0 0 0 101 0\n2 0 0 5 100 0\n";
  }
  Result r = run("mesh tetrahedralize " + p("ro.obj") + " --out " + p("ro_t"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("ro.regions:3:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("region seed 2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not inside the closed surface"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(p("ro_t.ele")));
  // Nested surfaces: the generated shoulder's seeds (between skin layers etc.) are all inside.
  ASSERT_EQ(run("mesh generate shoulder --vertices 642 --out " + p("ro_sh")).code, 0);
  r = run("mesh tetrahedralize " + p("ro_sh.obj") + " --out " + p("ro_sh_t"));
  EXPECT_EQ(r.code, 0) << r.err;
}

// Review: --seed -1 / 99999999999999999999 saturated to 2^64-1 with exit 0.
TEST(CliMesh, GenerateSeedIsAStrictUnsigned64BitInteger) {
  for (const char* s :
       {"-1", "99999999999999999999", "18446744073709551617", "1.5", "12abc", "+3", "0x10", ""}) {
    Result r = run(std::string("mesh generate model-a --seed '") + s + "' --out " + p("sd.obj"));
    EXPECT_EQ(r.code, 2) << s << r.err;
    EXPECT_NE(r.err.find("expected an unsigned 64-bit decimal integer"), std::string::npos)
        << s << r.err;
  }
  EXPECT_EQ(run("mesh generate model-a --seed 18446744073709551615 --out " + p("sd.obj")).code, 0);
}

// Review: the material table took "last": 4294967296 (wrapped to 0), unknown and duplicate keys,
// a wrong "format" and "version": 2 with exit 0.
TEST(CliMesh, MaterialTableIsCheckedStrictly) {
  const std::string entry =
      R"("name": "a", "youngs_modulus": 1, "poisson_ratio": 0.3, "density": 1, "colour": [0, 0, 0])";
  struct Case {
    std::string text, where, expected;
  };
  for (const Case& c : std::vector<Case>{
           {R"({"materials": [{"first": 1, "last": 4294967296, )" + entry + "}]}",
            "mt.json:1:", "$.materials[0].last: expected an integer tissue attribute"},
           {R"({"materials": [{"first": 1, "last": 1, "youngs_modlus": 2, )" + entry + "}]}",
            "mt.json:1:", "unknown key \"youngs_modlus\" (allowed: first, last, name"},
           {"{\"materials\": [{\"first\": 1,\n \"first\": 2, \"last\": 3, " + entry + "}]}",
            "mt.json:2:", "duplicate key"},
           {R"({"format": "palplab-material", "materials": []})",
            "mt.json:1:", "$.format: expected \"palplab-materials\""},
           {R"({"format": "palplab-materials", "version": 2, "materials": []})",
            "mt.json:1:", "$.version: expected 1"},
           {R"({"colours": 1, "materials": []})", "mt.json:1:", "unknown key \"colours\""},
           {R"({"materials": [{"first": 1, "last": 1, "needle": {"frction": 1}, )" + entry + "}]}",
            "mt.json:1:", "$.materials[0].needle.frction: unknown key"},
           {"{\"materials\": [{\"first\": 1, \"last\": 1, " + entry + ", \"density\": -1}]}",
            "mt.json:1:", "duplicate key"},
       }) {
    const std::string f = palplab::testing::write_temp("mt.json", c.text);
    Result r = run("mesh materials --check " + f);
    EXPECT_EQ(r.code, 2) << c.text << r.err;
    EXPECT_NE(r.err.find(c.where), std::string::npos) << c.text << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.text << r.err;
  }
  // Bounds are printed with %g, not %f.
  const std::string f = palplab::testing::write_temp(
      "mt.json", R"({"materials": [{"first": 1, "last": 1, "name": "a", "youngs_modulus": 1,
      "poisson_ratio": 0.3, "density": -1, "colour": [0, 0, 0]}]})");
  Result r = run("mesh materials --check " + f);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("mt.json:2:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("expected a value in (0, 100000], got -1"), std::string::npos) << r.err;
  // Optional "format"/"version" with the right values, and the notes, are fine.
  EXPECT_EQ(run("mesh materials --check " +
                palplab::testing::write_temp(
                    "mt_ok.json", R"({"format": "palplab-materials", "version": 1, "note": "x",
                    "materials": [{"first": 1, "last": 1, )" +
                                      entry + "}]}"))
                .code,
            0);
}

// Review: generate, repair and tetrahedralize wrote their --out files without the guard the other
// commands have (app::require_replaceable_output): `mesh repair X --out X` truncated the input,
// `tetrahedralize X.vtu --out X.vtu` replaced it, and a database, a study JSON or an image at an
// output path (BASE.node, the shoulder's BASE.regions, a stale BASE.names TetGen removes) was
// lost. Now an output is never an input (exit 2, --overwrite or not; there is no in-place
// repair) and a file of another kind is replaced only with --overwrite; nothing is written
// before a refusal.
namespace {

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// Victims: a results database, a study JSON, a PNG image (its 8-byte signature and a little).
std::string make_database(const std::string& name) {
  const std::string db = p(name);
  fs::remove(db);
  palplab::testing::sql_exec(db, "CREATE TABLE kept(x); INSERT INTO kept VALUES (42);");
  return db;
}
std::string make_study(const std::string& name) {
  const std::string f = p(name);
  write_bytes(f, palplab::testing::tiny_study_json("victim", 7));
  return f;
}
std::string make_png(const std::string& name) {
  const std::string f = p(name);
  write_bytes(f, std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16) + std::string(40, '\x07'));
  return f;
}

// Exit 2 naming --out and the file, stderr holding every one of `parts`, `victim` unchanged.
void expect_refused(const std::string& args, const std::string& victim,
                    std::initializer_list<std::string> parts) {
  SCOPED_TRACE(args);
  const std::string before = slurp(victim);
  ASSERT_FALSE(before.empty()) << victim;
  const Result r = run(args);
  palplab::testing::expect_exit2(r, {"--out: \"" + victim + "\""});
  palplab::testing::expect_exit2(r, parts);
  EXPECT_EQ(slurp(victim), before) << victim << " was changed";
}

}  // namespace

TEST(CliMeshOutput, RepairNeverReplacesItsInputOrAForeignFile) {
  ASSERT_EQ(run("mesh generate sphere --vertices 162 --out " + p("rp.obj")).code, 0);
  const std::string in = p("rp.obj");
  // In place, under three spellings (the path, another spelling, a symlink): refused.
  fs::create_symlink(in, p("rp_link.obj"));
  const std::string dotted = (fs::path(in).parent_path() / "." / "rp.obj").string();
  for (const std::string& out : {in, dotted, p("rp_link.obj")})
    for (const char* overwrite : {"", " --overwrite"})
      expect_refused("mesh repair " + in + " --out " + out + overwrite, out,
                     {"is the input mesh this command reads", "choose another --out"});
  // Files of another kind at the output path: refused without --overwrite.
  const std::string db = make_database("rp_db.obj");
  expect_refused("mesh repair " + in + " --out " + db, db,
                 {"exists and is an SQLite database", "not a mesh file (OBJ)", "--overwrite"});
  EXPECT_EQ(palplab::testing::sql_int(db, "SELECT x FROM kept"), 42);
  const std::string study = make_study("rp_study.stl");
  expect_refused("mesh repair " + in + " --out " + study + " --json", study,
                 {"exists and is a JSON file", "not a mesh file (STL)", "--overwrite"});
  const std::string png = make_png("rp_png.ply");
  expect_refused("mesh repair " + in + " --out " + png, png,
                 {"not a mesh file (PLY)", "give --overwrite to replace it"});
  // The command's own earlier output (and a mesh file of that format) is replaced silently.
  ASSERT_EQ(run("mesh repair " + in + " --out " + p("rp_fixed.stl")).code, 0);
  ASSERT_EQ(run("mesh repair " + in + " --out " + p("rp_fixed.stl") + " --max-hole-edges 0").code,
            0);
  EXPECT_EQ(run("mesh check " + p("rp_fixed.stl")).code, 0);
  // --overwrite replaces a foreign file with the repaired mesh.
  const Result r = run("mesh repair " + in + " --out " + study + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(run("mesh check " + study).code, 0);
}

TEST(CliMeshOutput, TetrahedralizeNeverReplacesAnInputOrAForeignFile) {
  ASSERT_EQ(run("mesh generate sphere --vertices 162 --out " + p("tq.vtu")).code, 0);
  ASSERT_EQ(run("mesh generate sphere --vertices 162 --out " + p("tq.obj")).code, 0);
  // The input surface as the VTU output (BASE.vtu or --vtu's BASE.vtu): refused.
  for (const std::string& args :
       {"mesh tetrahedralize " + p("tq.vtu") + " --out " + p("tq.vtu"),
        "mesh tetrahedralize " + p("tq.vtu") + " --out " + p("tq") + " --vtu --overwrite"})
    expect_refused(args, p("tq.vtu"), {"is the input surface this command reads"});
  // A region seed file where BASE.names would go.
  write_bytes(p("tqr.names"), "1\n1 0 0 0 101 0\n");
  expect_refused(
      "mesh tetrahedralize " + p("tq.obj") + " --regions " + p("tqr.names") + " --out " + p("tqr"),
      p("tqr.names"), {"is the region seed file this command reads"});
  // A database at BASE.node, a study at BASE.ele, an image at BASE.names (a stale .names is
  // removed when the mesh has no regions): refused, and no file of the set is written.
  const std::string db = make_database("tqf.node");
  expect_refused(
      "mesh tetrahedralize " + p("tq.obj") + " --out " + p("tqf"), db,
      {"exists and is an SQLite database", "not a TetGen mesh file (.node)", "--overwrite"});
  EXPECT_EQ(palplab::testing::sql_int(db, "SELECT x FROM kept"), 42);
  const std::string study = make_study("tqs.ele");
  expect_refused("mesh tetrahedralize " + p("tq.obj") + " --out " + p("tqs.node"), study,
                 {"exists and is a JSON file", "not a TetGen mesh file (.ele)"});
  EXPECT_FALSE(fs::exists(p("tqs.node")));
  const std::string png = make_png("tqp.names");
  expect_refused("mesh tetrahedralize " + p("tq.obj") + " --out " + p("tqp"), png,
                 {"not a TetGen mesh file (.names)"});
  EXPECT_FALSE(fs::exists(p("tqp.node")));
  // The command's own earlier output set is replaced without --overwrite.
  ASSERT_EQ(run("mesh tetrahedralize " + p("tq.obj") + " --out " + p("tqo") + " --vtu").code, 0);
  const Result again =
      run("mesh tetrahedralize " + p("tq.obj") + " --out " + p("tqo") + " --vtu --quality 1.5");
  ASSERT_EQ(again.code, 0) << again.err;
  // --overwrite replaces the foreign files.
  const Result r =
      run("mesh tetrahedralize " + p("tq.obj") + " --out " + p("tqf") + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(run("mesh check " + p("tqf.node")).code, 0);
}

TEST(CliMeshOutput, GenerateAndMaterialsNeverReplaceAForeignFile) {
  // A surface, a model-c TetGen set, the shoulder's .regions: each refused without --overwrite.
  const std::string study = make_study("gs.obj");
  expect_refused("mesh generate sphere --vertices 162 --out " + study, study,
                 {"exists and is a JSON file", "not a mesh file (OBJ)", "--overwrite"});
  const std::string db = make_database("gmc.ele");
  expect_refused("mesh generate model-c --vertices 750 --out " + p("gmc"), db,
                 {"exists and is an SQLite database", "not a TetGen mesh file (.ele)"});
  EXPECT_FALSE(fs::exists(p("gmc.node")));
  const std::string png = make_png("gsh.regions");
  expect_refused("mesh generate shoulder --vertices 162 --out " + p("gsh"), png,
                 {"not a region seed file (.regions)"});
  EXPECT_FALSE(fs::exists(p("gsh.obj")));
  const std::string table_victim = make_study("gm.json");
  expect_refused("mesh materials --out " + table_victim, table_victim,
                 {"exists and is a JSON file", "not a material table JSON", "--overwrite"});
  // Own earlier outputs: replaced silently.
  ASSERT_EQ(run("mesh generate sphere --vertices 162 --out " + p("gown.obj")).code, 0);
  EXPECT_EQ(run("mesh generate model-a --out " + p("gown.obj")).code, 0);
  ASSERT_EQ(run("mesh generate shoulder --vertices 162 --out " + p("gown_sh")).code, 0);
  EXPECT_EQ(run("mesh generate shoulder --vertices 162 --out " + p("gown_sh")).code, 0);
  ASSERT_EQ(run("mesh materials --out " + p("gown.json")).code, 0);
  EXPECT_EQ(run("mesh materials --out " + p("gown.json")).code, 0);
  // --overwrite replaces foreign files.
  Result r = run("mesh generate sphere --vertices 162 --out " + study + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(run("mesh check " + study).code, 0);
  r = run("mesh generate shoulder --vertices 162 --out " + p("gsh") + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(slurp(p("gsh.regions")), slurp(p("gown_sh.regions")));
  r = run("mesh materials --out " + table_victim + " --overwrite");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(run("mesh materials --check " + table_victim).code, 0);
  // --overwrite without a file to write would be ignored: an input error.
  palplab::testing::expect_exit2(run("mesh materials --overwrite"), {"--overwrite: applies only"});
}

// An OBJ face with index 0 (a 0-based exporter) and a TetGen .ele numbered from 0 beside a
// .node numbered from 1 said only "out of range" (review 2026-12-07): the numbering is named.
TEST(CliMesh, IndexNumberingMistakesAreNamed) {
  std::ofstream(p("zero.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 0 2 1\n";
  Result r = run("mesh info " + p("zero.obj"));
  palplab::testing::expect_exit2(
      r, {"vertex index 0 out of range (4 vertices defined so far; OBJ indices start at 1, or "
          "count back from -1)"});
  std::ofstream(p("mix.node")) << "4 3 0 0\n1 0 0 0\n2 0.02 0 0\n3 0 0.02 0\n4 0 0 0.02\n";
  std::ofstream(p("mix.ele")) << "1 4 0\n0 0 1 2 3\n";
  r = run("mesh info " + p("mix.ele"));
  palplab::testing::expect_exit2(
      r, {"node index 0 out of range: the .node file numbers its 4 nodes from 1 (1 to 4), and "
          "the .ele must use the same numbering"});
}

// Two seeds of different tissues in one closed region: TetGen gave the whole region one of
// them and the other tissue vanished, exit 0 (1774 tets of 101, 1 of 102; review 2026-12-07).
TEST(CliMesh, TwoSeedsInOneClosedRegionAreRefused) {
  ASSERT_EQ(run("mesh generate sphere --out " + p("two.stl")).code, 0);
  std::ofstream(p("two.regions")) << "2\n1 0 0 0 101 0\n2 0.001 0 0 102 0\n";
  const Result r = run("mesh tetrahedralize " + p("two.stl") + " --out " + p("two_t") +
                       " --regions " + p("two.regions"));
  palplab::testing::expect_exit2(
      r, {p("two.regions") + ":3: the region seeds of line 2 (region_id 101) and line 3 "
                             "(region_id 102) lie in one closed region"});
  std::ofstream(p("one.regions")) << "1\n1 0.001 0 0 102 0\n";
  EXPECT_EQ(run("mesh tetrahedralize " + p("two.stl") + " --out " + p("one_t") + " --regions " +
                p("one.regions"))
                .code,
            0);
}
