// Fuzz entries of the mesh readers (link palplab_mesh only, so these targets build fast).
#include "common/input_error.hpp"
#include "engine/mesh/check.hpp"
#include "engine/mesh/io.hpp"
#include "tests/fuzz/fuzz_entries.hpp"
#include "tests/fuzz/fuzz_util.hpp"

namespace palplab::fuzz {

using namespace detail;

static void read_and_check(const std::string& path) {
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

static void mesh(const char* ext, const std::uint8_t* d, std::size_t n) {
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

}  // namespace palplab::fuzz
