// results: SHA-256 on the FIPS 180 vectors, the embedded schema, the store round trip,
// per-session atomicity, the compact sample encoding and the CSV export.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/input_error.hpp"
#include "results/sha256.hpp"
#include "results/store.hpp"
#include "tests/results/results_test_support.hpp"

using namespace palplab;
using namespace palplab::results;
namespace fs = std::filesystem;

namespace {
fs::path tmp(const std::string& name) {
  return test_support::tmp("results", name);
}
using test_support::slurp;

SessionData make_session(const std::string& participant, int ordinal, std::size_t n_samples) {
  SessionData d;
  d.session.participant = participant;
  d.session.ordinal = ordinal;
  d.session.phase = ordinal == 0 ? "training" : "post_training";
  d.session.phase_index = 0;
  d.session.prototype = "A";
  d.session.study_offset = 600.0 * ordinal;
  d.session.duration = n_samples * 0.001;
  d.session.steps = static_cast<long long>(n_samples);
  d.session.wall_duration = 0.25;
  d.session.loop_median = 2e-6;
  d.session.loop_p99 = 9e-6;
  d.session.seed = 18446744073709551557ULL;  // > INT64_MAX: stored as text
  d.session.state_after = "{\"target\": 2.5}";
  d.measures = {{"palpation_force", 2.4375, "N"},
                {"exploration_time", 12.5, "s"},
                {"feature_identified", 1.0, "1"},
                {"accuracy", std::nullopt, "%"}};
  d.events = {{1.5, "contact_start", 0.0, "ovary_left"}, {2.0, "st_reached", 2.31, "ovary_left"}};
  d.samples.t0 = 0.0;
  d.samples.dt = 0.001;
  for (std::size_t i = 0; i < n_samples; ++i) {
    double t = i * 0.001;
    d.samples.x.insert(d.samples.x.end(), {0.01 * std::sin(t), -0.2 + 0.001 * t, 0.3 * t});
    d.samples.F.insert(d.samples.F.end(), {0.0, 2.5 * std::sin(3 * t), -0.1});
    d.samples.node.push_back(i % 100 < 50 ? -1 : static_cast<int>(i % 1500));
  }
  return d;
}
}  // namespace

