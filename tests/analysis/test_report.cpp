// The report of a small fixture database: every section present, APA lines that match the
// statistics of the same numbers, every SVG (files and the ones inlined in the HTML) well-formed
// XML, no NaN / inf anywhere; bad databases are InputErrors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>

#include <sqlite3.h>
#include <sstream>

#include "analysis/anova.hpp"
#include "analysis/descriptives.hpp"
#include "analysis/distributions.hpp"
#include "analysis/report.hpp"
#include "analysis/summary.hpp"
#include "analysis/svg.hpp"
#include "analysis/two_sample.hpp"
#include "common/input_error.hpp"
#include "results/store.hpp"
#include "tests/analysis/support.hpp"

using namespace palplab;
using namespace palplab::analysis;
namespace fs = std::filesystem;

namespace {

// Minimal XML well-formedness check: balanced, properly nested tags, quoted attributes, valid
// entities, a single root element. Returns "" when well-formed, else what is wrong.
std::string xml_problem(const std::string& s) {
  std::vector<std::string> stack;
  size_t i = 0, roots = 0;
  auto entity_ok = [&](size_t at) {
    static const std::regex ent("^&(amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);");
    return std::regex_search(s.substr(at, 12), ent);
  };
  while (i < s.size()) {
    if (s[i] == '<') {
      if (s.compare(i, 4, "<!--") == 0) {
        size_t e = s.find("-->", i);
        if (e == std::string::npos) return "unterminated comment";
        i = e + 3;
        continue;
      }
      if (s.compare(i, 2, "<?") == 0) {
        size_t e = s.find("?>", i);
        if (e == std::string::npos) return "unterminated declaration";
        i = e + 2;
        continue;
      }
      bool closing = s[i + 1] == '/';
      size_t j = i + (closing ? 2 : 1);
      size_t n0 = j;
      while (j < s.size() && (std::isalnum(static_cast<unsigned char>(s[j])) || s[j] == ':' ||
                              s[j] == '-' || s[j] == '_'))
        ++j;
      std::string name = s.substr(n0, j - n0);
      if (name.empty()) return "empty tag name at " + std::to_string(i);
      if (closing) {
        while (j < s.size() && std::isspace(static_cast<unsigned char>(s[j]))) ++j;
        if (j >= s.size() || s[j] != '>') return "bad closing tag " + name;
        if (stack.empty() || stack.back() != name) return "mismatched </" + name + ">";
        stack.pop_back();
        i = j + 1;
        continue;
      }
      // attributes
      while (true) {
        while (j < s.size() && std::isspace(static_cast<unsigned char>(s[j]))) ++j;
        if (j >= s.size()) return "unterminated tag " + name;
        if (s[j] == '>' || s.compare(j, 2, "/>") == 0) break;
        size_t a0 = j;
        while (j < s.size() && s[j] != '=' && !std::isspace(static_cast<unsigned char>(s[j])) &&
               s[j] != '>')
          ++j;
        if (j == a0 || j >= s.size() || s[j] != '=') return "attribute without value in " + name;
        ++j;
        if (j >= s.size() || (s[j] != '"' && s[j] != '\'')) return "unquoted attribute in " + name;
        char q = s[j++];
        while (j < s.size() && s[j] != q) {
          if (s[j] == '<') return "'<' in attribute of " + name;
          if (s[j] == '&' && !entity_ok(j)) return "bad entity in attribute of " + name;
          ++j;
        }
        if (j >= s.size()) return "unterminated attribute in " + name;
        ++j;
      }
      if (stack.empty()) ++roots;
      if (s[j] == '>') {
        stack.push_back(name);
        i = j + 1;
      } else {
        i = j + 2;
      }
      continue;
    }
    if (s[i] == '&' && !entity_ok(i)) return "bad entity at " + std::to_string(i);
    if (stack.empty() && !std::isspace(static_cast<unsigned char>(s[i])))
      return "text outside the root";
    ++i;
  }
  if (!stack.empty()) return "unclosed <" + stack.back() + ">";
  if (roots != 1) return "expected one root element, got " + std::to_string(roots);
  return "";
}

bool has_nan_or_inf(const std::string& s) {
  static const std::regex bad("(^|[^A-Za-z])(nan|NaN|NAN|-?inf|-?Inf|infinity)([^A-Za-z]|$)");
  return std::regex_search(s, bad);
}

struct FixtureDb {
  fs::path dir, db;
  std::vector<double> post[3];  // post-training palpation_force per group (defined values)
};

// The structure the runner stores: phases with kinds, cues, thresholds. The phase ids are
// deliberately not "train…": the report must read the kind, not guess it from the name.
results::StudyStructure fixture_structure() {
  results::StudyStructure st;
  st.has_structure = true;
  st.groups = {{"A", "A"}, {"B", "B"}, {"C", "C"}};
  results::PhaseRecord tr;
  tr.phase = "training";
  tr.kind = "training";
  tr.sessions = 3;
  tr.session_duration = 2;
  tr.audio = true;
  tr.feature = "ovary_left";
  tr.thresholds = {{"ovary_left", 2.3, 2.5, 3.5}};
  results::PhaseRecord post = tr;
  post.phase = "post_training";
  post.kind = "post_training";
  post.sessions = 1;
  post.audio = false;
  post.visual_deformation = false;
  st.phases = {tr, post};
  return st;
}

// edit: changes the stored study JSON; with it, every session also stores the palpation task's
// two counts (palpations, sft_reached), as a run does.
FixtureDb make_fixture(bool finished = true, bool pool_sessions = false, bool structure = true,
                       const nlohmann::json& hypotheses = nullptr,
                       const std::function<void(nlohmann::json&)>& edit = {}) {
  FixtureDb f;
  f.dir = fs::temp_directory_path() / ("palplab_report_test_" + std::to_string(::getpid()));
  fs::remove_all(f.dir);
  fs::create_directories(f.dir);
  f.db = f.dir / "study.db";
  nlohmann::json sj = {
      {"palplab_study", 1},
      {"id", "fixture"},
      {"title", "Fixture study <with & special> characters"},
      {"description", "Three groups, three training sessions and a post-training test."},
      {"groups", {{{"id", "A"}}, {{"id", "B"}}, {{"id", "C"}}}},
      {"phases",
       {{{"id", "training"}, {"kind", "training"}, {"sessions", 3}},
        {{"id", "post_training"}, {"kind", "post_training"}, {"sessions", 1}}}},
      {"analyses",
       {{{"kind", "descriptives"},
         {"measure", "palpation_force"},
         {"phase", "training"},
         {"pooled", true}},
        {{"kind", "anova_oneway"}, {"measure", "palpation_force"}, {"phase", "post_training"}},
        {{"kind", "pairwise_t"},
         {"measure", "palpation_force"},
         {"phase", "post_training"},
         {"welch", true}},
        {{"kind", "anova_oneway"}, {"measure", "exploration_time"}, {"phase", "post_training"}}}}};
  if (pool_sessions) sj["analyses"][0]["pool_sessions"] = true;
  if (!hypotheses.is_null()) sj["hypotheses"] = hypotheses;
  if (edit) edit(sj);
  auto store = results::Store::create(f.db.string());
  results::StudyRecord st;
  st.study_id = "fixture";
  st.title = sj["title"];
  st.json = sj.dump(2);
  st.sha256 = "0123abcd";
  st.palplab_version = "0.1.0";
  st.git_commit = "test";
  st.seed = 42;
  st.started_at = "2026-11-21T10:00:00Z";
  std::vector<results::ParticipantRecord> ps;
  const char* groups[] = {"A", "B", "C"};
  for (int g = 0; g < 3; ++g)
    for (int i = 0; i < 5; ++i) {
      results::ParticipantRecord p;
      p.participant = std::string(groups[g]) + std::to_string(i + 1);
      p.group = groups[g];
      p.number = g * 5 + i;
      p.seed = 1000 + p.number;
      ps.push_back(p);
    }
  store.write_study(st, {{"A", "prototypes/A.json", "aa", "{}"}}, ps);
  if (structure) store.write_structure(fixture_structure());
  for (const auto& p : ps) {
    int g = p.number / 5, i = p.number % 5;
    for (int s = 0; s < 4; ++s) {
      results::SessionData d;
      d.session.participant = p.participant;
      d.session.ordinal = s;
      d.session.phase = s < 3 ? "training" : "post_training";
      d.session.phase_index = s < 3 ? s : 0;
      d.session.prototype = "A";
      d.session.duration = 2;
      d.session.steps = 2000;
      d.session.seed = 7;
      d.session.state_after = "{}";
      d.session.completed_at = "2026-11-21T10:10:00Z";
      double force = 2.0 + 0.4 * g + 0.1 * i + 0.05 * (3 - s) * (g + 1) + 0.03 * ((i * 7 + s) % 3);
      std::optional<double> fv = force;
      if (s == 3 && g == 2 && i == 4) fv.reset();  // not identified: undefined force
      // With edit: C5 identifies nothing in training, B1 not in its first session.
      if (edit && ((s < 3 && g == 2 && i == 4) || (s == 0 && g == 1 && i == 0))) fv.reset();
      if (s == 3 && fv) f.post[g].push_back(*fv);
      d.measures.push_back({"palpation_force", fv, "N"});
      d.measures.push_back({"exploration_time", 10.0 + g + 0.7 * i - s, "s"});
      if (edit) {
        d.measures.push_back({"palpations", 3.0 + (i + s) % 4, "1"});
        d.measures.push_back({"sft_reached", static_cast<double>((i + g) % 2), "1"});
      }
      if (s == 3) {
        d.samples.t0 = 0;
        d.samples.dt = 0.001;
        for (int k = 0; k < 2000; ++k) {
          double fz = force * std::max(0.0, std::sin(k * 0.005));
          d.samples.x.insert(d.samples.x.end(), {0.0, 0.0, 0.01});
          d.samples.F.insert(d.samples.F.end(), {0.0, 0.0, fz});
          d.samples.node.push_back(fz > 0 ? 3 : -1);
        }
      }
      store.write_session(d);
    }
  }
  if (finished) store.set_finished("2026-11-21T11:00:00Z");
  return f;
}

}  // namespace

