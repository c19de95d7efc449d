// The one JSON validator (common/json_check.hpp) and the hardened parser (json_locate).
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <utility>

#include "common/escape.hpp"
#include "common/json_check.hpp"
#include "common/read_file.hpp"

using namespace palplab;
using Json = nlohmann::json;
namespace pj = palplab::json;
using palplab::json::Checker;

namespace {

// The problems a check function finds on `text` (parsed with the hardened parser).
template <class F>
std::vector<Problem> problems(const std::string& text, F&& f) {
  const Json j = pj::parse_located(text, "t.json");
  Checker c("t.json", text);
  f(c, j);
  return c.problems();
}

std::string located_error(const std::string& text) {
  try {
    pj::parse_located(text, "t.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(JsonCheck, IntegersOutsideTheirRangeNeverWrap) {
  for (const char* v : {"4294967296", "18446744073709551615", "18446744073709551616",
                        "-9223372036854775808", "1e3", "3.0", "-1"}) {
    auto ps = problems(std::string("{\"n\": ") + v + "}", [](Checker& c, const Json& j) {
      EXPECT_FALSE(c.integer(j, "$", "n", true, 1, 100000, "a group size").has_value());
    });
    ASSERT_EQ(ps.size(), 1u) << v;
    EXPECT_EQ(ps[0].where.json_path, "$.n");
    EXPECT_EQ(ps[0].where.line, 1);
    EXPECT_EQ(ps[0].where.column, 7);
    EXPECT_NE(ps[0].what.find("a group size in [1, 100000]"), std::string::npos) << ps[0].what;
  }
  auto ok = problems("{\"n\": 100000}", [](Checker& c, const Json& j) {
    EXPECT_EQ(c.integer(j, "$", "n", true, 1, 100000, "a group size"), 100000);
  });
  EXPECT_TRUE(ok.empty());
}

// Review finding: a seed of 2^64 (the parser keeps it as a double) said "got a number".
TEST(JsonCheck, AWholeNumberBeyondSixtyFourBitsIsOutOfRangeAsWritten) {
  const std::pair<const char*, const char*> cases[] = {
      {"18446744073709551616", "got 18446744073709551616, out of range [0, 18446744073709551615]"},
      {"1e30", "got 1e30, out of range [0, 18446744073709551615]"},
      {"1.5e3", "got 1.5e3 (write an integer as digits only)"},
      {"2.5", "got a number with a fraction, 2.5"},
      {"-1", "got a negative integer"},
      {"\"7\"", "got a string"}};
  for (const auto& [v, expected] : cases) {
    auto ps = problems(std::string("{\"seed\": ") + v + "}", [](Checker& c, const Json& j) {
      EXPECT_FALSE(c.uint64(j, "$", "seed", true, "an integer >= 0").has_value());
    });
    ASSERT_EQ(ps.size(), 1u) << v;
    EXPECT_EQ(ps[0].where.column, 10);
    EXPECT_NE(ps[0].what.find(expected), std::string::npos) << ps[0].what;
  }
  auto ps = problems("{\"t\": -9223372036854775809}", [](Checker& c, const Json& j) {
    EXPECT_FALSE(c.integer(j, "$", "t", true, "an integer").has_value());
  });
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_NE(ps[0].what.find("got -9223372036854775809, out of range "
                            "[-9223372036854775808, 9223372036854775807]"),
            std::string::npos)
      << ps[0].what;
  auto ok = problems("{\"seed\": 18446744073709551615}", [](Checker& c, const Json& j) {
    EXPECT_EQ(c.uint64(j, "$", "seed", true, "an integer >= 0"), 18446744073709551615ull);
  });
  EXPECT_TRUE(ok.empty());
}

// Review finding: `validate /dev/zero` read until memory ran out (std::bad_alloc, exit 3).
// Every whole-file read of an input is bounded, and checked while reading.
TEST(ReadFile, EndlessAndOversizedInputsStopAtTheLimit) {
  auto message = [](const std::string& path, std::size_t limit) {
    try {
      read_file_bounded(path, limit, "JSON file");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message("/dev/zero", 1u << 20)
                .find("/dev/zero: more than the 1 MiB accepted for "
                      "JSON file"),
            std::string::npos);
  const std::string dir = ::testing::TempDir();
  const std::string big = dir + "/palplab_read_file_big.json";
  { std::ofstream(big) << std::string(5000, ' ') << "{}"; }
  EXPECT_NE(message(big, 4096).find("is 5002 bytes, more than the 4096 bytes accepted"),
            std::string::npos)
      << message(big, 4096);
  EXPECT_EQ(read_file_bounded(big, 5002, "JSON file").size(), 5002u);  // at the limit: read
  EXPECT_NE(message(dir, 4096).find("is a directory, expected a JSON file"), std::string::npos);
  EXPECT_NE(message(dir + "/no_such_file.json", 4096).find("cannot open file"), std::string::npos);
  std::remove(big.c_str());
}

TEST(JsonCheck, NumbersAreFiniteAndInRange) {
  auto ps = problems("{\"x\": -1e200, \"y\": \"1\"}", [](Checker& c, const Json& j) {
    EXPECT_FALSE(c.number(j, "$", "x", true, -10, 10, "a position (m)"));
    EXPECT_FALSE(c.number(j, "$", "y", true, -10, 10, "a position (m)"));
    EXPECT_FALSE(c.number(j, "$", "z", true, -10, 10, "a position (m)"));
  });
  ASSERT_EQ(ps.size(), 3u);
  EXPECT_EQ(
      ps[0].format(),
      "t.json:1:7: $.x: value -1e+200 out of range: expected a position (m) in [-10.0, 10.0]");
  EXPECT_EQ(ps[1].format(), "t.json:1:20: $.y: expected a number: a position (m), got a string");
  EXPECT_EQ(ps[2].format(), "t.json:1:1: $: missing required key \"z\" (a position (m))");
  auto v = problems("{\"p\": [1, 2, 1e9]}", [](Checker& c, const Json& j) {
    EXPECT_FALSE(c.vec3(j, "$", "p", true, -10, 10, "the start (m)"));
  });
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v[0].where.json_path, "$.p[2]");
}

TEST(JsonCheck, UnknownKeysAreErrorsAtTheKeyWithAHint) {
  auto ps = problems("{\n  \"sede\": 1}", [](Checker& c, const Json& j) {
    c.keys(j, "$", {"seed", "id"});
  });
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].format(),
            "t.json:2:3: $.sede: unknown key \"sede\" (did you mean \"seed\"?); expected one of: "
            "seed, id");
}

TEST(JsonParse, HostileTextIsALocatedError) {
  EXPECT_EQ(located_error(std::string(100, '[') + std::string(100, ']')),
            "t.json:1:65: invalid JSON: nested deeper than 64 levels (palplab files need a few)");
  EXPECT_EQ(located_error(std::string(64, '[') + std::string(64, ']')), "");
  EXPECT_NE(located_error("{\"a\":\n [1e400]}").find("t.json:2:3: number 1e400 is out of range"),
            std::string::npos);
  EXPECT_NE(located_error("{\"a\": -1e999}").find("t.json:1:7:"), std::string::npos);
  EXPECT_EQ(located_error("{\"a\": \"1e400 [[[[\"}"), "");  // inside a string: just text
  // A nonzero number below the smallest double was read as 0 and said "got 0.0" by the
  // checks (review 2026-12-06, eighth): refused at its place; subnormals and zeros are numbers.
  EXPECT_EQ(located_error("{\"a\":\n  1e-400}"),
            "t.json:2:3: number 1e-400 underflows to 0 (a nonzero JSON number must fit a double, "
            "|x| >= 4.9e-324): write 0, or the value in other units");
  EXPECT_NE(located_error("{\"a\": -2.5E-999}").find("t.json:1:7: number -2.5E-999 underflows"),
            std::string::npos);
  EXPECT_EQ(located_error("{\"a\": [1e-310, 0e-400, 0.000e-999, -0.0]}"), "");
  // Review finding (2026-12-06): the parser took a NUL byte for the end of the input, so what
  // followed was ignored (garbage after a document accepted, keys after it "missing").
  const std::string nul = "{\"a\": 1,\n \"b\": [2]}" + std::string(1, '\0') + "{garbage";
  EXPECT_EQ(located_error(nul),
            "t.json:2:11: invalid JSON: a NUL byte (JSON text has none: a binary file, or text "
            "damaged by a NUL)");
  EXPECT_EQ(located_error("{\"a\": " + std::string(1, '\0') + "1}").substr(0, 12), "t.json:1:7: ");
  // UTF-16 (with or without its byte-order mark, either byte order) is said as such (review
  // 2026-12-06, second: "a NUL byte" at 1:4 left the researcher guessing).
  const std::string utf16 =
      "t.json:1:1: invalid JSON: the file is UTF-16 text (expected UTF-8: save it as UTF-8)";
  EXPECT_EQ(located_error(std::string("\xff\xfe{\0}\0", 6)), utf16);
  EXPECT_EQ(located_error(std::string("\xfe\xff\0{\0}", 6)), utf16);
  EXPECT_EQ(located_error(std::string("{\0\n\0}\0", 6)), utf16);
  EXPECT_EQ(located_error(std::string("\0{\0\n\0}", 6)), utf16);
  // UTF-32 was called UTF-16 (review 2026-12-06, second).
  const std::string utf32 =
      "t.json:1:1: invalid JSON: the file is UTF-32 text (expected UTF-8: save it as UTF-8)";
  EXPECT_EQ(located_error(std::string("\xff\xfe\0\0{\0\0\0}\0\0\0", 12)), utf32);
  EXPECT_EQ(located_error(std::string("\0\0\xfe\xff\0\0\0{\0\0\0}", 12)), utf32);
  EXPECT_EQ(located_error(std::string("{\0\0\0}\0\0\0", 8)), utf32);
  EXPECT_EQ(located_error(std::string("\0\0\0{\0\0\0}", 8)), utf32);
  // A repeated key is reported once, not again at every value under its second copy (a
  // device-sim script's repeated "waypoints" was reported at $.waypoints[0][0] ...; review
  // 2026-12-06, fourth); a key repeated inside the first copy is reported too (it was hidden by
  // that filter: fifth).
  const std::string dups =
      located_error("{\"a\": {\"b\": 1, \"b\": 2, \"c\": [1]},\n \"a\": {\"b\": 3, \"c\": [2]}}");
  EXPECT_NE(dups.find("t.json:1:16: $.a.b: duplicate key"), std::string::npos) << dups;
  EXPECT_NE(dups.find("t.json:2:2: $.a: duplicate key"), std::string::npos) << dups;
  EXPECT_EQ(dups.find("$.a.c"), std::string::npos) << dups;
  EXPECT_EQ(std::count(dups.begin(), dups.end(), '\n'), 1) << dups;  // two lines
  // A key repeated inside the kept (later) copy is reported too (review 2026-12-06, seventh);
  // three copies: each repeat names the one before it.
  const std::string kept = located_error("{\"a\": {\"b\": 1},\n \"a\": {\"b\": 2, \"b\": 3}}");
  EXPECT_NE(kept.find("t.json:2:16: $.a.b: duplicate key (also defined at line 2, column 8)"),
            std::string::npos)
      << kept;
  EXPECT_NE(kept.find("t.json:2:2: $.a: duplicate key"), std::string::npos) << kept;
  EXPECT_EQ(std::count(kept.begin(), kept.end(), '\n'), 1) << kept;
  const std::string three = located_error("{\"x\": 1,\n \"x\": 2,\n \"x\": 3}");
  EXPECT_NE(three.find("t.json:2:2: $.x: duplicate key (also defined at line 1, column 2)"),
            std::string::npos)
      << three;
  EXPECT_NE(three.find("t.json:3:2: $.x: duplicate key (also defined at line 2, column 2)"),
            std::string::npos)
      << three;
  // palplab's own binary files where JSON goes are named (review 2026-12-06, fourth: `probe
  // A.psim` said "a NUL byte").
  EXPECT_EQ(located_error(std::string("PALPSIM\0\1\0\0\0", 12)),
            "t.json:1:1: not JSON: the file is a palplab scene file (.psim): give it with "
            "--scene, and the prototype's JSON file or id where a prototype goes");
  EXPECT_EQ(located_error(std::string("SQLite format 3\0\x10\0", 18)),
            "t.json:1:1: not JSON: the file is an SQLite database (a results database?), not a "
            "JSON file");
}

TEST(Escape, Utf8IsToldFromOtherBytes) {
  EXPECT_TRUE(palplab::is_valid_utf8(""));
  EXPECT_TRUE(palplab::is_valid_utf8("ovary_left"));
  EXPECT_TRUE(palplab::is_valid_utf8("ov\xc3\xa1rio \xe2\x82\xac \xf0\x9f\x99\x82"));
  EXPECT_FALSE(palplab::is_valid_utf8("m\xe9"));             // Latin-1
  EXPECT_FALSE(palplab::is_valid_utf8("\xc3"));              // cut short
  EXPECT_FALSE(palplab::is_valid_utf8("\xc0\xaf"));          // overlong '/'
  EXPECT_FALSE(palplab::is_valid_utf8("\xed\xa0\x80"));      // a surrogate
  EXPECT_FALSE(palplab::is_valid_utf8("\xf4\x90\x80\x80"));  // above U+10FFFF
  EXPECT_FALSE(palplab::is_valid_utf8("\xe2\x82"));          // cut short
}

TEST(Escape, ControlCharactersAreShownEscaped) {
  EXPECT_EQ(escape_controls("G\x1b[31mred\x07\n"), "G\\x1b[31mred\\x07\n");
  EXPECT_EQ(escape_controls("a\nb", false), "a\\x0ab");
  EXPECT_EQ(escape_controls("\xc2\x9b"
                            "2J ovary \xc3\xa9"),
            "\\u009b2J ovary \xc3\xa9");
  Problem p{{"s\x1b.json", 1, 1, -1, "$.id"}, "bad \x1b]0;title\x07"};
  EXPECT_EQ(p.format(), "s\\x1b.json:1:1: $.id: bad \\x1b]0;title\\x07");
  // Bytes of no UTF-8 character (a binary file's, Latin-1 text) are escaped too: a binary .ele's
  // first line went to the terminal raw (review 2026-12-07); characters around them pass.
  EXPECT_EQ(escape_controls("a\xff\xfe b \xe9t\xc3\xa9 \xe2\x82 \xf0\x9f\x98\x80"),
            "a\\xff\\xfe b \\xe9t\xc3\xa9 \\xe2\\x82 \xf0\x9f\x98\x80");
  EXPECT_EQ(escape_controls("\xed\xa0\x80"), "\\xed\\xa0\\x80");  // a surrogate
}

// A UTF-8 byte order mark (Windows Notepad saves one) hid every duplicate key and put every
// location at 1:1 (review 2026-12-07): the mark is skipped and is no column.
TEST(JsonCheck, AByteOrderMarkIsNoCharacter) {
  const std::string bom = "\xEF\xBB\xBF";
  const std::string e = located_error(bom + "{\"seed\": 4242,\n  \"seed\": 5}");
  EXPECT_NE(e.find("t.json:2:3"), std::string::npos) << e;
  EXPECT_NE(e.find("seed"), std::string::npos) << e;
  auto ps = problems(bom + "{\"seed\": 18446744073709551616}", [](Checker& c, const Json& j) {
    c.uint64(j, "$", "seed", true, "an integer >= 0");
  });
  ASSERT_EQ(ps.size(), 1u);
  EXPECT_EQ(ps[0].where.line, 1);
  EXPECT_EQ(ps[0].where.column, 10);  // as without the mark
  EXPECT_NE(ps[0].what.find("18446744073709551616"), std::string::npos) << ps[0].what;
  EXPECT_EQ(located_error(bom + "{\"a\": tru}"), located_error("{\"a\": tru}"));
}
