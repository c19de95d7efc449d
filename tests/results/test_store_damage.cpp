// A damaged or hand-edited results database is bad input (InputError naming the file and what is
// wrong), never an internal error: a dropped table, a file cut short, a text in a measure's
// value, a number column holding text or ±inf, a corrupt sample blob, an empty or impossible
// path. A failing export leaves an earlier export's files as they were; an export without samples
// removes an earlier export's samples.csv.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "common/input_error.hpp"
#include "results/sha256.hpp"
#include "results/store.hpp"
#include "tests/results/results_test_support.hpp"
#include "tests/sqlite_support.hpp"

using namespace palplab;
using namespace palplab::results;
namespace fs = std::filesystem;

namespace {

fs::path damage_tmp(const std::string& name) {
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
  d.events = {{0.5, "contact_start", 0.0, "feature"}, {1.25, "contact_end", 2.5, ""}};
  d.session.wall_duration = 0.75;
  // One sample per step, as a run stores them (a complete session's count is checked).
  d.session.steps = static_cast<long long>(n_samples);
  d.session.duration = 0.001 * static_cast<double>(n_samples);
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
void expect_input_error(const std::function<void()>& f, const std::vector<std::string>& parts) {
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
  auto d = damage_tmp("notable");
  const std::string db = make_db(d);
  sql_exec(db, "DROP TABLE samples; DROP TABLE sessions;");
  expect_input_error([&] { Store::open(db); },
                     {db, "not a complete palplab results database", "table \"sessions\""});
  expect_input_error([&] { Store::open(db, true); }, {db, "table \"sessions\" is missing"});
}

TEST(StoreDamage, MissingColumnIsNamedWhenOpening) {
  auto d = damage_tmp("nocolumn");
  const std::string db = make_db(d);
  sql_exec(db, "ALTER TABLE measures DROP COLUMN unit;");
  expect_input_error([&] { Store::open(db); }, {db, "table \"measures\" lacks the column(s) unit"});
}

TEST(StoreDamage, TruncatedFileIsSaidDamagedNotForeign) {
  auto d = damage_tmp("truncated");
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
  auto d = damage_tmp("textvalue");
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
  auto d = damage_tmp("blob");
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
  auto d = damage_tmp("export");
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
  auto d = damage_tmp("paths");
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

namespace {
// The id of P02's session in a make_db database.
std::string p02_session() {
  return "(SELECT session FROM sessions WHERE participant = 'P02')";
}
}  // namespace

// A hand-edited events row (±inf, text) is refused naming the table, the row and the column,
// by read_events and so by the export, which kept writing `contact_end,inf` and `t` = 0.
TEST(StoreDamage, EventValuesThatAreNotFiniteNumbersAreRefused) {
  auto d = damage_tmp("events");
  const std::string db = make_db(d);
  export_csv(Store::open(db), (d / "csv").string(), false);
  const std::string events = slurp(d / "csv" / "events.csv");
  ASSERT_NE(events.find("P02,B,post_training,1,1.25,contact_end,2.5,"), std::string::npos)
      << events;
  struct Case {
    std::string sql;
    std::vector<std::string> parts;
  };
  const std::vector<Case> cases = {
      {"UPDATE events SET value = 9e999 WHERE kind = 'contact_end' AND session = " + p02_session(),
       {"table events, row (session ", "participant P02", "kind contact_end", "t 1.25",
        "column value: expected a finite number, got inf"}},
      {"UPDATE events SET value = -9e999 WHERE kind = 'contact_end' AND session = " + p02_session(),
       {"table events", "column value: expected a finite number, got -inf"}},
      {"UPDATE events SET value = 'abc' WHERE kind = 'contact_end' AND session = " + p02_session(),
       {"table events", "participant P02", "column value: expected a finite number, got 'abc'"}},
      {"UPDATE events SET t = 'abc' WHERE kind = 'contact_start' AND session = " + p02_session(),
       {"table events", "participant P02", "kind contact_start",
        "column t: expected a finite number, got 'abc'"}},
      {"UPDATE events SET t = x'00ff' WHERE kind = 'contact_start' AND session = " + p02_session(),
       {"table events", "column t: expected a finite number, got (a blob)"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.sql);
    const fs::path copy = d / "edited.db";
    fs::copy_file(db, copy, fs::copy_options::overwrite_existing);
    sql_exec(copy, c.sql + ";");
    Store s = Store::open(copy.string());
    const auto sessions = s.read_sessions();
    ASSERT_EQ(sessions.size(), 2u);
    EXPECT_EQ(s.read_events(sessions[0].session).size(), 2u);  // P01's are intact
    std::vector<std::string> parts = c.parts;
    parts.push_back(copy.string());
    parts.push_back("session " + std::to_string(sessions[1].session));
    expect_input_error([&] { s.read_events(sessions[1].session); }, parts);
    expect_input_error([&] { export_csv(s, (d / "csv").string(), false); }, parts);
    EXPECT_EQ(slurp(d / "csv" / "events.csv"), events);  // the earlier export is kept
  }
  // A numeric text is stored as a number by the column's REAL affinity and reads as one.
  sql_exec(db, "UPDATE events SET value = '3.5' WHERE kind = 'contact_end';");
  Store s = Store::open(db);
  EXPECT_EQ(s.read_events(s.read_sessions()[1].session)[1].value, 3.5);
}

// The same for every number column of a sessions row (read_sessions, read_attempts, the
// export's sessions.csv and the session columns of read_measures), and the participants' and the
// study's numbers.
TEST(StoreDamage, SessionNumbersThatAreNotWhatTheSchemaSaysAreRefused) {
  auto d = damage_tmp("sessions");
  const std::string db = make_db(d);
  export_csv(Store::open(db), (d / "csv").string(), false);
  const std::string sessions_csv = slurp(d / "csv" / "sessions.csv");
  struct Case {
    std::string set, column, got;
  };
  const std::string int_range = "expected an integer from 0 to 2147483647, got ";
  const std::vector<Case> cases = {
      {"loop_median = 9e999", "loop_median", "expected a finite number, got inf"},
      {"loop_p99 = -9e999", "loop_p99", "expected a finite number, got -inf"},
      {"wall_duration = 'x'", "wall_duration", "expected a finite number, got 'x'"},
      {"study_offset = 'soon'", "study_offset", "expected a finite number, got 'soon'"},
      {"duration = x'01'", "duration", "expected a finite number, got (a blob)"},
      {"ordinal = 1.5", "ordinal", int_range + "1.5"},
      {"ordinal = -1", "ordinal", int_range + "-1"},
      {"phase_index = 'first'", "phase_index", int_range + "'first'"},
      {"day = 4294967296", "day", int_range + "4294967296"},
      {"steps = 'many'", "steps", "expected an integer >= 0, got 'many'"},
      {"attempt = 9e999", "attempt", int_range + "inf"},
      {"seed = 'abc'", "seed", "expected an unsigned 64-bit integer in decimal, got 'abc'"},
      {"seed = '-5'", "seed", "expected an unsigned 64-bit integer in decimal, got '-5'"},
      {"seed = '18446744073709551616'", "seed",
       "expected an unsigned 64-bit integer in decimal, got '18446744073709551616'"},
      {"transparency = 2", "transparency", "expected an integer from 0 to 1, got 2"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.set);
    const fs::path copy = d / "edited.db";
    fs::copy_file(db, copy, fs::copy_options::overwrite_existing);
    sql_exec(copy, "UPDATE sessions SET " + c.set + " WHERE participant = 'P02';");
    Store s = Store::open(copy.string());
    const std::vector<std::string> parts = {copy.string(), "table sessions, row (session ",
                                            "participant P02", "phase post_training",
                                            "column " + c.column + ": " + c.got};
    expect_input_error([&] { s.read_sessions(); }, parts);
    expect_input_error([&] { s.read_attempts("P02"); }, parts);
    EXPECT_EQ(s.read_attempts("P01").size(), 1u);  // P01's row is intact
    expect_input_error([&] { export_csv(s, (d / "csv").string(), false); }, parts);
    EXPECT_EQ(slurp(d / "csv" / "sessions.csv"), sessions_csv);
  }
  // read_measures reads a session's ordinal and phase_index too.
  sql_exec(db, "UPDATE sessions SET phase_index = 'x' WHERE participant = 'P02';");
  expect_input_error([&] { Store::open(db).read_measures(); },
                     {db, "table sessions", "participant P02", "column phase_index", "got 'x'"});
  // Participants and the study.
  sql_exec(db,
           "UPDATE sessions SET phase_index = 0; UPDATE participants SET number = 'one' WHERE "
           "participant = 'P02';");
  expect_input_error([&] { Store::open(db).read_participants(); },
                     {db, "table participants, row (participant P02) column number", "got 'one'"});
  sql_exec(db, "UPDATE participants SET number = 1, seed = '' WHERE participant = 'P02';");
  expect_input_error([&] { Store::open(db).read_participants(); },
                     {"table participants", "column seed", "got ''"});
  sql_exec(db, "UPDATE participants SET seed = '2'; UPDATE study SET seed = '1e3';");
  expect_input_error([&] { Store::open(db).read_study(); },
                     {"table study, row (id 1) column seed", "got '1e3'"});
  // What the schema allows still reads: a number stored as numeric text (REAL affinity), NULL
  // for the transparency that was not recorded, the largest seed.
  sql_exec(db,
           "UPDATE study SET seed = '18446744073709551615'; UPDATE sessions SET wall_duration = "
           "'2.5', transparency = NULL, seed = '18446744073709551615';");
  Store s = Store::open(db);
  EXPECT_EQ(s.read_study().seed, 18446744073709551615ull);
  const auto rows = s.read_sessions();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].wall_duration, 2.5);
  EXPECT_EQ(rows[1].seed, 18446744073709551615ull);
  EXPECT_FALSE(rows[1].transparency.has_value());
}

// The study's structure (phases and thresholds, read by report) is typed the same way.
TEST(StoreDamage, PhaseAndThresholdNumbersThatAreNotNumbersAreRefused) {
  auto d = damage_tmp("structure");
  const std::string db = make_db(d);
  sql_exec(db,
           "INSERT INTO phases (phase, position, kind, sessions, session_duration, haptic, "
           "visual_deformation, audio, instructed, feature, transparency) VALUES ('post_training', "
           "0, 'post_training', 1, 120.0, 1, 0, NULL, 0, 'ovary_left', NULL);"
           "INSERT INTO thresholds VALUES ('post_training', '*', 2.0, 2.5, 3.0);");
  const StudyStructure st = Store::open(db).read_structure();
  ASSERT_EQ(st.phases.size(), 1u);
  ASSERT_EQ(st.phases[0].thresholds.size(), 1u);
  EXPECT_EQ(st.phases[0].thresholds[0].mpf, 2.5);
  EXPECT_EQ(st.phases[0].session_duration, 120.0);
  EXPECT_FALSE(st.phases[0].audio.has_value());
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"UPDATE phases SET session_duration = 9e999",
       {"table phases, row (phase ", "column session_duration: expected a finite number, got inf"}},
      {"UPDATE phases SET sessions = 'four'",
       {"table phases", "column sessions: expected an integer from 0 to 2147483647, got 'four'"}},
      {"UPDATE phases SET audio = 7", {"table phases", "column audio", "got 7"}},
      {"UPDATE phases SET instructed = 0.5", {"table phases", "column instructed", "got 0.5"}},
      {"UPDATE thresholds SET mpf = 'x'",
       {"table thresholds, row (phase ", "region ", "column mpf: expected a finite number"}},
  };
  for (const auto& [sql, parts] : cases) {
    SCOPED_TRACE(sql);
    const fs::path copy = d / "edited.db";
    fs::copy_file(db, copy, fs::copy_options::overwrite_existing);
    sql_exec(copy, sql + ";");
    std::vector<std::string> want = parts;
    want.insert(want.begin(), copy.string());
    expect_input_error([&] { Store::open(copy.string()).read_structure(); }, want);
  }
}

