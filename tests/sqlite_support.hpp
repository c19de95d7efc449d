#pragma once
// What tests that edit a results database by hand share: run SQL on a database file, read one
// integer back. A failing statement is a test failure carrying SQLite's message.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <string>

namespace palplab::testing {

// Runs `sql` (one or more statements) on the database file `db` (created if missing).
inline void sql_exec(const std::filesystem::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK) << db;
  char* err = nullptr;
  const int rc = sqlite3_exec(h, sql.c_str(), nullptr, nullptr, &err);
  const std::string message = err ? err : "";
  sqlite3_free(err);
  sqlite3_close(h);
  ASSERT_EQ(rc, SQLITE_OK) << message << "\n" << sql;
}

// The first column of the first row of `query` as an integer; -1 (and a failure) on an error.
inline long long sql_int(const std::filesystem::path& db, const std::string& query) {
  sqlite3* h = nullptr;
  long long v = -1;
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(h, query.c_str(), -1, &st, nullptr) == SQLITE_OK &&
        sqlite3_step(st) == SQLITE_ROW)
      v = sqlite3_column_int64(st, 0);
    else
      ADD_FAILURE() << sqlite3_errmsg(h) << "\n" << query;
    sqlite3_finalize(st);
  } else {
    ADD_FAILURE() << "cannot open " << db;
  }
  sqlite3_close(h);
  return v;
}

}  // namespace palplab::testing
