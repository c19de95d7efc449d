// The learning-curve mixed model of the report: on a database with a planted linear trend per
// group, value = a_g + b_g * session + u_participant + e, the report's table recovers b_g and the
// figure carries one fitted line with its band per group; with one participant per group the
// section says why there is no fit and keeps the plain curves. KEEP=1 keeps the databases and
// reports in the temporary directory for inspection.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "analysis/report.hpp"
#include "results/store.hpp"
#include "tests/analysis/support.hpp"

using namespace palplab;
using namespace palplab::analysis;
namespace fs = std::filesystem;

namespace {

constexpr double kSlope[2] = {-0.30, -0.10};  // N per session, groups A and B
constexpr double kIntercept[2] = {3.0, 2.6};  // N at session 0
constexpr int kSessions = 5;

// Two groups of `per_group` participants, kSessions training sessions and one post-training
// test. Participant offsets and the residuals are fixed, small and balanced so the planted slopes
// are recovered to well within their standard errors.
fs::path make_db(const std::string& tag, int per_group, bool slope_spread = false) {
  fs::path dir =
      fs::temp_directory_path() / ("palplab_lcurve_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::path db = dir / "study.db";
  nlohmann::json sj = {
      {"palplab_study", 1},
      {"id", "lcurve"},
      {"title", "Learning-curve fixture"},
      {"groups", {{{"id", "A"}}, {{"id", "B"}}}},
      {"phases",
       {{{"id", "practice"}, {"kind", "training"}, {"sessions", kSessions}},
        {{"id", "test"}, {"kind", "post_training"}, {"sessions", 1}}}},
      {"analyses",
       {{{"kind", "descriptives"}, {"measure", "palpation_force"}, {"phase", "test"}}}}};
  auto store = results::Store::create(db.string());
  results::StudyRecord st;
  st.study_id = "lcurve";
  st.title = sj["title"];
  st.json = sj.dump(2);
  st.sha256 = "00";
  st.palplab_version = "0.1.0";
  st.git_commit = "test";
  st.seed = 1;
  st.started_at = "2026-11-21T10:00:00Z";
  std::vector<results::ParticipantRecord> ps;
  for (int g = 0; g < 2; ++g)
    for (int i = 0; i < per_group; ++i) {
      results::ParticipantRecord p;
      p.participant = std::string(g == 0 ? "A" : "B") + std::to_string(i + 1);
      p.group = g == 0 ? "A" : "B";
      p.number = g * per_group + i;
      p.seed = 100 + p.number;
      ps.push_back(p);
    }
  store.write_study(st, {{"P", "prototypes/P.json", "pp", "{}"}}, ps);
  results::StudyStructure ss;
  ss.has_structure = true;
  ss.groups = {{"A", "A"}, {"B", "B"}};
  results::PhaseRecord tr;
  tr.phase = "practice";
  tr.kind = "training";
  tr.sessions = kSessions;
  tr.session_duration = 2;
  results::PhaseRecord post = tr;
  post.phase = "test";
  post.kind = "post_training";
  post.sessions = 1;
  ss.phases = {tr, post};
  store.write_structure(ss);
  for (const auto& p : ps) {
    const int g = p.number / per_group, i = p.number % per_group;
    const double u = 0.2 * (i - (per_group - 1) / 2.0);  // participant offset, mean 0
    // Participant slope deviations (mean 0 over 6 participants, not collinear with u).
    static const double dv[6] = {0.06, -0.04, 0.0, -0.06, 0.05, -0.01};
    const double v = slope_spread && per_group == 6 ? dv[i] : 0.0;
    for (int s = 0; s <= kSessions; ++s) {
      results::SessionData d;
      d.session.participant = p.participant;
      d.session.ordinal = s;
      d.session.phase = s < kSessions ? "practice" : "test";
      d.session.phase_index = s < kSessions ? s : 0;
      d.session.prototype = "P";
      d.session.duration = 2;
      d.session.steps = 10;
      d.session.seed = 7;
      d.session.state_after = "{}";
      d.session.completed_at = "2026-11-21T10:10:00Z";
      const int session = s + 1;
      const double e = 0.04 * (((i + 2 * s) % 5) - 2);  // small residual, ~uncorrelated with s
      d.measures.push_back(
          {"palpation_force", kIntercept[g] + (kSlope[g] + v) * session + u + e, "N"});
      store.write_session(d);
    }
  }
  store.set_finished("2026-11-21T11:00:00Z");
  return db;
}

double table_number(const std::string& md, const std::string& row_start, int column) {
  const size_t at = md.find(row_start);
  if (at == std::string::npos) return NAN;
  std::string line = md.substr(at, md.find('\n', at) - at);
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, '|')) cells.push_back(cell);
  // cells[0] is empty (leading '|')
  return static_cast<size_t>(column + 1) < cells.size() ? std::stod(cells[column + 1]) : NAN;
}

}  // namespace