TEST(StoreDamage, SampleRowNumbersThatAreNotNumbersAreRefused) {
  auto d = damage_tmp("samplecols");
  const std::string db = make_db(d);
  sql_exec(db,
           "UPDATE samples SET t0 = 'abc' WHERE second = 1 AND session = " + p02_session() + ";");
  Store s = Store::open(db);
  const auto sessions = s.read_sessions();
  expect_input_error([&] { s.read_samples(sessions[1].session); },
                     {db, "table samples", "participant P02", "second 1",
                      "column t0: expected a finite number, got 'abc'"});
  EXPECT_EQ(s.read_samples(sessions[0].session).size(), 1500u);
}

// `export DB1 --samples` then `export DB2` (no --samples) into one directory: the samples.csv of
// DB1 is removed (and reported), not left beside DB2's files; only once the export succeeded.
TEST(StoreDamage, ExportWithoutSamplesRemovesAnEarlierSamplesCsv) {
  auto d = damage_tmp("stale");
  fs::create_directories(d / "one");
  fs::create_directories(d / "two");
  const std::string db1 = make_db(d / "one");
  const std::string db2 = make_db(d / "two");
  sql_exec(db2, "UPDATE sessions SET wall_duration = 9.5;");
  const fs::path out = d / "csv";
  EXPECT_TRUE(export_csv(Store::open(db1), out.string(), true).removed.empty());
  ASSERT_TRUE(fs::exists(out / "samples.csv"));
  const std::string samples1 = slurp(out / "samples.csv");
  // A failing export of DB2 changes nothing, samples.csv included.
  const fs::path bad = d / "bad.db";
  fs::copy_file(db2, bad);
  sql_exec(bad, "UPDATE events SET value = 9e999;");
  expect_input_error([&] { export_csv(Store::open(bad.string()), out.string(), false); },
                     {"table events"});
  EXPECT_EQ(slurp(out / "samples.csv"), samples1);
  // The export of DB2 without samples writes its three files and removes DB1's samples.csv.
  const ExportSummary r = export_csv(Store::open(db2), out.string(), false);
  ASSERT_EQ(r.removed.size(), 1u);
  EXPECT_EQ(fs::path(r.removed[0]), out / "samples.csv");
  EXPECT_FALSE(fs::exists(out / "samples.csv"));
  EXPECT_NE(slurp(out / "sessions.csv").find(",9.5,"), std::string::npos);
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(out)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"events.csv", "measures.csv", "sessions.csv"}));
  // Nothing to remove the next time; with --samples it is written again.
  EXPECT_TRUE(export_csv(Store::open(db2), out.string(), false).removed.empty());
  EXPECT_TRUE(export_csv(Store::open(db2), out.string(), true).removed.empty());
  EXPECT_TRUE(fs::exists(out / "samples.csv"));
  // A directory named samples.csv is not an export's file: left alone.
  fs::remove(out / "samples.csv");
  fs::create_directories(out / "samples.csv");
  std::ofstream(out / "samples.csv" / "notes.txt") << "mine\n";
  EXPECT_TRUE(export_csv(Store::open(db2), out.string(), false).removed.empty());
  EXPECT_EQ(slurp(out / "samples.csv" / "notes.txt"), "mine\n");
}

