#pragma once
// One entry function per parser, shared by the libFuzzer targets (fuzz_main.cc, built with
// -DPALPLAB_FUZZ=ON and clang) and the corpus regression test (test_fuzz_corpus.cpp, run by
// `make test` with any compiler). An entry parses the bytes as its file kind and then uses what
// it got (validation, mesh checks, number parsing), exactly as the command line would.
//
// Contract: bad input may only end in palplab::InputError (caught here, returns normally).
// Anything else — a crash, a sanitizer report, another exception, a hang — is a bug.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace palplab::fuzz {

using Entry = void (*)(const std::uint8_t* data, std::size_t size);

struct Target {
  const char* name;  // the corpus directory name: tests/fuzz/corpus/<name>/
  Entry entry;
};

// The entries (fuzz_files.cpp: study, prototype, csv; fuzz_mesh.cpp: the mesh formats). The
// TetGen input is BASE.node text, a line "===", BASE.ele text (optionally "===" and .names).
void study(const std::uint8_t* data, std::size_t size);
void prototype(const std::uint8_t* data, std::size_t size);
void csv(const std::uint8_t* data, std::size_t size);
void obj(const std::uint8_t* data, std::size_t size);
void stl(const std::uint8_t* data, std::size_t size);
void off(const std::uint8_t* data, std::size_t size);
void ply(const std::uint8_t* data, std::size_t size);
void vtu(const std::uint8_t* data, std::size_t size);
void tetgen(const std::uint8_t* data, std::size_t size);

// All of them by corpus name (fuzz_entries.cpp; for the regression test).
const std::vector<Target>& targets();

}  // namespace palplab::fuzz
