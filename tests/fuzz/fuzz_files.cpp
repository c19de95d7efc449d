// Fuzz entries of the study, prototype and CSV readers.
#include "analysis/csv.hpp"
#include "common/input_error.hpp"
#include "protocols/plan.hpp"
#include "protocols/study.hpp"
#include "prototypes/factory.hpp"
#include "tests/fuzz/fuzz_entries.hpp"
#include "tests/fuzz/fuzz_util.hpp"

namespace palplab::fuzz {

using namespace detail;

void study(const std::uint8_t* d, std::size_t n) {
  // Stand-ins for the prototype ids the seeds use, so that resolution succeeds and the fuzzer
  // reaches the plan (they are not inspected: prototype files have their own target).
  static const bool stubs = [] {
    for (const char* id : {"A", "B", "C", "C1", "C2"}) write(std::string(id) + ".json", "{}");
    return true;
  }();
  (void)stubs;
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

}  // namespace palplab::fuzz
