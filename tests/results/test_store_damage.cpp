// A damaged or hand-edited results database is bad input (InputError naming the file and what is
// wrong), never an internal error: a dropped table, a file cut short, a text in a measure's
// value, a corrupt sample blob, an empty or impossible path. A failing export leaves an earlier
// export's files as they were.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "common/input_error.hpp"
#include "results/sha256.hpp"
#include "results/store.hpp"
#include "tests/results/results_test_support.hpp"
#include "tests/sqlite_support.hpp"

using namespace palplab;
using namespace palplab::results;
namespace fs = std::filesystem;

namespace {

fs::path tmp(const std::string& name) {
  return test_support::tmp("damage", name);
}
using test_support::slurp;

SessionData session(const std::string& participant, int ordinal, std::size_t n_samples) {
  SessionData d;
  d.session.participant = participant;
  d.session.ordinal = ordinal;
  d.session.phase = "post_training";
  d.session.prototype = "A";
  d.session.state_after = "{}";
  d.measures = {{"palpation_force", 2.5, "N"}, {"exploration_time", 12.5, "s"}};
  d.samples.dt = 0.001;
  for (std::size_t i = 0; i < n_samples; ++i) {
    d.samples.x.insert(d.samples.x.end(), {0.001 * i, 0.0, 0.0});
    d.samples.F.insert(d.samples.F.end(), {0.0, 0.0, 0.5});
    d.samples.node.push_back(static_cast<int>(i % 7));
  }
  return d;
}

// A finished two-participant database (closed: its WAL checkpointed into the file).
std::string make_db(const fs::path& dir, std::size_t n_samples = 1500) {
  const std::string db = (dir / "r.db").string();
  Store s = Store::create(db);
  s.write_study({"x", "x", "{}", sha256_hex("{}"), "v", "c", 1, "t", ""}, {},
                {{"P01", "A", 0, 1}, {"P02", "B", 1, 2}});
  SessionData a = session("P01", 0, n_samples), b = session("P02", 0, n_samples);
  s.write_session(a);
  s.write_session(b);
  s.set_finished("2026-01-01T01:00:00Z");
  return db;
}

using palplab::testing::sql_exec;

// `f` throws an InputError whose message holds every one of `parts`.
void expect_input_error(const std::function<void()>& f, std::initializer_list<std::string> parts) {
  try {
    f();
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    for (const auto& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what() << "\nmissing: " << p;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not an InputError (an internal error for the user): " << e.what();
  }
}

}  // namespace

TEST(StoreDamage, MissingTableIsNamedWhenOpening) {
  auto d = tmp("notable");
  const std::string db = make_db(d);
  sql_exec(db, "DROP TABLE samples; DROP TABLE sessions;");
  expect_input_error([&] { Store::open(db); },
                     {db, "not a complete palplab results database", "table \"sessions\""});
  expect_input_error([&] { Store::open(db, true); }, {db, "table \"sessions\" is missing"});
}

TEST(StoreDamage, MissingColumnIsNamedWhenOpening) {
  auto d = tmp("nocolumn");
  const std::string db = make_db(d);
  sql_exec(db, "ALTER TABLE measures DROP COLUMN unit;");
  expect_input_error([&] { Store::open(db); }, {db, "table \"measures\" lacks the column(s) unit"});
}

TEST(StoreDamage, TruncatedFileIsSaidDamagedNotForeign) {
  auto d = tmp("truncated");
  const std::string db = make_db(d, 20000);  // a few hundred pages
  ASSERT_FALSE(fs::exists(db + "-wal"));
  const std::uintmax_t size = fs::file_size(db);
  for (std::uintmax_t keep :
       {size / 2, std::uintmax_t{4096}, std::uintmax_t{100}, std::uintmax_t{50}}) {
    fs::copy_file(db, d / "cut.db", fs::copy_options::overwrite_existing);
    fs::resize_file(d / "cut.db", keep);
    SCOPED_TRACE("cut to " + std::to_string(keep) + " bytes");
    expect_input_error([&] { Store::open((d / "cut.db").string()); },
                       {"cut.db", "damaged or truncated database"});
    // --force does not delete what it cannot recognise, and says why.
    expect_input_error([&] { Store::remove_existing((d / "cut.db").string()); },
                       {"refusing to replace it", "damaged or truncated"});
    EXPECT_EQ(fs::file_size(d / "cut.db"), keep);
  }
}

TEST(StoreDamage, TextInAMeasureValueIsRefusedNotReadAsZero) {
  auto d = tmp("textvalue");
  const std::string db = make_db(d);
  sql_exec(db,
           "UPDATE measures SET value = 'abc' WHERE name = 'palpation_force' AND session = "
           "(SELECT session FROM sessions WHERE participant = 'P02');");
  Store s = Store::open(db);
  expect_input_error(
      [&] { s.read_measures(); },
      {db, "participant P02", "measure \"palpation_force\"", "'abc' is not a number"});
  // A numeric text is stored as a number by the column's REAL affinity and reads as one.
  sql_exec(db, "UPDATE measures SET value = '2.75' WHERE name = 'palpation_force';");
  const auto rows = Store::open(db).read_measures();
  for (const auto& r : rows) {
    if (r.name == "palpation_force") {
      EXPECT_EQ(r.value, 2.75);
    }
  }
}

TEST(StoreDamage, CorruptSampleBlobNamesItsSession) {
  auto d = tmp("blob");
  const std::string db = make_db(d);
  sql_exec(db,
           "UPDATE samples SET data = substr(data, 1, 10) WHERE session = (SELECT session FROM "
           "sessions WHERE participant = 'P02');");
  Store s = Store::open(db);
  const auto sessions = s.read_sessions();
  ASSERT_EQ(sessions.size(), 2u);
  EXPECT_EQ(s.read_samples(sessions[0].session).size(), 1500u);  // P01's are intact
  expect_input_error([&] { s.read_samples(sessions[1].session); },
                     {db, "session " + std::to_string(sessions[1].session), "participant P02",
                      "corrupt sample blob"});
}

TEST(StoreDamage, FailingExportKeepsTheEarlierExport) {
  auto d = tmp("export");
  const std::string db = make_db(d);
  export_csv(Store::open(db), (d / "csv").string(), true);
  const std::string measures = slurp(d / "csv" / "measures.csv");
  const std::string samples = slurp(d / "csv" / "samples.csv");
  ASSERT_NE(measures.find("palpation_force"), std::string::npos);
  sql_exec(db, "UPDATE samples SET data = x'01';");
  expect_input_error([&] { export_csv(Store::open(db), (d / "csv").string(), true); },
                     {"corrupt sample blob"});
  EXPECT_EQ(slurp(d / "csv" / "measures.csv"), measures);
  EXPECT_EQ(slurp(d / "csv" / "samples.csv"), samples);
  for (const auto& e : fs::directory_iterator(d / "csv"))
    EXPECT_EQ(e.path().extension(), ".csv") << e.path();  // no .partial left behind
  // A directory where a CSV file goes, and a file where the directory goes, are said as such.
  fs::create_directories(d / "csv2" / "events.csv");
  expect_input_error(
      [&] { export_csv(Store::open(make_db(d / "csv2")), (d / "csv2").string(), false); },
      {"events.csv", "is a directory"});
  std::ofstream(d / "afile") << "notes\n";
  expect_input_error([&] { export_csv(Store::open(db), (d / "afile").string(), false); },
                     {"afile", "exists and is not a directory"});
  EXPECT_EQ(slurp(d / "afile"), "notes\n");
}

TEST(StoreDamage, PathsSayWhatIsWrongWithThem) {
  auto d = tmp("paths");
  expect_input_error([] { Store::open(""); }, {"no database file name given"});
  expect_input_error([] { Store::create(""); }, {"no database file name given"});
  expect_input_error([&] { Store::create((d / "missing" / "x.db").string()); },
                     {"its directory", "does not exist"});
  std::ofstream(d / "file") << "x";
  expect_input_error([&] { Store::create((d / "file" / "x.db").string()); },
                     {"is not a directory"});
  expect_input_error([&] { Store::create(d.string()); }, {"is a directory"});
  EXPECT_FALSE(fs::exists(d / "missing"));
}
