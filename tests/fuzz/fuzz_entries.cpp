#include "tests/fuzz/fuzz_entries.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string_view>

#include "analysis/csv.hpp"
#include "common/input_error.hpp"
#include "engine/mesh/check.hpp"
#include "engine/mesh/io.hpp"
#include "protocols/plan.hpp"
#include "protocols/study.hpp"
#include "prototypes/factory.hpp"

namespace palplab::fuzz {

namespace fs = std::filesystem;

namespace {

// A private scratch directory per process (the mesh and prototype readers take paths).
const fs::path& scratch() {
  static const fs::path d = [] {
    fs::path base = fs::exists("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
    fs::path p = base / ("palplab_fuzz_" + std::to_string(::getpid()));
    fs::create_directories(p);
    return p;
  }();
  return d;
}

std::string write(const std::string& name, std::string_view bytes) {
  const fs::path p = scratch() / name;
  std::ofstream(p, std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size());
  return p.string();
}

std::string_view view(const std::uint8_t* d, std::size_t n) {
  return {reinterpret_cast<const char*>(d), n};
}

template <class F>
void expect_input_errors_only(F&& f) {
  try {
    f();
  } catch (const palplab::InputError&) {
    // the one allowed failure: a located message and exit 2 on the command line
  }
}

void study(const std::uint8_t* d, std::size_t n) {
  expect_input_errors_only([&] {
    // No prototype inspection (prototype files have their own target); plan building is part
    // of `validate`, so it runs too.
    const protocols::Study s =
        protocols::parse_study(std::string(view(d, n)), (scratch() / "study.json").string(), {});
    (void)protocols::make_plan(s);
  });
}

void prototype(const std::uint8_t* d, std::size_t n) {
  expect_input_errors_only(
      [&] { (void)prototypes::inspect_prototype(write("p.json", view(d, n))); });
}

void read_and_check(const std::string& path) {
  expect_input_errors_only([&] {
    const mesh::AnyMesh a = mesh::read_mesh(path);
    mesh::CheckOptions o;
    o.max_per_kind = 16;
    if (a.is_tet)
      (void)mesh::check_tets(a.tet, o);
    else
      (void)mesh::check_surface(a.surface, o);
  });
}

void mesh(const char* ext, const std::uint8_t* d, std::size_t n) {
  read_and_check(write(std::string("m") + ext, view(d, n)));
}

void obj(const std::uint8_t* d, std::size_t n) {
  mesh(".obj", d, n);
}
void stl(const std::uint8_t* d, std::size_t n) {
  mesh(".stl", d, n);
}
void off(const std::uint8_t* d, std::size_t n) {
  mesh(".off", d, n);
}
void ply(const std::uint8_t* d, std::size_t n) {
  mesh(".ply", d, n);
}
void vtu(const std::uint8_t* d, std::size_t n) {
  mesh(".vtu", d, n);
}

// TetGen: the input is BASE.node, then a line "===", then BASE.ele (and optionally "===" and
// BASE.names).
void tetgen(const std::uint8_t* d, std::size_t n) {
  std::string_view all = view(d, n);
  std::string_view parts[3];
  int k = 0;
  while (k < 2) {
    const auto cut = all.find("\n===\n");
    if (cut == std::string_view::npos) break;
    parts[k++] = all.substr(0, cut);
    all.remove_prefix(cut + 5);
  }
  parts[k] = all;
  fs::remove(scratch() / "t.names");
  write("t.node", parts[0]);
  write("t.ele", parts[1]);
  if (k == 2) write("t.names", parts[2]);
  read_and_check((scratch() / "t.node").string());
}

void csv(const std::uint8_t* d, std::size_t n) {
  expect_input_errors_only([&] {
    const analysis::CsvTable t = analysis::parse_csv(view(d, n), "fuzz.csv");
    for (int r = 0; r < static_cast<int>(t.rows.size()) && r < 64; ++r)
      for (int c = 0; c < static_cast<int>(t.header.size()); ++c)
        expect_input_errors_only([&] { (void)analysis::parse_number(t, r, c); });
    if (!t.header.empty())
      expect_input_errors_only([&] { (void)analysis::column_index(t, "value"); });
  });
}

}  // namespace

const std::vector<Target>& targets() {
  static const std::vector<Target> t = {
      {"study", study}, {"prototype", prototype}, {"obj", obj}, {"stl", stl}, {"off", off},
      {"ply", ply},     {"tetgen", tetgen},       {"vtu", vtu}, {"csv", csv}};
  return t;
}

Entry find_target(const std::string& name) {
  for (const auto& t : targets())
    if (name == t.name) return t.entry;
  return nullptr;
}

}  // namespace palplab::fuzz