// Review finding (2026-12-06, seventh): a session whose participant was edited to one the
// participants table lacks was left out of every CSV of the export (its measures and events
// too), exit 0. Rows that name a row that is not there are refused when the database is opened.
TEST(StoreDamage, RowsThatNameAMissingRowAreRefusedWhenOpening) {
  auto d = damage_tmp("references");
  const std::string db = make_db(d);
  struct Case {
    std::string sql;
    std::vector<std::string> parts;
  };
  const std::vector<Case> cases = {
      {"UPDATE sessions SET participant = 'ZZZ' WHERE participant = 'P02'",
       {"table sessions: session ",
        " names participant 'ZZZ', which table participants does "
        "not hold"}},
      {"UPDATE measures SET session = 999 WHERE rowid = 1",
       {"table measures: measure '", "' names session 999, which table sessions does not hold"}},
      // The value as stored (it showed session 2 for 2.5, 0 for 'abc': review 2026-12-06,
      // seventh).
      {"UPDATE measures SET session = 2.5 WHERE rowid = 1", {"' names session 2.5, which"}},
      {"UPDATE events SET session = 'abc' WHERE rowid = 1",
       {"table events: event '", "' names session 'abc', which table sessions does not hold"}},
      // Samples too (an orphan's samples were dropped from the export, exit 0).
      {"UPDATE samples SET session = 99 WHERE rowid = 1",
       {"table samples: samples of second ",
        " names session 99, which table sessions does not "
        "hold"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.sql);
    const fs::path copy = d / "edited.db";
    fs::copy_file(db, copy, fs::copy_options::overwrite_existing);
    sql_exec(copy, c.sql + ";");
    std::vector<std::string> parts = c.parts;
    parts.push_back(copy.string());
    parts.push_back("not a consistent palplab results database");
    expect_input_error([&] { Store::open(copy.string()); }, parts);
  }
  EXPECT_NO_THROW(Store::open(db));
}
