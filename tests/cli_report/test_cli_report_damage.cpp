// `palplab report` and `palplab export` on a damaged or hand-edited database, and into an output
// directory with a file where a directory goes (or the reverse): exit 2 with a message naming
// the file and what is wrong, never "internal error" (exit 3); nothing of the user's is deleted.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "../cli_support.hpp"
#include "../sqlite_support.hpp"

namespace fs = std::filesystem;

namespace {
using Result = palplab::testing::CliResult;
using palplab::testing::run_palplab;
using palplab::testing::scratch_dir;
using palplab::testing::slurp;

const std::string kStudy = palplab::testing::tiny_study_json("dmg", 7);

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

using palplab::testing::sql_exec;

using palplab::testing::expect_exit2;
using palplab::testing::has;

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
  sql_exec(db, "DROP TABLE sessions;");
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
  sql_exec(db,
           "UPDATE measures SET value = 'abc' WHERE name = 'palpation_force' AND session = "
           "(SELECT MIN(session) FROM sessions);");
  expect_both_refuse(
      d, db, {db.string(), "measure \"palpation_force\"", "'abc' is not a number", "participant"});
}

// Numbers a hand edit left in events and sessions rows (±inf, text): refused naming the table,
// row and column, where the export wrote `contact_end,inf` and read text as 0.
TEST(CliReportDamage, HandEditedEventNumbersAreRefusedByExport) {
  auto d = scratch_dir("dmg_events");
  const fs::path db = copy_db(d);
  ASSERT_GT(palplab::testing::sql_int(db, "SELECT COUNT(*) FROM events"), 0);
  sql_exec(db, "UPDATE events SET value = 9e999;");
  Result r = run_palplab("export " + db.string() + " --csv " + (d / "csv").string(), d);
  expect_exit2(r, {db.string(), "table events, row (session ", "participant",
                   "column value: expected a finite number, got inf"});
  EXPECT_FALSE(fs::exists(d / "csv" / "events.csv"));
  sql_exec(db, "UPDATE events SET value = 1, t = 'abc';");
  r = run_palplab("export " + db.string() + " --csv " + (d / "csv").string(), d);
  expect_exit2(r, {db.string(), "table events", "column t: expected a finite number, got 'abc'"});
  sql_exec(db, "UPDATE events SET t = 0.5;");
  r = run_palplab("export " + db.string() + " --csv " + (d / "csv").string(), d);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(has(slurp(d / "csv" / "events.csv"), "inf"));
}

TEST(CliReportDamage, HandEditedSessionNumbersAreRefused) {
  auto d = scratch_dir("dmg_sessions");
  const fs::path db = copy_db(d);
  sql_exec(db,
           "UPDATE sessions SET loop_median = 9e999 WHERE session = (SELECT MIN(session) "
           "FROM sessions);");
  expect_both_refuse(d, db,
                     {db.string(), "table sessions, row (session ", "participant",
                      "column loop_median: expected a finite number, got inf"});
  sql_exec(db, "UPDATE sessions SET loop_median = 1e-6, wall_duration = 'x';");
  expect_both_refuse(
      d, db,
      {db.string(), "table sessions", "column wall_duration: expected a finite number, got 'x'"});
}

// `export DB1 --samples` then `export DB2` (no --samples) into the same directory: DB1's
// samples.csv is removed, and said on stdout, rather than left beside DB2's files.
TEST(CliReportDamage, ExportWithoutSamplesRemovesAnEarlierSamplesCsv) {
  auto d = scratch_dir("dmg_stale");
  const fs::path db1 = copy_db(d);
  fs::create_directories(d / "two");
  const fs::path db2 = copy_db(d / "two");
  sql_exec(db2, "UPDATE sessions SET wall_duration = 123.5;");
  const fs::path csv = d / "csv";
  Result r = run_palplab("export " + db1.string() + " --csv " + csv.string() + " --samples", d);
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(csv / "samples.csv"));
  EXPECT_FALSE(has(r.out, "removed"));
  r = run_palplab("export " + db2.string() + " --csv " + csv.string(), d);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(has(r.out, "removed " + (csv / "samples.csv").string())) << r.out;
  EXPECT_TRUE(has(r.out, "add --samples")) << r.out;
  EXPECT_FALSE(fs::exists(csv / "samples.csv"));
  EXPECT_TRUE(has(slurp(csv / "sessions.csv"), ",123.5,"));
}

TEST(CliReportDamage, CorruptSampleBlobNamesItsSession) {
  auto d = scratch_dir("dmg_blob");
  const fs::path db = copy_db(d);
  sql_exec(db, "UPDATE samples SET data = substr(data, 1, 5);");
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

// A database that does not exist (or is no palplab database) is refused before any output is
// made: `report` created its --out directory first and then said "no such database".
TEST(CliReportDamage, MissingDatabaseCreatesNoOutput) {
  auto d = scratch_dir("dmg_missing");
  const fs::path missing = d / "MISSING.db";
  Result r =
      run_palplab("report " + missing.string() + " --out " + (d / "rep" / "sub").string(), d);
  expect_exit2(r, {missing.string() + ": no such database"});
  EXPECT_FALSE(fs::exists(d / "rep"));
  r = run_palplab("export " + missing.string() + " --csv " + (d / "csv" / "sub").string(), d);
  expect_exit2(r, {missing.string() + ": no such database"});
  EXPECT_FALSE(fs::exists(d / "csv"));
  EXPECT_FALSE(fs::exists(missing));  // not created by opening it either
  std::ofstream(d / "notes.db") << "my notes\n";
  r = run_palplab("report " + (d / "notes.db").string() + " --out " + (d / "rep").string(), d);
  expect_exit2(r, {(d / "notes.db").string(), "not a palplab results database"});
  EXPECT_FALSE(fs::exists(d / "rep"));
  r = run_palplab("export " + (d / "notes.db").string() + " --csv " + (d / "csv").string(), d);
  expect_exit2(r, {(d / "notes.db").string(), "not a palplab results database"});
  EXPECT_FALSE(fs::exists(d / "csv"));
  EXPECT_EQ(slurp(d / "notes.db"), "my notes\n");
}
