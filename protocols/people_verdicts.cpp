#include "protocols/people_verdicts.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>

#include "common/input_error.hpp"
#include "common/seed.hpp"
#include "protocols/rng.hpp"

namespace palplab::protocols {

namespace {
// The number of tests with a verdict (a p) in `v`.
std::size_t verdicts_of(const PeopleVerdicts& v) {
  return static_cast<std::size_t>(std::count_if(
      v.tests.begin(), v.tests.end(), [](const TestOutcome& t) { return std::isfinite(t.p); }));
}
}  // namespace

PeopleVerdicts people_verdicts(const Study& study, const std::vector<HumanCell>& cells,
                               double alpha, const std::vector<int>& sizes, long resamples) {
  if (cells.empty()) throw InputError("no human data");
  PeopleVerdicts out;
  out.file = cells.front().file;
  std::map<std::string, std::vector<SimValue>> values_of;   // participant -> its values
  std::map<std::string, std::vector<std::string>> members;  // group -> participants, file order
  std::vector<SimValue> all;
  for (const auto& c : cells) {
    // As `calibrate`: every row a cell the study simulates (a misspelt phase or a session the
    // study does not have would otherwise leave the tests silently or replace their values).
    check_human_measure(study, cells, c);
    check_human_cell(study, c);
    auto add = [&](const std::string& who, std::optional<double> v) {
      SimValue s{who, c.group, c.phase, c.session, c.measure, v};
      auto& mine = values_of[who];
      if (mine.empty()) members[c.group].push_back(who);
      mine.push_back(s);
      all.push_back(s);
    };
    for (std::size_t i = 0; i < c.values.size(); ++i) add(c.participants[i], c.values[i]);
    for (const auto& who : c.undefined_participants) add(who, std::nullopt);
  }
  // Every tested cell must be testable in the people's data, as in the replicates.
  for (std::size_t i = 0; i < study.analyses.size(); ++i) {
    const Analysis& a = study.analyses[i];
    if (a.kind != "anova_oneway" && a.kind != "pairwise_t") continue;
    const std::string where = "the study's $.analyses[" + std::to_string(i) + "] (" + a.kind +
                              " of " + a.measure + " in phase " + a.phase + ")";
    int last = 0;
    for (const auto& c : cells)
      if (c.phase == a.phase && c.measure == a.measure) last = std::max(last, c.session);
    if (last == 0)
      throw InputError(SourceLocation{out.file},
                       "no values of " + a.measure + " in phase " + a.phase + ", which " + where +
                           " tests (expected rows with that measure and phase)");
    for (const auto& g : study.groups) {
      int n = 0, line = 0;
      for (const auto& c : cells)
        if (c.group == g.id && c.phase == a.phase && c.measure == a.measure &&
            (a.pooled || c.session == last))
          n += c.n, line = line ? line : c.line;
      if (n < 2)
        throw InputError(SourceLocation{out.file, line, line ? 1 : 0},
                         "group " + g.id + " has " + std::to_string(n) + " value" +
                             (n == 1 ? "" : "s") + " of " + a.measure + " in phase " + a.phase +
                             (a.pooled ? "" : " session " + std::to_string(last)) + "; " + where +
                             " needs at least 2 per group");
    }
  }
  // The cells no test uses (another phase, an earlier session of an unpooled test, a measure
  // never tested): said, as `calibrate` lists what it does not fit (review 2026-12-07).
  for (const auto& c : cells) {
    bool used = false;
    for (const Analysis& a : study.analyses) {
      if ((a.kind != "anova_oneway" && a.kind != "pairwise_t") || a.phase != c.phase ||
          a.measure != c.measure)
        continue;
      int last = 0;
      for (const auto& o : cells)
        if (o.phase == a.phase && o.measure == a.measure) last = std::max(last, o.session);
      used = used || a.pooled || c.session == last;
    }
    if (!used)
      out.untested.push_back(c.measure + " of group " + c.group + " in phase " + c.phase +
                             " session " + std::to_string(c.session) + " (line " +
                             std::to_string(c.line) + ")");
  }
  out.tests = run_declared_analyses(study, all);
  out.groups = tested_group_descriptives(study, all);
  for (const auto& [g, who] : members) out.n[g] = static_cast<int>(who.size());
  // A test undefined on the people's data (no variance in any group, say) has no verdict to
  // compare: it is left out of every agreement (power.hpp). With none defined there is nothing.
  if (verdicts_of(out) == 0)
    throw InputError(SourceLocation{out.file},
                     "none of the study's tests is defined on the people's data (every group's "
                     "values without variance?): there is no verdict to compare");

  // A right model at each n: a people's study of the same size and a replicate of n per group,
  // drawn independently from the people's participants (with replacement within groups: the
  // truth taken as their distribution), the replicate compared with the drawn people's study.
  out.resamples = resamples;
  out.seed = derive_seed(study.seed, "people_resample");
  std::vector<SimValue> people_draw, model_draw;
  // `count` participants of each group drawn into `drawn`.
  auto draw = [&](Rng& rng, std::vector<SimValue>& drawn, int count) {
    drawn.clear();
    for (const auto& g : study.groups) {
      const auto& who = members[g.id];
      const int k = count > 0 ? count : static_cast<int>(who.size());
      for (int j = 0; j < k; ++j)
        for (SimValue v : values_of[who[rng.below(who.size())]]) {
          v.participant = g.id + "#" + std::to_string(j);  // each draw a participant of its own
          drawn.push_back(std::move(v));
        }
    }
  };
  for (int n : sizes) {
    Rng rng(derive_seed(out.seed, static_cast<std::uint64_t>(n)));  // n's draws alone
    RightModel& m = out.right[n];
    std::vector<long> agreeing(verdicts_of(out) + 1, 0);  // draws by the number agreeing
    for (long r = 0; r < resamples; ++r) {
      draw(rng, people_draw, 0);
      draw(rng, model_draw, n);
      PeopleVerdicts drawn_people;
      drawn_people.tests = run_declared_analyses(study, people_draw);
      drawn_people.groups = tested_group_descriptives(study, people_draw);
      const Comparison c =
          compare_with_people(drawn_people, run_declared_analyses(study, model_draw),
                              tested_group_descriptives(study, model_draw), alpha);
      for (const auto& id : c.agree) ++m.agree[id];
      for (const auto& cell : c.same_order) ++m.same_order[cell];
      for (const auto& key : c.inside) ++m.inside[key];
      ++agreeing[std::min(c.agree.size(), agreeing.size() - 1)];
      m.all_agree += c.all_agree;
      m.all_orders += c.all_orders;
      m.all_inside += c.all_inside;
      m.pattern += c.pattern();
    }
    m.median_agreeing = median_of_counts(agreeing);
  }
  return out;
}

std::vector<std::string> people_warnings(const PeopleVerdicts& people) {
  std::vector<std::string> out;
  for (const auto& t : people.tests)
    if (!std::isfinite(t.p))
      out.push_back("the test \"" + t.id +
                    "\" is undefined on the people's data (a group without variance?): it has no "
                    "verdict and is not compared");
  if (!people.untested.empty()) {
    std::string list;
    for (std::size_t i = 0; i < people.untested.size() && i < 5; ++i)
      list += (i ? "; " : "") + people.untested[i];
    if (people.untested.size() > 5)
      list += "; … " + std::to_string(people.untested.size()) + " in all";
    out.push_back("rows that no test of the study's $.analyses uses are not compared: " + list);
  }
  std::set<std::string> cells;
  for (const auto& g : people.groups)
    if (cells.insert(g.cell).second && compared_order(people.groups, g.cell).empty())
      out.push_back("the people's group means of " + g.cell + " tie (" +
                    order_of_means(people.groups, g.cell) +
                    "): there is no order to reach, and it is not compared");
  return out;
}

}  // namespace palplab::protocols