TEST(ReportLearningCurve, MixedModelRecoversPlantedSlopesAndDrawsFittedLines) {
  fs::path db = make_db("fit", 6);
  ReportFiles files = write_report(db.string(), (db.parent_path() / "report").string());
  const std::string md = slurp(files.markdown);
  const size_t sec = md.find("### Mixed model of the learning curve: palpation_force");
  ASSERT_NE(sec, std::string::npos) << md;
  const std::string s = md.substr(sec);
  // No participant slope variation planted: the random-slope fit is singular, the random-
  // intercept model is kept and the report says so.
  EXPECT_NE(s.find("`palpation_force ~ group * session + (1 | participant)`, REML"),
            std::string::npos)
      << s.substr(0, 1500);
  EXPECT_NE(s.find("was not kept: its fit is singular"), std::string::npos);
  EXPECT_EQ(s.find("No mixed model fitted"), std::string::npos);
  // Balanced design, random intercept: the fixed-effect slope of a group is the OLS slope of
  // its session means, i.e. the planted slope plus the slope of the mean residual. Per session
  // the six residuals cover the five values once and repeat the first participant's, whose
  // pattern over sessions 1..5 is (-2, 0, 2, -1, 1) x 0.04 with slope 0.5 x 0.04, so the bias is
  // 0.04 / 12. The slope's SE is sigma / sqrt(6 participants x Sxx = 10).
  const double bias = 0.04 / 12;
  const double slope_a = table_number(s, "| A |", 1), slope_b = table_number(s, "| B |", 1);
  EXPECT_NEAR(slope_a, kSlope[0] + bias, 1e-4) << s.substr(0, 2500);
  EXPECT_NEAR(slope_b, kSlope[1] + bias, 1e-4);
  const double sigma = std::stod(s.substr(s.find("Residual SD ") + 12));
  EXPECT_NEAR(table_number(s, "| A |", 2), sigma / std::sqrt(60.0), 1e-5);
  // The fixed effects: session = slope of the reference group A, groupB:session = the difference.
  EXPECT_NEAR(table_number(s, "| session |", 1), kSlope[0] + bias, 1e-4);
  EXPECT_NEAR(table_number(s, "| groupB:session |", 1), kSlope[1] - kSlope[0], 1e-4);
  EXPECT_NEAR(table_number(s, "| (Intercept) |", 1), kIntercept[0], 0.1);
  // Type III F tests for all three terms; the interaction is clearly significant here.
  for (const char* term : {"| group |", "| session |", "| group:session |"})
    EXPECT_NE(s.find(term), std::string::npos) << term;
  EXPECT_NE(s.find("Do the groups learn differently?"), std::string::npos);
  EXPECT_NE(s.find("p < .001"), std::string::npos) << s.substr(0, 3000);
  // Partial η² with its noncentral-F interval beside each type III F test: the interval holds
  // the point estimate, and a clearly significant interaction has a lower bound above 0.
  EXPECT_NE(s.find("partial η² [95% CI]"), std::string::npos);
  {
    const size_t row = s.find("| group:session |");
    ASSERT_NE(row, std::string::npos);
    const std::string line = s.substr(row, s.find('\n', row) - row);
    double pes = NAN, lo = NAN, hi = NAN;
    const size_t last = line.rfind("| ", line.size() - 3);
    ASSERT_EQ(std::sscanf(line.c_str() + last, "| %lf [%lf, %lf]", &pes, &lo, &hi), 3) << line;
    EXPECT_GT(lo, 0) << line;
    EXPECT_LE(lo, pes);
    EXPECT_GE(hi, pes);
    EXPECT_LT(hi, 1);
  }
  // The figure: one dashed fitted line and one band per group, plus the observed means.
  std::string svg;
  for (const auto& f : files.figures)
    if (f.find("learning_palpation_force.svg") != std::string::npos) svg = slurp(f);
  ASSERT_FALSE(svg.empty());
  auto count = [&](const std::string& what) {
    size_t n = 0;
    for (size_t at = svg.find(what); at != std::string::npos; at = svg.find(what, at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count("class=\"fit\""), 2u);
  EXPECT_EQ(count("class=\"fitband\""), 2u);
  EXPECT_EQ(count("class=\"errorbar\""), 2u * kSessions);
  if (!std::getenv("KEEP")) fs::remove_all(db.parent_path());
}

TEST(ReportLearningCurve, OneParticipantPerGroupReportsWhyThereIsNoFit) {
  fs::path db = make_db("one", 1);
  ReportFiles files = write_report(db.string(), (db.parent_path() / "report").string());
  const std::string md = slurp(files.markdown);
  EXPECT_NE(md.find("No mixed model fitted: group A has 1 participant with training data"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("The figure shows the observed group means only."), std::string::npos);
  std::string svg;
  for (const auto& f : files.figures)
    if (f.find("learning_palpation_force.svg") != std::string::npos) svg = slurp(f);
  ASSERT_FALSE(svg.empty());
  EXPECT_EQ(svg.find("class=\"fit\""), std::string::npos);
  EXPECT_NE(svg.find("<circle"), std::string::npos);  // the plain curves are still drawn
  if (!std::getenv("KEEP")) fs::remove_all(db.parent_path());
}

// With planted participant slope deviations (sample SD 0.048 N per session) the random-slope model
// fits without a singular fit and is the one reported; the group slopes are still recovered.
TEST(ReportLearningCurve, RandomSlopeModelKeptWhenItFits) {
  fs::path db = make_db("slope", 6, /*slope_spread=*/true);
  ReportFiles files = write_report(db.string(), (db.parent_path() / "report").string());
  const std::string md = slurp(files.markdown);
  const size_t sec = md.find("### Mixed model of the learning curve: palpation_force");
  ASSERT_NE(sec, std::string::npos) << md;
  const std::string s = md.substr(sec);
  EXPECT_NE(s.find("`palpation_force ~ group * session + (1 + session | participant)`, REML"),
            std::string::npos)
      << s.substr(0, 1500);
  EXPECT_EQ(s.find("was not kept"), std::string::npos);
  const double sd_slope = std::stod(s.substr(s.find("session slope SD ") + 17));
  EXPECT_GT(sd_slope, 0.02);
  EXPECT_LT(sd_slope, 0.09);
  // The planted deviations average to zero within each group, so the slopes stay on target.
  EXPECT_NEAR(table_number(s, "| A |", 1), kSlope[0], 0.02) << s.substr(0, 2500);
  EXPECT_NEAR(table_number(s, "| B |", 1), kSlope[1], 0.02);
  if (!std::getenv("KEEP")) fs::remove_all(db.parent_path());
}
