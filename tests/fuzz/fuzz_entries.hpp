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

// study, prototype, obj, stl, off, ply, tetgen, vtu, csv.
const std::vector<Target>& targets();
Entry find_target(const std::string& name);

}  // namespace palplab::fuzz
