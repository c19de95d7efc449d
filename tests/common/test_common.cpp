#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "common/escape.hpp"
#include "common/format.hpp"
#include "common/input_error.hpp"
#include "common/seed.hpp"

using namespace palplab;

TEST(InputError, FormatsEveryKnownPart) {
  Problem p{{"study.json", 12, 7, -1, "$.groups[1].size"}, "expected an integer >= 1"};
  EXPECT_EQ(p.format(), "study.json:12:7: $.groups[1].size: expected an integer >= 1");
  Problem b{{"tract.stl", 0, 0, 84, ""}, "truncated triangle record"};
  EXPECT_EQ(b.format(), "tract.stl:byte 84: truncated triangle record");
  Problem bare{{}, "no file"};
  EXPECT_EQ(bare.format(), "no file");
}

TEST(InputError, ListsAllProblemsInWhat) {
  InputError e(std::vector<Problem>{{{"a.json", 1, 2}, "x"}, {{"a.json", 3, 4}, "y"}});
  EXPECT_STREQ(e.what(), "a.json:1:2: x\na.json:3:4: y");
  EXPECT_EQ(e.problems().size(), 2u);
}

TEST(Seed, DerivedSeedsAreDistinctAndStable) {
  // Fixed values: stored studies rely on the derivation never changing.
  EXPECT_EQ(splitmix64(0), 0xe220a8397b1dcdafULL);
  std::set<std::uint64_t> seen;
  for (std::uint64_t p = 0; p < 100; ++p)
    for (std::uint64_t s = 0; s < 10; ++s) seen.insert(derive_seed(42, p, s));
  EXPECT_EQ(seen.size(), 1000u);
  EXPECT_EQ(derive_seed(42, 3, 4), derive_seed(derive_seed(42, 3), 4));
  EXPECT_NE(derive_seed(42, "exploration"), derive_seed(42, "perception"));
  EXPECT_NE(derive_seed(1, 2, 3), derive_seed(1, 3, 2));
}

// Text from user files in Markdown (power.md, report.md cells): what could end a cell, open
// markup or an entity, or escape the next character is escaped; what cannot stays as written.
TEST(MarkdownText, EscapesWhatCouldBeMarkupAndNothingElse) {
  EXPECT_EQ(palplab::markdown_text("<script>x</script> | `y`"),
            "\\<script>x\\</script> \\| \\`y\\`");
  EXPECT_EQ(palplab::markdown_text("<!-- c --> <?php <https://x> a\\b"),
            "\\<!-- c --> \\<?php \\<https://x> a\\\\b");
  EXPECT_EQ(palplab::markdown_text("&lt; &#60; &"), "\\&lt; \\&#60; &");
  // p-values, comparisons and the report's own words are unchanged.
  for (const char* kept : {"< .001", "p < 0.05", "A & B", "2 <= 3", "η² [95% CI]", "G1 – G2", "<"})
    EXPECT_EQ(palplab::markdown_text(kept), kept);
}

// Terminal columns of a label (a text table padded by bytes shifted "Ärzte" and "日本" rows;
// review 2026-12-07): one per character, two for wide East Asian ones, none for combining marks.
TEST(DisplayWidth, CountsColumnsNotBytes) {
  using palplab::display_width;
  EXPECT_EQ(display_width("group"), 5u);
  EXPECT_EQ(display_width("\xC3\x84rzte"), 5u);              // Ärzte, precomposed
  EXPECT_EQ(display_width("A\xCC\x88rzte"), 5u);             // Ärzte, A + combining diaeresis
  EXPECT_EQ(display_width("\xE6\x97\xA5\xE6\x9C\xAC"), 4u);  // 日本
  EXPECT_EQ(palplab::printf_width("\xC3\x84rzte", 14), 15);  // 6 bytes, 5 columns
}

// An error of many problems prints the first 100 and the count of the rest (a device-sim script
// of a million bad waypoints printed 117 MB, review 2026-12-07); problems() keeps every one.
TEST(InputError, ManyProblemsArePrintedUpToAHundredWithTheCount) {
  std::vector<palplab::Problem> ps;
  for (int i = 0; i < 150; ++i)
    ps.push_back({palplab::SourceLocation{"s.json", i + 1, 1}, "bad " + std::to_string(i)});
  const palplab::InputError e(ps);
  const std::string w = e.what();
  EXPECT_EQ(e.problems().size(), 150u);
  EXPECT_NE(w.find("bad 99"), std::string::npos);
  EXPECT_EQ(w.find("bad 100"), std::string::npos);
  EXPECT_NE(w.find("... and 50 more problems (the first 100 are shown)"), std::string::npos) << w;
  EXPECT_EQ(std::count(w.begin(), w.end(), '\n'), 100);
}

// The one formatter of values quoted back (calibrate, validate, the store's checks, stats): the
// shortest text that reads back exactly; the fixed form within a tolerance for computed values.
TEST(Format, ShortestTextReadsBackExactly) {
  EXPECT_EQ(format_shortest(0.1), "0.1");
  EXPECT_EQ(format_shortest(0.1 + 0.2), "0.30000000000000004");
  EXPECT_EQ(format_shortest(15.633), "15.633");
  EXPECT_EQ(format_shortest(-2.5), "-2.5");
  EXPECT_EQ(format_shortest(1e300), "1e+300");
  EXPECT_EQ(format_shortest(std::numeric_limits<double>::infinity()), "inf");
  EXPECT_EQ(format_shortest(std::nan("")), "nan");
  for (double x : {0.1, 1.0 / 3.0, 2.5000000001, 6.02214076e23, 5e-324, -1.7976931348623157e308})
    EXPECT_EQ(std::strtod(format_shortest(x).c_str(), nullptr), x) << x;
  EXPECT_EQ(shortest_digits(0.1), 1);
  EXPECT_EQ(shortest_digits(1.0 / 3.0), 16);
  EXPECT_EQ(shortest_digits(0.1 + 0.2), 17);
  EXPECT_EQ(shortest_digits(0.0), 1);
  // 21 steps of 0.5 ms carry round-off: shown as the 0.0105 s meant, not 0.010500000000000001.
  EXPECT_EQ(format_fixed_within(21 * 0.0005), "0.0105");
  EXPECT_EQ(format_fixed_within(60.0), "60");
  EXPECT_EQ(format_fixed_within(2.0 / 3.0, 1e-4), "0.6667");
  EXPECT_EQ(format_fixed_within(-1e300).size(), 302u);  // sign and 301 digits, not cut
}
