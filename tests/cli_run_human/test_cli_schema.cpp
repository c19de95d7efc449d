// The results schema on the command line: a database written with schema version 2 (the DDL of
// tests/results/schema_v2.sql) is exported as it is (a reader never migrates), and a database of
// a version this build does not know exits 2 with the versions it reads (docs/FORMATS.md); a
// writer (`run --human` continuing a version-2 database of the same study) migrates it in place.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <string>

#include "engine/haptics/devices/trace_device.hpp"
#include "results/sha256.hpp"
#include "tests/cli_support.hpp"
#include "tests/sqlite_support.hpp"

namespace fs = std::filesystem;

namespace {
using palplab::testing::sql_exec;
}  // namespace

TEST(CliSchema, V2IsExportedAsItIsAndAnUnknownVersionExits2) {
  const fs::path dir = palplab::testing::scratch_dir("cli_schema");
  const fs::path db = dir / "v2.db";
  sql_exec(db, palplab::testing::slurp(std::string(PALPLAB_SOURCE_DIR) +
                                       "/tests/results/schema_v2.sql"));
  sql_exec(
      db,
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
  sql_exec(db,
           "UPDATE meta SET value = '99' WHERE key = 'schema_version'; PRAGMA user_version = 99;");
  r = palplab::testing::run_palplab("export " + db.string() + " --csv " + (dir / "csv4").string(),
                                    dir);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("results schema version 99 is not supported (expected 1 to 4)"),
            std::string::npos)
      << r.err;
  fs::remove_all(dir);
}

TEST(CliSchema, RunHumanContinuesAV2DatabaseMigratingIt) {
  const fs::path dir = palplab::testing::scratch_dir("cli_schema_run");
  const fs::path db = dir / "v2.db";
  const std::string study_file =
      std::string(PALPLAB_SOURCE_DIR) + "/tests/cli_run_human/human_study.json";
  const std::string study = palplab::testing::slurp(study_file);
  sql_exec(db, palplab::testing::slurp(std::string(PALPLAB_SOURCE_DIR) +
                                       "/tests/results/schema_v2.sql"));
  // The study as palplab 2 stored it (its exact text and SHA-256) and its two participants.
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(h,
                               "INSERT INTO study VALUES (1, 'human_smoke', 't', ?1, ?2, '0.2.0', "
                               "'deadbeef', '7', '2026-01-05T09:00:00Z', NULL)",
                               -1, &st, nullptr),
            SQLITE_OK);
  sqlite3_bind_text(st, 1, study.c_str(), -1, SQLITE_TRANSIENT);
  const std::string sha = palplab::results::sha256_hex(study);
  sqlite3_bind_text(st, 2, sha.c_str(), -1, SQLITE_TRANSIENT);
  EXPECT_EQ(sqlite3_step(st), SQLITE_DONE);
  sqlite3_finalize(st);
  sqlite3_close(h);
  sql_exec(
      db,
      "INSERT INTO meta VALUES ('schema_version', '2'), ('created_at', '2026-01-05T09:00:00Z');"
      "INSERT INTO participants VALUES ('P01', 'A', 0, '1'), ('P02', 'A', 1, '2');");
  // A device track held 2 mm above the model: 2 s at 1 kHz.
  palplab::engine::Trace tr;
  for (int k = 0; k < 2000; ++k) {
    palplab::engine::TraceSample s;
    s.t = k * 0.001;
    s.in.position = Eigen::Vector3d(0.0, 0.0, 0.5);
    tr.samples.push_back(s);
  }
  palplab::engine::write_trace((dir / "hold.trace").string(), tr);
  const auto r = palplab::testing::run_palplab(
      "run " + study_file + " --db " + db.string() +
          " --human --participant P01 --device trace:" + (dir / "hold.trace").string(),
      dir);
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  h = nullptr;
  ASSERT_EQ(sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  auto one = [&](const std::string& sql) {
    sqlite3_stmt* q = nullptr;
    std::string out = "<none>";
    if (sqlite3_prepare_v2(h, sql.c_str(), -1, &q, nullptr) == SQLITE_OK &&
        sqlite3_step(q) == SQLITE_ROW && sqlite3_column_text(q, 0))
      out = reinterpret_cast<const char*>(sqlite3_column_text(q, 0));
    sqlite3_finalize(q);
    return out;
  };
  EXPECT_EQ(one("PRAGMA user_version"), "4");
  EXPECT_NE(one("SELECT value FROM meta WHERE key = 'migrated_to_3_at'"), "<none>");
  EXPECT_EQ(one("SELECT status || ' ' || trainee || ' ' || steps FROM sessions"),
            "complete human 2000");
  sqlite3_close(h);
  fs::remove_all(dir);
}