TEST(Sha256, Fips180Vectors) {
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(
      sha256_hex("abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmnhijklmnoijklmnopjklmno"
                 "pqklmnopqrlmnopqrsmnopqrstnopqrstu"),
      "cf5b16a778af8380036ce59e7b0492370b249b11e8f07a51afac45037afee9d1");
  // one million 'a', fed in uneven pieces to exercise the buffering
  Sha256 h;
  std::string chunk(977, 'a');
  std::size_t left = 1000000;
  while (left) {
    std::size_t n = std::min(left, chunk.size());
    h.update(chunk.data(), n);
    left -= n;
  }
  auto d = h.digest();
  char hex[65];
  for (int i = 0; i < 32; ++i) std::snprintf(hex + 2 * i, 3, "%02x", d[i]);
  EXPECT_EQ(std::string(hex), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Schema, EmbeddedCopyMatchesSchemaSql) {
  EXPECT_EQ(schema_sql(), slurp(fs::path(PALPLAB_SOURCE_DIR) / "results" / "schema.sql"));
}

TEST(SampleEncoding, RoundTripWithinHalfAQuantum) {
  SessionData d = make_session("P01", 0, 2500);
  std::string blob = encode_samples(d.samples, 0, d.samples.size());
  SampleSeries back;
  decode_samples(blob, d.samples.size(), 0.0, 0.001, back);
  ASSERT_EQ(back.size(), d.samples.size());
  for (std::size_t i = 0; i < 3 * back.size(); ++i) {
    ASSERT_NEAR(back.x[i], d.samples.x[i], 0.5e-6 + 1e-12);
    ASSERT_NEAR(back.F[i], d.samples.F[i], 0.5e-4 + 1e-12);
  }
  EXPECT_EQ(back.node, d.samples.node);
  // compact: far below the 56 bytes of 7 doubles per sample
  EXPECT_LT(blob.size(), 14 * d.samples.size());
  EXPECT_THROW(decode_samples(blob.substr(0, blob.size() / 2), d.samples.size(), 0, 0.001, back),
               std::runtime_error);
}

TEST(Store, RoundTripAndRefusesToOverwrite) {
  auto dir = tmp("rt");
  std::string db = (dir / "r.db").string();
  {
    Store s = Store::create(db);
    StudyRecord st{"exp",   "Title", "{\"id\": \"exp\"}",     sha256_hex("{\"id\": \"exp\"}"),
                   "0.1.0", "abc",   18446744073709551615ULL, "2026-01-01T00:00:00Z",
                   ""};
    s.write_study(st, {{"A", "/p/A.json", sha256_hex("{}"), "{}"}},
                  {{"P01", "A", 0, 5}, {"P02", "B", 1, 6}});
    SessionData a = make_session("P02", 0, 1500), b = make_session("P01", 1, 10);
    s.write_session(a);
    s.write_session(b);
    EXPECT_GT(a.session.session, 0);
  }
  EXPECT_THROW(Store::create(db), InputError);
  Store s = Store::open(db);
  StudyRecord st = s.read_study();
  EXPECT_EQ(st.seed, 18446744073709551615ULL);
  EXPECT_EQ(st.finished_at, "");
  EXPECT_EQ(st.sha256, sha256_hex("{\"id\": \"exp\"}"));
  auto sessions = s.read_sessions();
  ASSERT_EQ(sessions.size(), 2u);
  EXPECT_EQ(sessions[0].participant, "P01");  // ordered by participant number
  EXPECT_EQ(sessions[1].seed, 18446744073709551557ULL);
  EXPECT_EQ(sessions[1].state_after, "{\"target\": 2.5}");
  auto m = s.read_measures();
  ASSERT_EQ(m.size(), 8u);
  EXPECT_EQ(m[0].name, "accuracy");
  EXPECT_FALSE(m[0].value.has_value());
  EXPECT_EQ(m[4].group, "B");
  auto ev = s.read_events(sessions[1].session);
  ASSERT_EQ(ev.size(), 2u);
  EXPECT_EQ(ev[1].kind, "st_reached");
  EXPECT_EQ(ev[1].region, "ovary_left");
  SampleSeries ss = s.read_samples(sessions[1].session);
  EXPECT_EQ(ss.size(), 1500u);
  s.set_finished("2026-01-01T01:00:00Z");
  EXPECT_EQ(s.read_study().finished_at, "2026-01-01T01:00:00Z");
}

TEST(Store, SessionIsAtomic) {
  auto dir = tmp("atomic");
  Store s = Store::create((dir / "a.db").string());
  s.write_study({"x", "x", "{}", sha256_hex("{}"), "v", "c", 1, "t", ""}, {}, {{"P01", "A", 0, 1}});
  SessionData a = make_session("P01", 0, 10);
  s.write_session(a);
  SessionData dup = make_session("P01", 0, 10);  // same (participant, ordinal): rejected
  dup.measures.push_back({"extra", 1.0, "1"});
  EXPECT_THROW(s.write_session(dup), std::runtime_error);
  EXPECT_EQ(s.read_sessions().size(), 1u);
  EXPECT_EQ(s.read_measures().size(), 4u);  // nothing of the failed session is left
}

TEST(Store, OpenRejectsOtherFiles) {
  auto dir = tmp("reject");
  EXPECT_THROW(Store::open((dir / "missing.db").string()), InputError);
  std::ofstream(dir / "text.db") << "hello, not a database";
  EXPECT_THROW(Store::open((dir / "text.db").string()), InputError);
}

TEST(Export, TidyCsvFiles) {
  auto dir = tmp("export");
  std::string db = (dir / "e.db").string();
  Store s = Store::create(db);
  s.write_study({"x", "x", "{}", sha256_hex("{}"), "v", "c", 1, "t", ""}, {},
                {{"P01", "A", 0, 1}, {"P,2", "B", 1, 2}});
  SessionData a = make_session("P01", 0, 1200), b = make_session("P,2", 0, 5);
  s.write_session(a);
  s.write_session(b);
  export_csv(s, (dir / "out").string(), true);
  std::istringstream m(slurp(dir / "out" / "measures.csv"));
  std::string line;
  std::getline(m, line);
  EXPECT_EQ(line, "participant,group,phase,session,measure,value,unit");
  std::getline(m, line);
  EXPECT_EQ(line, "P01,A,training,1,accuracy,,%");
  std::getline(m, line);
  EXPECT_EQ(line, "P01,A,training,1,exploration_time,12.5,s");
  int rows = 2;
  while (std::getline(m, line)) ++rows;
  EXPECT_EQ(rows, 8);  // data rows: 2 sessions x 4 measures
  EXPECT_NE(
      slurp(dir / "out" / "measures.csv").find("\"P,2\",B,training,1,palpation_force,2.4375,N"),
      std::string::npos);
  std::string ev = slurp(dir / "out" / "events.csv");
  EXPECT_EQ(ev.substr(0, ev.find('\n')), "participant,group,phase,session,t,kind,value,region");
  std::string smp = slurp(dir / "out" / "samples.csv");
  EXPECT_EQ(std::count(smp.begin(), smp.end(), '\n'), 1 + 1200 + 5);
  EXPECT_TRUE(fs::exists(dir / "out" / "sessions.csv"));
}

// sessions.csv numbers `ordinal` from 1 (the database's column is 0-based), like `session`: a
// column contract of the export (docs/FORMATS.md), pinned here.
TEST(Export, SessionsCsvOrdinalIsOneBased) {
  auto dir = tmp("export_ordinal");
  std::string db = (dir / "e.db").string();
  Store s = Store::create(db);
  s.write_study({"x", "x", "{}", sha256_hex("{}"), "v", "c", 1, "t", ""}, {}, {{"P01", "A", 0, 1}});
  SessionData a = make_session("P01", 0, 10), b = make_session("P01", 1, 10);
  s.write_session(a);
  s.write_session(b);
  ASSERT_EQ(s.read_sessions()[1].ordinal, 1);  // 0-based in the database
  export_csv(s, (dir / "out").string(), false);
  std::istringstream in(slurp(dir / "out" / "sessions.csv"));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line,
            "participant,group,phase,session,ordinal,prototype,instructor,study_offset_s,day,"
            "duration_s,steps,wall_duration_s,loop_median_s,loop_p99_s,seed,completed_at,"
            "session_id");
  // Up to the seed; then completed_at (a time) and the database's session id.
  auto seed_part = [](const std::string& l) {
    const std::size_t id = l.rfind(',');
    return l.substr(0, l.rfind(',', id - 1));
  };
  auto id_part = [](const std::string& l) { return l.substr(l.rfind(',') + 1); };
  std::getline(in, line);
  EXPECT_EQ(seed_part(line),
            "P01,A,training,1,1,A,,0,0,0.01,10,0.25,2e-06,9e-06,18446744073709551557");
  EXPECT_EQ(id_part(line), std::to_string(s.read_sessions()[0].session));
  std::getline(in, line);
  EXPECT_EQ(seed_part(line),
            "P01,A,post_training,1,2,A,,600,0,0.01,10,0.25,2e-06,9e-06,18446744073709551557");
  EXPECT_EQ(id_part(line), std::to_string(s.read_sessions()[1].session));
}
