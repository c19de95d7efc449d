// Schema migration: a database written with the previous schema version (2; its DDL is the
// committed fixture tests/results/schema_v2.sql) is read as it is by a reader and migrated in
// place to the current version by a writer, keeping every row; a database of a version this
// build does not know is refused with a clear InputError (exit 2 on the command line).
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/input_error.hpp"
#include "results/store.hpp"

using namespace palplab;
using namespace palplab::results;
namespace fs = std::filesystem;

namespace {

fs::path tmpdir(const std::string& name) {
  auto d = fs::temp_directory_path() / ("palplab_migr_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

void exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK)
      << (err ? err : "") << "\n"
      << sql;
}

std::string scalar(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr);
  sqlite3_stmt* st = nullptr;
  std::string out = "<error>";
  if (sqlite3_prepare_v2(h, sql.c_str(), -1, &st, nullptr) == SQLITE_OK) {
    out = "<none>";
    if (sqlite3_step(st) == SQLITE_ROW) {
      const auto* t = sqlite3_column_text(st, 0);
      out = t ? reinterpret_cast<const char*>(t) : "NULL";
    }
  }
  sqlite3_finalize(st);
  sqlite3_close(h);
  return out;
}

// A version-2 database as palplab 2 wrote it: the old DDL and one complete session of P01
// (session id 7) with two measures and one event.
void write_v2(const fs::path& db) {
  std::ifstream in(std::string(PALPLAB_SOURCE_DIR) + "/tests/results/schema_v2.sql");
  std::stringstream ddl;
  ddl << in.rdbuf();
  ASSERT_NE(ddl.str().find("PRAGMA user_version = 2;"), std::string::npos);
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  exec(h, "BEGIN;" + ddl.str() + "COMMIT;");
  exec(h,
       "INSERT INTO meta VALUES ('schema_version', '2'), ('created_at', '2026-01-05T09:00:00Z');"
       "INSERT INTO study VALUES (1, 'old', 'an old study', '{}', 'abc', '0.2.0', 'deadbeef', "
       "'42', '2026-01-05T09:00:00Z', '2026-01-05T09:01:00Z');"
       "INSERT INTO participants VALUES ('P01', 'A', 0, '1234');"
       "INSERT INTO sessions VALUES (7, 'P01', 0, 'training', 0, 'A', NULL, 0.0, 0, 2.0, 2000, "
       "0.5, 1e-6, 2e-6, '99', '{\"target\": 2.5}', '2026-01-05T09:00:30Z');"
       "INSERT INTO measures VALUES (7, 'palpation_force', 2.4375, 'N'), "
       "(7, 'feature_identified', 1.0, '1');"
       "INSERT INTO events VALUES (7, 1.5, 'contact_start', 0.0, 'ovary_left');");
  sqlite3_close(h);
}

}  // namespace

TEST(Migration, V2IsReadAsItIsAndMigratedByAWriterKeepingEveryRow) {
  const fs::path d = tmpdir("v2");
  const fs::path db = d / "v2.db";
  write_v2(db);
  {
    // A reader (export, stats) does not change the file.
    Store s = Store::open(db.string(), false);
    EXPECT_EQ(s.schema_version(), 2);
    const auto ss = s.read_sessions();
    ASSERT_EQ(ss.size(), 1u);
    EXPECT_EQ(ss[0].session, 7);
    EXPECT_EQ(ss[0].status, "complete");
    EXPECT_EQ(ss[0].trainee, "virtual");
    EXPECT_EQ(ss[0].attempt, 0);
    EXPECT_EQ(s.read_measures().size(), 2u);
  }
  EXPECT_EQ(scalar(db, "PRAGMA user_version"), "2");
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM pragma_table_info('sessions') WHERE name = 'status'"),
            "0");
  {
    // A writer (run --human continuing the database) migrates it in place.
    Store s = Store::open(db.string(), true);
    EXPECT_EQ(s.schema_version(), kSchemaVersion);
    const auto ss = s.read_sessions();
    ASSERT_EQ(ss.size(), 1u);
    EXPECT_EQ(ss[0].session, 7);  // ids kept: measures, events, samples still refer to it
    EXPECT_EQ(ss[0].participant, "P01");
    EXPECT_EQ(ss[0].state_after, "{\"target\": 2.5}");
    EXPECT_EQ(ss[0].status, "complete");
    const auto ms = s.read_measures();
    ASSERT_EQ(ms.size(), 2u);
    EXPECT_EQ(s.read_events(7).size(), 1u);
    // The new key (participant, ordinal, attempt) takes a second attempt of the same ordinal.
    SessionRecord r = ss[0];
    r.attempt = 1;
    r.status = "running";
    r.trainee = "virtual";
    s.begin_session(r);
    EXPECT_EQ(s.read_attempts("P01").size(), 2u);
  }
  EXPECT_EQ(scalar(db, "PRAGMA user_version"), std::to_string(kSchemaVersion));
  EXPECT_EQ(scalar(db, "SELECT value FROM meta WHERE key = 'schema_version'"),
            std::to_string(kSchemaVersion));
  EXPECT_NE(scalar(db, "SELECT value FROM meta WHERE key = 'migrated_to_3_at'"), "<none>");
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM pragma_table_info('sessions') WHERE name IN "
                   "('attempt','status','trainee','device','started_at','abort_reason')"),
            "6");
  EXPECT_NE(scalar(db, "SELECT value FROM meta WHERE key = 'migrated_to_4_at'"), "<none>");
  EXPECT_EQ(scalar(db,
                   "SELECT count(*) FROM pragma_table_info('sessions') WHERE name = "
                   "'transparency'"),
            "1");
  EXPECT_EQ(scalar(db, "SELECT count(*) FROM sessions WHERE transparency IS NULL"), "2");
  EXPECT_EQ(scalar(db, "PRAGMA foreign_key_check"), "<none>");
  fs::remove_all(d);
}

TEST(Migration, AVersionThisBuildDoesNotKnowIsRefusedClearly) {
  const fs::path d = tmpdir("v99");
  const fs::path db = d / "v99.db";
  { Store s = Store::create(db.string()); }
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  exec(h, "UPDATE meta SET value = '99' WHERE key = 'schema_version'; PRAGMA user_version = 99;");
  sqlite3_close(h);
  for (bool writer : {false, true}) {
    try {
      Store::open(db.string(), writer);
      FAIL() << "a version-99 database opened";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("results schema version 99 is not supported (expected "
                                           "1 to " +
                                           std::to_string(kSchemaVersion) + ")"),
                std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(db.string()), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(scalar(db, "PRAGMA user_version"), "99");  // untouched
  fs::remove_all(d);
}