TEST(Report, FixtureDatabaseHasEverySectionValidSvgAndNoNaN) {
  FixtureDb f = make_fixture();
  auto out = f.dir / "report";
  ReportFiles files = write_report(f.db.string(), out.string());
  EXPECT_EQ(files.analyses, 3);  // (force, post), (force, training pooled), (time, post)
  EXPECT_EQ(files.declared, 4);  // force post's anova and pairwise_t share one section
  std::string md = slurp(files.markdown), html = slurp(files.html);
  for (const char* section :
       {"## Study and provenance", "## Analysis: palpation_force — phase post_training",
        "## Analysis: palpation_force — phase training (participant means over all sessions)",
        "## Analysis: exploration_time — phase post_training", "### Descriptives",
        "### One-way ANOVA", "### Pairwise Welch t-tests", "### Post-hoc comparisons",
        "### Assumption checks and nonparametric tests", "## Learning curves",
        "## Example force traces", "Undefined values left out"})
    EXPECT_NE(md.find(section), std::string::npos) << section;
  // The APA line is the statistics of the same numbers.
  Anova a = oneway_anova({f.post[0], f.post[1], f.post[2]});
  std::string apa = apa_f(a.F, a.df_between, a.df_within, a.p);
  EXPECT_NE(md.find("Classical: " + apa), std::string::npos) << apa;
  // ... and its η²/ω² interval is the noncentral-F one of the same F and df.
  FEffectCi ci = f_effect_ci(a.F, a.df_between, a.df_within);
  ASSERT_TRUE(ci.defined);
  char ci_text[96];
  std::snprintf(ci_text, sizeof ci_text, "95 %% CI of the population η² (= ω²) [%.3f, %.3f]",
                ci.pve_low, ci.pve_high);
  EXPECT_NE(md.find(ci_text), std::string::npos) << ci_text;
  EXPECT_EQ(a.df_within, 11);  // 14 defined values (one undefined left out) - 3 groups
  EXPECT_NE(html.find("Fixture study &lt;with &amp; special&gt; characters"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  // Self-contained: the only URL is the SVG namespace name (not fetched by browsers).
  auto count_of = [&](const std::string& needle) {
    size_t n = 0;
    for (size_t p = html.find(needle); p != std::string::npos; p = html.find(needle, p + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count_of("http"), count_of("http://www.w3.org/2000/svg"));
  EXPECT_EQ(count_of(" src="), 0u);
  EXPECT_FALSE(has_nan_or_inf(md)) << "NaN/inf in report.md";
  EXPECT_FALSE(has_nan_or_inf(html)) << "NaN/inf in report.html";
  // Figures: box + participants per analysis, a learning curve per measure, the force traces.
  EXPECT_EQ(files.figures.size(), 3u * 2 + 2 + 1);
  for (const auto& fig : files.figures) {
    std::string svg = slurp(fig);
    EXPECT_EQ(xml_problem(svg), "") << fig;
    EXPECT_FALSE(has_nan_or_inf(svg)) << fig;
    EXPECT_NE(svg.find("<svg xmlns=\"http://www.w3.org/2000/svg\""), std::string::npos);
    EXPECT_NE(md.find("figures/" + fs::path(fig).filename().string()), std::string::npos);
  }
  // Inline SVGs of the HTML parse as XML too, one per figure.
  size_t count = 0;
  for (size_t p = html.find("<svg"); p != std::string::npos; p = html.find("<svg", p + 1)) {
    size_t e = html.find("</svg>", p);
    ASSERT_NE(e, std::string::npos);
    EXPECT_EQ(xml_problem(html.substr(p, e + 6 - p)), "");
    ++count;
  }
  EXPECT_EQ(count, files.figures.size());
  fs::remove_all(f.dir);
}

TEST(Report, BadDatabaseIsAnInputError) {
  auto dir = fs::temp_directory_path() / ("palplab_report_bad_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  EXPECT_THROW(write_report((dir / "missing.db").string(), (dir / "out").string()), InputError);
  std::ofstream(dir / "not.db") << "this is not a database";
  EXPECT_THROW(write_report((dir / "not.db").string(), (dir / "out").string()), InputError);
  fs::remove_all(dir);
}

TEST(Report, XmlCheckerRejectsBrokenSvg) {
  EXPECT_EQ(xml_problem("<svg a=\"1\"><g><rect/></g></svg>"), "");
  EXPECT_NE(xml_problem("<svg><g></svg>"), "");
  EXPECT_NE(xml_problem("<svg a=1></svg>"), "");
  EXPECT_NE(xml_problem("<svg>a & b</svg>"), "");
  EXPECT_TRUE(has_nan_or_inf("x=\"nan\""));
  EXPECT_FALSE(has_nan_or_inf("provenance, information"));
}

// An unfinished run (study.finished_at NULL) is flagged at the top of the report; a finished
// one is not. Force analyses carry an equivalence section (default margin ±7 % of the stored
// MPF, the force Weber fraction) whose verdicts are the three words, never "no difference",
// and the pairwise table states the unit of the mean difference.
TEST(Report, IncompleteWarningEquivalenceAndUnits) {
  for (bool finished : {false, true}) {
    FixtureDb f = make_fixture(finished);
    auto out = f.dir / "report";
    ReportFiles files = write_report(f.db.string(), out.string());
    std::string md = slurp(files.markdown);
    EXPECT_EQ(md.find("Warning: INCOMPLETE database") != std::string::npos, !finished);
    if (!finished) {
      // The warning comes before any result.
      EXPECT_LT(md.find("Warning: INCOMPLETE database"), md.find("## Study and provenance"));
    }
    ASSERT_NE(md.find("### Equivalence (TOST)"), std::string::npos);
    // The default margin: 7 % of the target force the database stores (MPF 2.5 N of the
    // feature region), named with its source.
    EXPECT_NE(md.find("Margins ±0.175 N (default: ±7 % (force Weber fraction) of the target "
                      "force, MPF = 2.5 N for region ovary_left in phase post_training, from the "
                      "study database)"),
              std::string::npos)
        << md;
    EXPECT_NE(md.find("mean diff (N)"), std::string::npos);
    const size_t eq = md.find("### Equivalence (TOST)");
    const std::string section = md.substr(eq, md.find("###", eq + 5) - eq);
    int verdicts = 0;
    for (const char* v : {"| equivalent |", "| different |", "| inconclusive |"})
      for (size_t p = section.find(v); p != std::string::npos; p = section.find(v, p + 1))
        ++verdicts;
    EXPECT_EQ(verdicts, 3) << section;  // one per pair of A, B, C
    EXPECT_EQ(md.find("no difference between"), std::string::npos);
    fs::remove_all(f.dir);
  }
}

// A pooled analysis is analysed on participant means by default (one value per participant,
// issue 11: pooled sessions gave F(2,117) where F(2,27) is right); pooling the sessions
// themselves happens only on explicit request and carries a pseudo-replication warning.
TEST(Report, PooledAnalysesUseParticipantMeans) {
  FixtureDb f = make_fixture();
  auto out = f.dir / "report";
  ReportFiles files = write_report(f.db.string(), out.string());
  std::string md = slurp(files.markdown);
  const size_t at = md.find("phase training (participant means over all sessions)");
  ASSERT_NE(at, std::string::npos);
  EXPECT_EQ(md.find("pseudo-replication"), std::string::npos);
  // Descriptives of the pooled section: n per group = participants of the group, not sessions.
  auto store = results::Store::open(f.db.string());
  std::map<std::string, int> per_group;
  for (const auto& p : store.read_participants()) per_group[p.group]++;
  const std::string section = md.substr(at, md.find("## Analysis", at + 10) - at);
  for (const auto& [g, n] : per_group)
    EXPECT_NE(section.find("| " + g + " | " + std::to_string(n) + " |"), std::string::npos)
        << g << " n=" << n << "\n"
        << section.substr(0, 800);
  fs::remove_all(f.dir);
}

// The study structure comes from the database: the phases table (kind, cues, thresholds) is in
// the provenance section, the learning curve covers exactly the phases of kind "training", and
// the force trace carries the stored ST / MPF / SFT as labelled lines.
TEST(Report, StructureFromTheDatabase) {
  FixtureDb f = make_fixture();
  ReportFiles files = write_report(f.db.string(), (f.dir / "report").string());
  std::string md = slurp(files.markdown);
  EXPECT_NE(md.find("| training | training | 3 | 2 | as prototype | as prototype | on | no | "
                    "ovary_left: 2.3 / 2.5 / 3.5 |"),
            std::string::npos)
      << md.substr(0, 2500);
  EXPECT_NE(md.find("| post_training | post_training | 1 | 2 | as prototype | off | off |"),
            std::string::npos);
  std::string traces;
  for (const auto& fig : files.figures)
    if (fig.find("force_traces.svg") != std::string::npos) traces = slurp(fig);
  ASSERT_FALSE(traces.empty());
  for (const char* line : {">ST 2.3 N<", ">MPF 2.5 N<", ">SFT 3.5 N<"})
    EXPECT_NE(traces.find(line), std::string::npos) << line;
  EXPECT_NE(md.find("Dashed lines: the phase's thresholds"), std::string::npos);
  fs::remove_all(f.dir);
}

// A database without the structure tables' contents is not guessed at by phase names: with
// no phase of kind training stored, there is no learning curve, whatever the phase is called.
// A study without analyses gets those of its measures, never of the counts every palpation
// session stores beside them (sft_reached was analysed although the study left it out).
TEST(Report, WithoutAnalysesTheStudysMeasuresAreAnalysed) {
  auto sections = [](const std::string& md) {
    std::vector<std::string> v;
    for (const char* m : {"palpation_force", "exploration_time", "palpations", "sft_reached"})
      if (md.find("## Analysis: " + std::string(m) + " —") != std::string::npos) v.push_back(m);
    return v;
  };
  using V = std::vector<std::string>;
  {
    FixtureDb f =
        make_fixture(true, false, true, nullptr, [](nlohmann::json& sj) { sj.erase("analyses"); });
    ReportFiles files = write_report(f.db.string(), (f.dir / "report").string());
    const std::string md = slurp(files.markdown);
    EXPECT_EQ(sections(md), (V{"palpation_force", "exploration_time"}));
    EXPECT_EQ(md.find("learning curve: sft_reached"), std::string::npos);
    fs::remove_all(f.dir);
  }
  {
    FixtureDb f = make_fixture(true, false, true, nullptr, [](nlohmann::json& sj) {
      sj.erase("analyses");
      sj["measures"] = {"palpation_force", "sft_reached"};
    });
    ReportFiles files = write_report(f.db.string(), (f.dir / "report").string());
    const std::string md = slurp(files.markdown);
    EXPECT_EQ(sections(md), (V{"palpation_force", "sft_reached"}));
    fs::remove_all(f.dir);
  }
}

// In a section of participant means n counts participants: the undefined values left out are
// said as sessions, and the participants left out (none of their sessions defined) apart.
TEST(Report, PooledUndefinedValuesAreSessionsAndParticipantsApart) {
  FixtureDb f = make_fixture(true, false, true, nullptr, [](nlohmann::json& sj) {
    sj["analyses"] = {{{"kind", "descriptives"},
                       {"measure", "palpation_force"},
                       {"phase", "training"},
                       {"pooled", true}}};
  });
  ReportFiles files = write_report(f.db.string(), (f.dir / "report").string());
  const std::string md = slurp(files.markdown);
  EXPECT_NE(md.find("Undefined session values left out of the participant means (e.g. force when "
                    "the feature was not identified), sessions per group: A 0, B 1, C 3. "
                    "Participants with no defined session, left out of n: A 0, B 0, C 1."),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| C | 4 |"), std::string::npos) << md;
  fs::remove_all(f.dir);
}

TEST(Report, NoNameGuessingOfTrainingPhases) {
  FixtureDb f = make_fixture(true, false, /*structure=*/false);
  {
    auto store = results::Store::open(f.db.string());
    results::StudyStructure st = fixture_structure();
    st.phases[0].kind = "other";  // called "training", declared other
    store.write_structure(st);
  }
  ReportFiles files = write_report(f.db.string(), (f.dir / "report").string());
  std::string md = slurp(files.markdown);
  EXPECT_NE(md.find("The study declares no phase of kind \"training\"."), std::string::npos);
  for (const auto& fig : files.figures) EXPECT_EQ(fig.find("learning_"), std::string::npos) << fig;
  fs::remove_all(f.dir);
}

// A schema-1 database (before the structure tables) is refused with a message that says why
// and what to do, never reported from guessed phase kinds.
TEST(Report, SchemaOneDatabaseIsRefusedClearly) {
  FixtureDb f = make_fixture();
  { auto store = results::Store::open(f.db.string()); }
  // Downgrade the file to what palplab wrote before: version 1, no structure tables.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(f.db.string().c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "DROP TABLE thresholds; DROP TABLE phases; DROP TABLE study_groups; "
                         "UPDATE meta SET value = '1' WHERE key = 'schema_version'; "
                         "PRAGMA user_version = 1;",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  try {
    write_report(f.db.string(), (f.dir / "report").string());
    ADD_FAILURE() << "a schema-1 database was reported";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("schema version 1 does not store the study structure"), std::string::npos)
        << what;
    EXPECT_NE(what.find("re-run the study"), std::string::npos) << what;
  }
  fs::remove_all(f.dir);
}

// Without a stored MPF for the phase, the default margin falls back to 7 % of the grand mean,
// and says so; a margin the study declares wins over both.
TEST(Report, EquivalenceMarginWithoutStoredMpf) {
  FixtureDb f = make_fixture();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(f.db.string().c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "DELETE FROM thresholds WHERE phase = 'post_training';", nullptr,
                         nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  ReportFiles files = write_report(f.db.string(), (f.dir / "report").string());
  const std::string md = slurp(files.markdown);
  long double sum = 0;
  int n = 0;
  for (const auto& g : f.post)
    for (double v : g) sum += v, ++n;
  char want[160];
  std::snprintf(want, sizeof want,
                "Margins ±%.4g N (default: ±7 %% (force Weber fraction) of the grand mean, as the "
                "database stores no MPF for phase post_training)",
                0.07 * static_cast<double>(sum / n));
  EXPECT_NE(md.find(want), std::string::npos) << want << "\n" << md;
  fs::remove_all(f.dir);
}

// Proportions get Wilson intervals inside [0, 1]; neighbouring groups' error bars are offset.
TEST(Report, WilsonIntervalAndDodgedErrorBars) {
  // Wilson (1927) 95 % for 0/10, 10/10 and 3/10: the closed form (p + z²/2n ± z·sqrt(p(1-p)/n
  // + z²/4n²)) / (1 + z²/n) evaluated separately, = R's prop.test(k, n, correct = FALSE).
  auto w0 = wilson_interval(0, 10), w10 = wilson_interval(10, 10), w3 = wilson_interval(3, 10);
  EXPECT_EQ(w0.low, 0.0);
  EXPECT_NEAR(w0.high, 0.2775328, 1e-6);
  EXPECT_NEAR(w10.low, 0.7224672, 1e-6);
  EXPECT_EQ(w10.high, 1.0);
  EXPECT_NEAR(w3.low, 0.1077913, 1e-6);
  EXPECT_NEAR(w3.high, 0.6032219, 1e-6);
  // Two series at the same x: their error bars are drawn at different x positions.
  Series a, b;
  a.x = b.x = {1, 2};
  a.y = {1, 2};
  b.y = {1.1, 2.1};
  a.err = b.err = {0.5, 0.5};
  b.colour = 1;
  std::string svg = svg_line_plot({a, b}, "t", "x", "y");
  std::regex bar("class=\"errorbar\" x1=\"([0-9.]+)\"");
  std::set<std::string> xs;
  size_t bars = 0;
  for (std::sregex_iterator it(svg.begin(), svg.end(), bar), end; it != end; ++it, ++bars)
    xs.insert((*it)[1]);
  EXPECT_EQ(bars, 4u);
  EXPECT_EQ(xs.size(), 4u) << svg;
}

// Declared hypotheses run first, labelled confirmatory, with their own α and correction; the
// t statistics are those of the two samples (checked against welch_t on the same values); the
// rest of the report is labelled exploratory. Without hypotheses there is no such label.
TEST(Report, ConfirmatoryHypothesesFirst) {
  nlohmann::json hyps =
      nlohmann::json::array({{{"id", "H1"},
                              {"statement", "C presses harder than A"},
                              {"measure", "palpation_force"},
                              {"phase", "post_training"},
                              {"test", "welch_t"},
                              {"pairs", nlohmann::json::array({nlohmann::json::array({"C", "A"})})},
                              {"alpha", 0.01}},
                             {{"id", "H2"},
                              {"measure", "palpation_force"},
                              {"phase", "post_training"},
                              {"test", "tost"},
                              {"margins", 5.0},
                              {"correction", "bonferroni"}}});
  FixtureDb f = make_fixture(true, false, true, hyps);
  ReportFiles files = write_report(f.db.string(), (f.dir / "report").string());
  std::string md = slurp(files.markdown);
  const size_t conf = md.find("## Confirmatory analyses (declared hypotheses)");
  const size_t expl = md.find("## Exploratory analyses");
  ASSERT_NE(conf, std::string::npos);
  ASSERT_NE(expl, std::string::npos);
  EXPECT_LT(conf, expl);
  EXPECT_LT(expl, md.find("## Analysis: "));
  EXPECT_NE(md.find("### H1: C presses harder than A"), std::string::npos);
  TTest t = welch_t(f.post[2], f.post[0]);  // C – A, as declared
  char row[160];
  std::snprintf(row, sizeof row, "| C – A | %.4g | %.3f | %.2f |", t.mean_diff, t.t, t.df);
  EXPECT_NE(md.find(row), std::string::npos) << row << "\n" << md.substr(conf, 1500);
  EXPECT_NE(md.find("α = 0.01"), std::string::npos);
  // H2: every pair (3), Bonferroni; a ±5 N margin around differences of < 1 N is equivalent.
  const size_t h2 = md.find("### H2");
  ASSERT_NE(h2, std::string::npos);
  const std::string sec = md.substr(h2, expl - h2);
  EXPECT_NE(sec.find("p (bonferroni)"), std::string::npos);
  int eq = 0;
  for (size_t p = sec.find("| equivalent |"); p != std::string::npos;
       p = sec.find("| equivalent |", p + 1))
    ++eq;
  EXPECT_EQ(eq, 3) << sec;
  fs::remove_all(f.dir);
  FixtureDb g = make_fixture();
  std::string md2 = slurp(write_report(g.db.string(), (g.dir / "report").string()).markdown);
  EXPECT_EQ(md2.find("Confirmatory"), std::string::npos);
  EXPECT_EQ(md2.find("Exploratory analyses"), std::string::npos);
  fs::remove_all(g.dir);
}

// The report printed t and F with its own "%.3f" into a 64-byte buffer: a t of 1.4e200 came out
// as 63 of its digits. It now formats them as the stats APA text does (stat_text / f_text):
// exploration_time of the post-training test set to 1e100 in group A (constant) and to
// 1e-100 · (1..5) in B, 2e-100 · (1..5) in C gives t(A–B) = 1.41e+200, an F beyond a double
// (4.00e+399, from log F) and a Holm p built from the 1e-300 bound (< 3e-300).
TEST(Report, HugeStatisticsInScientificNotation) {
  FixtureDb f = make_fixture();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(f.db.string().c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "UPDATE measures SET value = (SELECT CASE substr(s.participant, 1, 1) "
                         "WHEN 'A' THEN 1e100 WHEN 'B' THEN 1e-100 * substr(s.participant, 2) "
                         "ELSE 2e-100 * substr(s.participant, 2) END FROM sessions s WHERE "
                         "s.session = measures.session) WHERE name = 'exploration_time' AND "
                         "session IN (SELECT session FROM sessions WHERE phase = 'post_training');",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  ReportFiles files = write_report(f.db.string(), (f.dir / "report").string());
  const std::string md = slurp(files.markdown);
  const size_t at = md.find("## Analysis: exploration_time — phase post_training");
  ASSERT_NE(at, std::string::npos) << md;
  const std::string section = md.substr(at, md.find("\n## ", at + 5) - at);
  // No run of digits from a fixed-point printing of a huge number.
  EXPECT_FALSE(std::regex_search(section, std::regex("[0-9]{20}"))) << section;
  EXPECT_NE(section.find("| 1.414e+200 |"), std::string::npos) << section;
  EXPECT_NE(section.find("t(4) = 1.41e+200, p < .001 (Holm p < .001)"), std::string::npos)
      << section;
  EXPECT_TRUE(std::regex_search(section, std::regex(R"(\| [1-9]\.[0-9]{3}e\+399 \| < 1e-300 \|)")))
      << section;
  EXPECT_TRUE(std::regex_search(
      section, std::regex(R"(Classical: F\(2, 12\) = [1-9]\.[0-9]{2}e\+399, p < \.001)")))
      << section;
  EXPECT_NE(section.find("| < 1e-300 | < 3e-300 |"), std::string::npos) << section;
  fs::remove_all(f.dir);
}
