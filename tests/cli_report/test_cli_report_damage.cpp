// `palplab report` and `palplab export` on a damaged or hand-edited database, and into an output
// directory with a file where a directory goes (or the reverse): exit 2 with a message naming
// the file and what is wrong, never "internal error" (exit 3); nothing of the user's is deleted.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "../cli_support.hpp"

namespace fs = std::filesystem;

namespace {
using Result = palplab::testing::CliResult;
using palplab::testing::run_palplab;
using palplab::testing::scratch_dir;
using palplab::testing::slurp;

// One participant per group, three short sessions each: a database in well under a second.
const char* kStudy = R"({"palplab_study": 1, "id": "dmg", "title": "damage", "seed": 7,
  "task": {"feature": "ovary_left", "thresholds": {"*": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}}},
  "groups": [{"id": "G1", "prototype": "A", "size": 1}, {"id": "G2", "prototype": "B", "size": 1}],
  "phases": [
    {"id": "pre", "kind": "pre_training", "session_duration": 2, "start": {"day": 0}},
    {"id": "test", "kind": "post_training", "session_duration": 2,
     "start": {"after_previous": {"minutes": 10}}}]})";

// A fresh, valid database (made once per test process, copied for each test).
fs::path good_db() {
  static const fs::path db = [] {
    const fs::path d = scratch_dir("report_damage_src");
    std::ofstream(d / "s.json") << kStudy;
    Result r = run_palplab(
        "run " + (d / "s.json").string() + " --db " + (d / "r.db").string() + " --quiet --jobs 1",
        d);
    EXPECT_EQ(r.code, 0) << r.err;
    return d / "r.db";
  }();
  return db;
}

fs::path copy_db(const fs::path& dir) {
  fs::copy_file(good_db(), dir / "r.db", fs::copy_options::overwrite_existing);
  return dir / "r.db";
}

void sql(const fs::path& db, const std::string& text) {
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(h, text.c_str(), nullptr, nullptr, &err);
  const std::string m = err ? err : "";
  sqlite3_free(err);
  sqlite3_close(h);
  ASSERT_EQ(rc, SQLITE_OK) << m;
}

bool has(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// Exit 2, not an internal error, and stderr holds every one of `parts`.
void expect_exit2(const Result& r, std::initializer_list<std::string> parts) {
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_FALSE(has(r.err, "internal error")) << r.err;
  for (const auto& p : parts) EXPECT_TRUE(has(r.err, p)) << r.err << "\nmissing: " << p;
}

// `report --no-stills` and `export --samples` of `db` both refuse it, saying `parts`.
void expect_both_refuse(const fs::path& d, const fs::path& db,
                        std::initializer_list<std::string> parts) {
  SCOPED_TRACE(db.string());
  expect_exit2(
      run_palplab("report " + db.string() + " --out " + (d / "rep").string() + " --no-stills", d),
      parts);
  expect_exit2(
      run_palplab("export " + db.string() + " --csv " + (d / "csv").string() + " --samples", d),
      parts);
}

}  // namespace

TEST(CliReportDamage, MissingTableIsNamed) {
  auto d = scratch_dir("dmg_table");
  const fs::path db = copy_db(d);
  sql(db, "DROP TABLE sessions;");
  expect_both_refuse(d, db,
                     {db.string(), "not a complete palplab results database", "\"sessions\""});
}

TEST(CliReportDamage, TruncatedDatabaseIsSaidDamaged) {
  auto d = scratch_dir("dmg_trunc");
  const fs::path db = copy_db(d);
  fs::resize_file(db, fs::file_size(db) / 2);
  expect_both_refuse(d, db, {db.string(), "damaged or truncated database"});
  expect_exit2(run_palplab("report " + db.string() + " --out " + (d / "rep").string(), d),
               {"damaged or truncated"});
}

TEST(CliReportDamage, TextInAMeasureValueNamesSessionAndMeasure) {
  auto d = scratch_dir("dmg_text");
  const fs::path db = copy_db(d);
  sql(db,
      "UPDATE measures SET value = 'abc' WHERE name = 'palpation_force' AND session = "
      "(SELECT MIN(session) FROM sessions);");
  expect_both_refuse(
      d, db, {db.string(), "measure \"palpation_force\"", "'abc' is not a number", "participant"});
}

TEST(CliReportDamage, CorruptSampleBlobNamesItsSession) {
  auto d = scratch_dir("dmg_blob");
  const fs::path db = copy_db(d);
  sql(db, "UPDATE samples SET data = substr(data, 1, 5);");
  expect_both_refuse(d, db, {db.string(), "corrupt sample blob", "participant"});
}

TEST(CliReportDamage, FileWhereTheReportPutsADirectory) {
  auto d = scratch_dir("dmg_out");
  const fs::path db = copy_db(d);
  fs::create_directories(d / "rep");
  std::ofstream(d / "rep" / "figures") << "my notes\n";
  Result r =
      run_palplab("report " + db.string() + " --out " + (d / "rep").string() + " --no-stills", d);
  expect_exit2(r, {(d / "rep" / "figures").string(), "exists and is not a directory"});
  EXPECT_EQ(slurp(d / "rep" / "figures"), "my notes\n");
  // Checked before the work starts (also for stills/ when stills are drawn).
  fs::remove(d / "rep" / "figures");
  std::ofstream(d / "rep" / "stills") << "x";
  r = run_palplab("report " + db.string() + " --out " + (d / "rep").string(), d);
  expect_exit2(r, {(d / "rep" / "stills").string(), "exists and is not a directory"});
  EXPECT_FALSE(fs::exists(d / "rep" / "figures"));
  // A directory where report.md goes: refused, not "written" silently into nothing.
  fs::remove(d / "rep" / "stills");
  fs::create_directories(d / "rep" / "report.md");
  r = run_palplab("report " + db.string() + " --out " + (d / "rep").string() + " --no-stills", d);
  expect_exit2(r, {"report.md", "is a directory"});
  fs::remove(d / "rep" / "report.md");
  r = run_palplab("report " + db.string() + " --out " + (d / "rep").string() + " --no-stills", d);
  EXPECT_EQ(r.code, 0) << r.err;
}

TEST(CliReportDamage, FileWhereTheExportPutsADirectory) {
  auto d = scratch_dir("dmg_csv");
  const fs::path db = copy_db(d);
  std::ofstream(d / "csv") << "my notes\n";
  Result r = run_palplab("export " + db.string() + " --csv " + (d / "csv").string(), d);
  expect_exit2(r, {"--csv", "exists and is not a directory"});
  EXPECT_EQ(slurp(d / "csv"), "my notes\n");
  fs::remove(d / "csv");
  fs::create_directories(d / "csv" / "sessions.csv");
  r = run_palplab("export " + db.string() + " --csv " + (d / "csv").string(), d);
  expect_exit2(r, {"sessions.csv", "is a directory"});
}
