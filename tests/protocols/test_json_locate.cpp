// common/json_locate: positions of values and keys, syntax errors, duplicate keys.
#include <gtest/gtest.h>

#include "common/json_locate.hpp"

using namespace palplab;
using namespace palplab::json;

TEST(JsonLocate, OffsetToPosCountsLinesAndCodePoints) {
  std::string t = "ab\ncd\n\xC3\xA9x";  // é is two bytes, one column
  EXPECT_EQ(offset_to_pos(t, 0).line, 1);
  EXPECT_EQ(offset_to_pos(t, 0).column, 1);
  EXPECT_EQ(offset_to_pos(t, 4).line, 2);
  EXPECT_EQ(offset_to_pos(t, 4).column, 2);
  TextPos p = offset_to_pos(t, 8);  // the 'x' after é
  EXPECT_EQ(p.line, 3);
  EXPECT_EQ(p.column, 2);
}

TEST(JsonLocate, PathsAndPointers) {
  EXPECT_EQ(path_key("$", "groups"), "$.groups");
  EXPECT_EQ(path_key("$", "a b"), "$[\"a b\"]");
  EXPECT_EQ(path_index("$.groups", 3), "$.groups[3]");
  EXPECT_EQ(normalize_path("/groups/1/size"), "$.groups[1].size");
  EXPECT_EQ(normalize_path("/a~1b/x~0"), "$[\"a/b\"][\"x~\"]");
  EXPECT_EQ(normalize_path(""), "$");
  EXPECT_EQ(normalize_path("$.x"), "$.x");
}

TEST(JsonLocate, ValueAndKeyPositions) {
  std::string t =
      "{\n"
      "  \"id\": \"s\",\n"
      "  \"groups\": [\n"
      "    {\"name\": \"A\", \"size\": 10},\n"
      "    {\"name\": \"B\", \"size\": -1}\n"
      "  ],\n"
      "  \"odd key\": {\"x\": [1, [2, 3]]}\n"
      "}\n";
  JsonLocator loc(t);
  EXPECT_EQ(loc.value("$").line, 1);
  EXPECT_EQ(loc.value("$").column, 1);
  EXPECT_EQ(loc.value("$.id").line, 2);
  EXPECT_EQ(loc.value("$.id").column, 9);
  EXPECT_EQ(loc.key("$.id").column, 3);
  TextPos s = loc.value("$.groups[1].size");
  EXPECT_EQ(s.line, 5);
  EXPECT_EQ(s.column, 27);
  EXPECT_EQ(loc.key("$.groups[1].size").column, 19);
  // array elements: key position == value position
  EXPECT_EQ(loc.key("$.groups[1]").column, 5);
  EXPECT_EQ(loc.value("$[\"odd key\"].x[1][0]").line, 7);
  EXPECT_EQ(loc.value("$[\"odd key\"].x[1][0]").column, 25);
  EXPECT_EQ(loc.value("/odd key/x/1/1").column, 28);
  EXPECT_TRUE(loc.contains("$.groups[0].name"));
  EXPECT_FALSE(loc.contains("$.groups[2]"));
}

TEST(JsonLocate, MissingPathFallsBackToAncestor) {
  std::string t = "{\"groups\": [{\"name\": \"A\"}]}";
  JsonLocator loc(t);
  TextPos p = loc.value("$.groups[0].size");
  EXPECT_EQ(p.column, 13);  // the object of groups[0]
  EXPECT_EQ(loc.value("$.nothing.deeper").column, 1);
  SourceLocation sl = loc.locate("f.json", "$.groups[0].size");
  EXPECT_EQ(sl.file, "f.json");
  EXPECT_EQ(sl.json_path, "$.groups[0].size");
  EXPECT_EQ(sl.line, 1);
  EXPECT_EQ(sl.column, 13);
}

TEST(JsonLocate, EscapedKeysAndStringsWithBrackets) {
  std::string t = "{\"a\\\"b\": 1, \"s\": \"[{,}]\", \"n\": 2}";
  JsonLocator loc(t);
  EXPECT_TRUE(loc.contains("$[\"a\\\"b\"]"));
  EXPECT_EQ(loc.value("$.n").column, 32);
}

TEST(JsonLocate, SyntaxErrorIsLocated) {
  std::string t = "{\n  \"a\": 1,\n  \"b\": tru\n}";
  try {
    parse_located(t, "x.json");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    ASSERT_EQ(e.problems().size(), 1u);
    const Problem& p = e.problems()[0];
    EXPECT_EQ(p.where.file, "x.json");
    EXPECT_EQ(p.where.line, 3);
    EXPECT_GE(p.where.column, 8);
    EXPECT_LE(p.where.column, 11);
    EXPECT_NE(p.what.find("invalid JSON"), std::string::npos);
    EXPECT_EQ(p.format().rfind("x.json:3:", 0), 0u) << p.format();
  }
}

TEST(JsonLocate, DuplicateKeysAreErrors) {
  std::string t = "{\"a\": 1,\n \"a\": 2}";
  try {
    parse_located(t, "d.json");
    FAIL();
  } catch (const InputError& e) {
    ASSERT_EQ(e.problems().size(), 1u);
    EXPECT_EQ(e.problems()[0].where.line, 2);
    EXPECT_EQ(e.problems()[0].where.column, 2);
    EXPECT_EQ(e.problems()[0].where.json_path, "$.a");
    // Both definitions at their keys (the first was at its value).
    EXPECT_NE(e.problems()[0].what.find("also defined at line 1, column 2)"), std::string::npos)
        << e.problems()[0].what;
  }
  // Deferred: the later value is kept and the repeat is handed back, for the file's validator
  // to report with its other problems.
  std::vector<palplab::Problem> repeated;
  const nlohmann::json j = parse_located(t, "d.json", &repeated);
  EXPECT_EQ(j.at("a"), 2);
  ASSERT_EQ(repeated.size(), 1u);
  EXPECT_EQ(repeated[0].format(),
            "d.json:2:2: $.a: duplicate key (also defined at line 1, column 2); each key may "
            "appear once");
}

TEST(JsonLocate, MissingFileIsInputError) {
  EXPECT_THROW(parse_file_located("/nonexistent/zzz.json"), InputError);
}
