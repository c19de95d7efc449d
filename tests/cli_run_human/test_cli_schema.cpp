// The results schema on the command line: a database written with schema version 2 (the DDL of
// tests/results/schema_v2.sql) is exported as it is (a reader never migrates), and a database of
// a version this build does not know exits 2 with the versions it reads (docs/FORMATS.md).
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <string>

#include "tests/cli_support.hpp"

namespace fs = std::filesystem;

namespace {
void exec(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  char* err = nullptr;
  EXPECT_EQ(sqlite3_exec(h, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(h);
}
}  // namespace

TEST(CliSchema, V2IsExportedAsItIsAndAnUnknownVersionExits2) {
  const fs::path dir = palplab::testing::scratch_dir("cli_schema");
  const fs::path db = dir / "v2.db";
  exec(db,
       palplab::testing::slurp(std::string(PALPLAB_SOURCE_DIR) + "/tests/results/schema_v2.sql"));
  exec(db,
       "INSERT INTO meta VALUES ('schema_version', '2'), ('created_at', '2026-01-05T09:00:00Z');"
       "INSERT INTO study VALUES (1, 'old', 'an old study', '{}', 'abc', '0.2.0', 'deadbeef', "
       "'42', '2026-01-05T09:00:00Z', '2026-01-05T09:01:00Z');"
       "INSERT INTO participants VALUES ('P01', 'A', 0, '1234');"
       "INSERT INTO sessions VALUES (7, 'P01', 0, 'training', 0, 'A', NULL, 0.0, 0, 2.0, 2000, "
       "0.5, 1e-6, 2e-6, '99', '{}', '2026-01-05T09:00:30Z');"
       "INSERT INTO measures VALUES (7, 'palpation_force', 2.4375, 'N');");
  auto r = palplab::testing::run_palplab(
      "export " + db.string() + " --csv " + (dir / "csv").string(), dir);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const std::string measures = palplab::testing::slurp(dir / "csv" / "measures.csv");
  EXPECT_NE(measures.find("2.4375"), std::string::npos) << measures;
  exec(db, "UPDATE meta SET value = '4' WHERE key = 'schema_version'; PRAGMA user_version = 4;");
  r = palplab::testing::run_palplab("export " + db.string() + " --csv " + (dir / "csv4").string(),
                                    dir);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("results schema version 4 is not supported (expected 1 to 3)"),
            std::string::npos)
      << r.err;
  fs::remove_all(dir);
}
