// $.phases[i].instructions (what `run --human` shows a person before each session): one text for
// every session of the phase or one per session; bad values are located problems of the shared
// study validator; runner's session_instructions() picks the right text or a default.
#include <gtest/gtest.h>

#include "common/input_error.hpp"
#include "protocols/plan.hpp"
#include "protocols/runner.hpp"
#include "protocols/study.hpp"
#include "study_fixture.hpp"

using namespace palplab;
using namespace palplab::protocols;

namespace {

std::string study(const std::string& training_instructions, const std::string& test_instructions) {
  return R"({
  "palplab_study": 1, "id": "t", "title": "test", "seed": 7,
  "task": {"feature": "ovary_left",
           "thresholds": {"ovary_left": {"ST": 2.3, "MPF": 2.5, "SFT": 3.5}}},
  "groups": [{"id": "A", "prototype": "A", "size": 1}],
  "phases": [
    {"id": "training", "kind": "training", "sessions": 2, "session_duration": 60,
     "gap": {"minutes": 10})" +
         training_instructions + R"(},
    {"id": "test", "kind": "post_training", "session_duration": 30,
     "start": {"after_previous": {"minutes": 10}})" +
         test_instructions + R"(}
  ]
})";
}

using fixture::problems_of;

}  // namespace

TEST(StudyInstructions, OnePerPhaseOrOnePerSessionElseTheDefault) {
  const Study s = load_study(
      fixture::study_in_dir(
          "instr_ok", study(R"(, "instructions": ["First: explore.", "Second: find it."])", "")),
      fixture::tract_inspector());
  ASSERT_EQ(s.phases[0].instructions.size(), 2u);
  const Plan plan = make_plan(s);
  const auto& ss = plan.participants.at(0).sessions;
  ASSERT_EQ(ss.size(), 3u);
  EXPECT_EQ(session_instructions(s, ss[0]), "First: explore.");
  EXPECT_EQ(session_instructions(s, ss[1]), "Second: find it.");
  // No instructions: a default naming the feature and the session length.
  EXPECT_EQ(session_instructions(s, ss[2]),
            "Palpate the model and find the ovary_left. The session lasts 30 s.");

  const Study one =
      load_study(fixture::study_in_dir("instr_one",
                                       study(R"(, "instructions": "Every session: find it.")", "")),
                 fixture::tract_inspector());
  const Plan p1 = make_plan(one);
  EXPECT_EQ(session_instructions(one, p1.participants[0].sessions[0]), "Every session: find it.");
  EXPECT_EQ(session_instructions(one, p1.participants[0].sessions[1]), "Every session: find it.");
}

TEST(StudyInstructions, BadValuesAreLocatedProblemsAllAtOnce) {
  auto ps = problems_of("instr_bad",
                        study(R"(, "instructions": ["only one"])", R"(, "instructions": 3)"));
  ASSERT_EQ(ps.size(), 2u) << InputError(ps).what();
  EXPECT_EQ(ps[0].where.json_path, "$.phases[0].instructions");
  EXPECT_NE(ps[0].what.find("expected one text per session (2), got 1"), std::string::npos)
      << ps[0].format();
  EXPECT_EQ(ps[1].where.json_path, "$.phases[1].instructions");
  EXPECT_NE(ps[1].what.find("expected a text (string), got an integer"), std::string::npos)
      << ps[1].format();
  EXPECT_GT(ps[1].where.line, 0);

  ps = problems_of("instr_blank", study(R"(, "instructions": ["ok", "  "])", ""));
  ASSERT_EQ(ps.size(), 1u) << InputError(ps).what();
  EXPECT_EQ(ps[0].where.json_path, "$.phases[0].instructions[1]");
  EXPECT_NE(ps[0].what.find("expected a non-empty text"), std::string::npos);

  ps = problems_of("instr_long",
                   study(", \"instructions\": \"" + std::string(4001, 'x') + "\"", ""));
  ASSERT_EQ(ps.size(), 1u) << InputError(ps).what();
  EXPECT_NE(ps[0].what.find("at most 4000 characters, got 4001"), std::string::npos);

  ps = problems_of("instr_typo", study(R"(, "instruction": "x")", ""));
  ASSERT_EQ(ps.size(), 1u) << InputError(ps).what();
  EXPECT_NE(ps[0].what.find("did you mean \"instructions\""), std::string::npos) << ps[0].format();
}
