#include "analysis/recheck.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <regex>

#include "analysis/anova.hpp"
#include "analysis/grouped.hpp"
#include "analysis/summary.hpp"
#include "analysis/two_sample.hpp"
#include "common/input_error.hpp"
#include "common/json_check.hpp"
#include "common/json_locate.hpp"

namespace palplab::analysis {

namespace {

int decimals_of(const std::string& number) {
  size_t dot = number.find('.');
  return dot == std::string::npos ? 0 : static_cast<int>(number.size() - dot - 1);
}

// ".001" and "0.001" both mean 0.001 (APA omits the leading zero of p). The text matched the
// APA pattern (digits and a point): only a number of more than 308 digits overflows.
double to_number(const std::string& s, const std::string& text, const SourceLocation& where) {
  const double x = std::strtod(s.c_str(), nullptr);
  if (!std::isfinite(x))
    throw InputError(where, "the number " + s.substr(0, 20) +
                                "... is beyond the range of a double, in \"" + text + "\"");
  return x;
}

constexpr const char* kNotRecomputable = "not recomputable";
// How far a rounding difference may be, as a share of the value (classify_number), and the level
// whose verdict a printed p may not reverse (classify_p).
constexpr double kRoundingShare = 0.05;
constexpr double kVerdictAlpha = 0.05;

int rank(const std::string& v) {
  return v == "consistent" ? 0 : v == "rounding" ? 1 : v == kNotRecomputable ? 2 : 3;
}

// "line 8" / "lines 3, 5"
std::string lines_text(const std::vector<int>& lines) {
  std::string s = lines.size() == 1 ? "line " : "lines ";
  for (size_t i = 0; i < lines.size(); ++i) s += (i ? ", " : "") + std::to_string(lines[i]);
  return s;
}

// "group 'D' has 1 value (line 8)"
std::string too_few(const GroupedData& d, size_t g) {
  return "group '" + d.names[g] + "' has " + std::to_string(d.values[g].size()) + " value" +
         (d.values[g].size() == 1 ? "" : "s") + " (" + lines_text(d.lines[g]) + ")";
}

bool has_column(const CsvTable& t, const std::string& name) {
  return std::find(t.header.begin(), t.header.end(), name) != t.header.end();
}

std::string no_column(const CsvTable& t, const std::string& name) {
  return "no column '" + shown_text(name) + "' in " + t.file +
         "; its columns are: " + shown_columns(t.header, "'") + separator_hint(t.header);
}

}  // namespace

ApaStatistic parse_apa(const std::string& text, const SourceLocation& where) {
  // F(2, 27) = 18.65, p < .001    t(17.92) = -3.02, p = .056   (spaces optional, "−" allowed)
  std::string t = std::regex_replace(text, std::regex("\xE2\x88\x92"), "-");
  static const std::regex re(
      R"(^\s*([Ft])\s*\(\s*([0-9]+(?:\.[0-9]+)?)\s*(?:,\s*([0-9]+(?:\.[0-9]+)?)\s*)?\)\s*=\s*(-?[0-9]*\.?[0-9]+)\s*,\s*p\s*([<>=])\s*([0-9]*\.[0-9]+|[01])\s*$)");
  std::smatch m;
  if (!std::regex_match(t, m, re))
    throw InputError(where,
                     "expected APA text such as \"F(2, 27) = 18.65, p < .001\" or "
                     "\"t(17.9) = -3.02, p = .056\", got \"" +
                         text + "\"");
  ApaStatistic a;
  a.kind = m[1].str()[0];
  a.df1 = to_number(m[2], text, where);
  a.df1_decimals = decimals_of(m[2]);
  if (a.kind == 'F') {
    if (!m[3].matched)
      throw InputError(where, "an F needs two df: F(df1, df2), got \"" + text + "\"");
    a.df2 = to_number(m[3], text, where);
    a.df2_decimals = decimals_of(m[3]);
  } else if (m[3].matched) {
    throw InputError(where, "a t has one df: t(df), got \"" + text + "\"");
  }
  a.value = to_number(m[4], text, where);
  a.value_decimals = decimals_of(m[4]);
  a.p_relation = m[5];
  a.p = to_number(m[6], text, where);
  a.p_decimals = decimals_of(m[6]);
  // Values no test can print are malformed input, not an inconsistency of the data.
  const std::string got = ", got \"" + text + "\"";
  if (!(a.df1 > 0) || (a.kind == 'F' && !(a.df2 > 0)))
    throw InputError(where, "degrees of freedom must be > 0" + got);
  if (a.kind == 'F' && a.value < 0)
    throw InputError(where, "an F statistic is never negative" + got);
  if (a.p > 1) throw InputError(where, "a p-value is at most 1" + got);
  // "p = 0" or "p = 1" says only that p is below or above .5 (and no p is 0): nothing to check.
  if (a.p_relation == "=" && a.p_decimals == 0)
    throw InputError(where,
                     "a p-value printed without decimals (p = 0 or p = 1) says nothing to "
                     "check: give it with its decimals (p = .056) or as a bound "
                     "(p < .001)" +
                         got);
  if (a.p_relation == "<" && a.p == 0) throw InputError(where, "no p-value is below 0" + got);
  if (a.p_relation == ">" && a.p == 1) throw InputError(where, "no p-value is above 1" + got);
  return a;
}

std::string classify_number(double reported, int decimals, double recomputed) {
  if (!std::isfinite(recomputed)) return kNotRecomputable;
  const double unit = std::pow(10.0, -decimals);
  // Rounded half away from zero, as printed; a small relative slack absorbs the binary
  // representation of values exactly on a half.
  const double rounded = std::round(recomputed / unit) * unit;
  const double slack = 1e-9 * unit;
  if (std::fabs(rounded - reported) <= slack) return "consistent";
  // A rounding difference: a value cut instead of rounded, or recomputed from data the CSV holds
  // rounded — its digits cut, or off by at most one unit of the last printed digit and by at
  // most kRoundingShare of the value. With few printed decimals one unit is most of the value:
  // "F = 12" for 11.05 and "p = .1" for .0016 were graded rounding (review 2026-12-07).
  // Cut: the printed digits are the recomputed value's, truncated (MINITAB's Welch df, "p = .02"
  // for .02506 when the CSV holds the data rounded and the unrounded data gave .024997).
  const double cut = std::trunc(recomputed / unit + (recomputed >= 0 ? 1e-9 : -1e-9)) * unit;
  if (std::fabs(cut - reported) <= slack) return "rounding";
  const double diff = std::fabs(recomputed - reported);
  if (diff <= unit + slack &&
      diff <= kRoundingShare * std::max(std::fabs(reported), std::fabs(recomputed)))
    return "rounding";
  return "inconsistent";
}

// A df that is a count by definition (k - 1, N - k, n1 + n2 - 2): it is printed exactly or it
// is wrong (a group too many, N - k off by one: the slip the check exists to catch), never a
// rounding difference.
std::string classify_count(double reported, double recomputed) {
  if (!std::isfinite(recomputed)) return kNotRecomputable;
  return reported == recomputed ? "consistent" : "inconsistent";
}

std::string classify_p(const std::string& relation, double reported, int decimals,
                       double recomputed) {
  if (!std::isfinite(recomputed)) return kNotRecomputable;
  // A bound is a claim ("p < .05" with p = .051 claims significance that is not there): it
  // holds or it is inconsistent; no rounding slack.
  if (relation == "<") return recomputed < reported ? "consistent" : "inconsistent";
  if (relation == ">") return recomputed > reported ? "consistent" : "inconsistent";
  // A printed p that is not the recomputed one rounded, on the other side of .05, claims the
  // opposite verdict: never a rounding (statcheck's gross inconsistency).
  const std::string v = classify_number(reported, decimals, recomputed);
  if (v == "rounding" && (recomputed < kVerdictAlpha) != (reported < kVerdictAlpha))
    return "inconsistent";
  return v;
}

std::vector<RecheckItem> recheck(const nlohmann::json& rep, const CsvTable& table,
                                 const std::string& file, std::string_view text, bool skip_empty) {
  // Errors at a JSON path, with the line:column when the text is at hand (located on the first
  // error only).
  auto at = [&](const std::string& path, bool at_key = false) {
    if (text.empty()) return SourceLocation{file, 0, 0, -1, path};
    return json::JsonLocator(text).locate(file, path, at_key);
  };
  if (!rep.is_object() || !rep.contains("statistics") || !rep["statistics"].is_array())
    throw InputError(at("$.statistics"), "expected an object with an array \"statistics\"");
  if (rep["statistics"].empty())
    throw InputError(at("$.statistics"),
                     "no statistics: nothing to check (expected at least one {\"text\": ...})");
  auto str = [&](const nlohmann::json& j, const char* key, const std::string& path,
                 const std::string& def) -> std::string {
    const std::string kp = json::path_key(path, key);
    if (!j.contains(key)) {
      if (!def.empty()) return def;
      throw InputError(at(kp), "missing key");
    }
    if (!j[key].is_string()) throw InputError(at(kp), "expected a string");
    return j[key];
  };
  // A CSV of the header only: nothing to recompute from (it said "column 'phase' holds "
  // with nothing after it; review 2026-12-07).
  if (table.rows.empty())
    throw InputError(SourceLocation{table.file, 1},
                     "no data rows (the header only): nothing to recompute the statistics from");
  const std::string def_value = rep.contains("value") ? str(rep, "value", "$", "") : "";
  const std::string def_group = rep.contains("group") ? str(rep, "group", "$", "") : "";
  std::vector<RecheckItem> out;
  std::map<std::string, size_t> ids;  // id -> index of the statistic that has it
  // Every statistic is checked, and the problems of all of them are said at once (one per
  // statistic, every unknown key): a paper's list is fixed in one pass, not one run per error.
  std::vector<Problem> problems;
  const auto report = [&](const InputError& e) {
    for (const auto& p : e.problems())
      if (std::none_of(problems.begin(), problems.end(), [&](const Problem& q) {
            return q.format_raw() == p.format_raw();  // "$.value" names no column: said once
          }))
        problems.push_back(p);
  };
  {
    json::Checker keys(file, text);
    keys.keys(rep, "$", {"comment", "value", "group", "statistics"});
    problems = keys.problems();
  }
  for (size_t i = 0; i < rep["statistics"].size(); ++i) {
    try {
      const auto& s = rep["statistics"][i];
      const std::string path = json::path_index("$.statistics", i);
      if (!s.is_object()) throw InputError(at(path), "expected an object");
      json::Checker keys(file, text);
      keys.keys(s, path, {"id", "text", "test", "value", "group", "where", "pair", "comment"});
      keys.throw_if_any();
      RecheckItem item;
      item.id = s.contains("id") ? str(s, "id", path, "") : std::to_string(i + 1);
      if (auto [first, fresh] = ids.emplace(item.id, i); !fresh)
        throw InputError(at(path + ".id"), "duplicate id \"" + item.id + "\" (also $.statistics[" +
                                               std::to_string(first->second) +
                                               "]); each statistic needs its own id");
      item.text = str(s, "text", path, "");
      ApaStatistic a;
      try {
        a = parse_apa(item.text, SourceLocation{file, 0, 0, -1, path + ".text"});
      } catch (const InputError& e) {
        throw InputError(at(path + ".text"), e.problems().front().what);
      }
      item.test =
          s.contains("test") ? str(s, "test", path, "") : (a.kind == 'F' ? "anova" : "welch_t");
      const std::string value = str(s, "value", path, def_value);
      const std::string group = str(s, "group", path, def_group);
      // The columns are checked here, at the key that names them (the CSV reader's own message
      // has no JSON path).
      for (const auto& [key, name] : {std::pair{"value", value}, std::pair{"group", group}})
        if (!has_column(table, name))
          throw InputError(at(json::path_key(s.contains(key) ? path : "$", key)),
                           no_column(table, name));
      // One column as both values and labels makes every value its own group's label: refused,
      // as `palplab stats` refuses --value and --group naming the same column.
      if (value == group)
        throw InputError(at(json::path_key(s.contains("group") ? path : "$", "group")),
                         "\"value\" and \"group\" name the same column ('" + shown_text(group) +
                             "'); \"group\" takes the column of group labels");
      std::vector<WhereFilter> where;
      const std::string where_path = json::path_key(path, "where");
      if (s.contains("where")) {
        if (!s["where"].is_array())
          throw InputError(at(where_path), "expected an array of \"COL=VALUE\" strings");
        for (size_t k = 0; k < s["where"].size(); ++k) {
          const auto& w = s["where"][k];
          const std::string wp = json::path_index(where_path, k);
          const bool text = w.is_string() && w.get<std::string>().find('=') != std::string::npos;
          const WhereFilter f = text ? parse_where(w) : WhereFilter{};
          if (f.column.empty())  // not a string, no '=', or nothing before it
            throw InputError(at(wp), "expected a \"COL=VALUE\" string, got " + w.dump());
          if (!has_column(table, f.column)) throw InputError(at(wp), no_column(table, f.column));
          where.push_back(f);
        }
        // group_table would say "no data rows match the --where filters": a flag recheck does
        // not have.
        if (!where.empty() && filter_rows(table, where).empty())
          throw InputError(at(where_path), no_row_matches(table, where, s["where"].dump()));
      }
      const bool f_test = item.test == "anova" || item.test == "welch_anova";
      const bool t_test = item.test == "welch_t" || item.test == "student_t";
      if (!f_test && !t_test)
        throw InputError(
            at(path + ".test"),
            "expected anova, welch_anova, welch_t or student_t, got \"" + item.test + "\"");
      if ((a.kind == 'F') != f_test)
        throw InputError(at(path + ".test"),
                         "test \"" + item.test + "\" does not print as " + std::string(1, a.kind));
      if (f_test && s.contains("pair"))
        throw InputError(at(path + ".pair", true), "\"pair\" applies to t-tests only; an F test (" +
                                                       item.test +
                                                       ") compares all groups of column '" + group +
                                                       "' (select groups with \"where\")");
      // Every group of the rows used with at least 1 value: which groups a test needs (and how
      // many values) is the test's own matter, and too few is "not recomputable", not bad input.
      // One measure: a tidy table's rows of several measures (% and s and N) pooled into one
      // variable were recomputed as one (review 2026-12-07).
      check_one_measure(table, filter_rows(table, where), value, "a \"where\" entry \"", "\"");
      GroupedData d = group_table(table, value, group, where, 1, 1, skip_empty);
      item.rows_skipped_empty = d.rows_skipped_empty;
      double df1 = NAN, df2 = NAN, stat = NAN, p = NAN;
      std::string why;  // why the test is undefined on these rows
      const std::string col = "column '" + group + "'";
      if (f_test && d.names.size() < 2) {
        why = "the rows used hold one group of " + col + " ('" + d.names[0] +
              "'); an F test compares at least 2";
      } else if (item.test == "anova") {
        size_t n = 0;
        for (const auto& g : d.values) n += g.size();
        df1 = static_cast<double>(d.names.size() - 1);
        if (n <= d.names.size()) {
          why = "every group of " + col +
                " has a single value: no variation within groups to "
                "compare with (df2 = 0)";
        } else {
          Anova r = oneway_anova(d.values);
          df2 = r.df_within;
          if (r.defined)
            stat = r.F, p = r.p;
          else
            why = "no variation within any group of " + col +
                  " (the values of each group are all equal): F and p are undefined";
        }
      } else if (item.test == "welch_anova") {
        df1 = static_cast<double>(d.names.size() - 1);
        for (size_t g = 0; g < d.names.size() && why.empty(); ++g)
          if (d.values[g].size() < 2)
            why = too_few(d, g) + "; Welch's F needs at least 2 per group";
        if (why.empty()) {
          WelchAnova r = welch_anova(d.values);
          if (r.defined)
            df2 = r.df_within, stat = r.F, p = r.p;
          else
            for (size_t g = 0; g < d.names.size() && why.empty(); ++g)
              if (std::all_of(d.values[g].begin(), d.values[g].end(),
                              [&](double x) { return x == d.values[g].front(); }))
                why = "group '" + d.names[g] +
                      "' has no variation (its values are all equal): Welch's F weights each "
                      "group by 1/variance and is undefined";
        }
      } else {
        if (!s.contains("pair") || !s["pair"].is_array() || s["pair"].size() != 2 ||
            !s["pair"][0].is_string() || !s["pair"][1].is_string())
          throw InputError(at(path + ".pair"),
                           "a t-test needs \"pair\": [\"GROUP_A\", \"GROUP_B\"] (t = A − B)");
        int ia = -1, ib = -1;
        for (size_t g = 0; g < d.names.size(); ++g) {
          if (d.names[g] == s["pair"][0].get<std::string>()) ia = static_cast<int>(g);
          if (d.names[g] == s["pair"][1].get<std::string>()) ib = static_cast<int>(g);
        }
        if (ia < 0 || ib < 0 || ia == ib) {
          // Which one, and what the rows hold (it said only "both groups must be distinct").
          std::string held;
          for (const auto& name : d.names)
            held += (held.empty() ? "'" : ", '") + shown_text(name) + "'";
          const std::string why_pair =
              ia == ib && ia >= 0
                  ? "the same group twice ('" + shown_text(d.names[ia]) + "')"
                  : "no group '" + shown_text(s["pair"][ia < 0 ? 0 : 1].get<std::string>()) +
                        "' in " + col + " among the rows used";
          throw InputError(at(path + ".pair"), "expected two distinct groups, got " + why_pair +
                                                   "; the rows used hold " + held);
        }
        for (int g : {ia, ib})
          if (why.empty() && d.values[g].size() < 2)
            why = too_few(d, g) + "; a t-test needs at least 2 per group";
        if (why.empty()) {
          TTest r = item.test == "welch_t" ? welch_t(d.values[ia], d.values[ib])
                                           : student_t(d.values[ia], d.values[ib]);
          df1 = r.df;
          if (r.defined) {
            stat = r.t, p = r.p;
            // A printed t may be the |t| of a pair written the other way round.
            if (a.value >= 0 && stat < 0) stat = -stat;
          } else {
            why = "no variation within groups '" + d.names[ia] + "' and '" + d.names[ib] +
                  "' (the values of each are all equal): t and p are undefined";
          }
        }
      }
      auto part = [&](const std::string& name, const std::string& shown, std::string verdict,
                      double v) {
        item.parts.push_back({name, shown, v, std::move(verdict)});
      };
      char b[64];
      auto show = [&](double v, int dec) {
        std::snprintf(b, sizeof b, "%.*f", dec, v);
        return std::string(b);
      };
      // Every df but Welch's denominators (the t's, the F's df2) is a whole count.
      const bool df1_count = item.test != "welch_t";
      const bool df2_count = item.test == "anova";
      part(a.kind == 'F' ? "df1" : "df", show(a.df1, a.df1_decimals),
           df1_count ? classify_count(a.df1, df1) : classify_number(a.df1, a.df1_decimals, df1),
           df1);
      if (a.kind == 'F')
        part("df2", show(a.df2, a.df2_decimals),
             df2_count ? classify_count(a.df2, df2) : classify_number(a.df2, a.df2_decimals, df2),
             df2);
      part("statistic", show(a.value, a.value_decimals),
           classify_number(a.value, a.value_decimals, stat), stat);
      part("p", a.p_relation + " " + show(a.p, a.p_decimals),
           classify_p(a.p_relation, a.p, a.p_decimals, p), p);
      item.verdict = "consistent";
      bool undefined = false;
      for (const auto& pt : item.parts) {
        if (rank(pt.verdict) > rank(item.verdict)) item.verdict = pt.verdict;
        undefined = undefined || pt.verdict == kNotRecomputable;
      }
      if (undefined)
        item.reason = why.empty() ? "the test is undefined on the rows used" : why;
      else
        item.recomputed_apa = a.kind == 'F' ? apa_f(stat, df1, df2, p) : apa_t(stat, df1, p);
      out.push_back(std::move(item));
    } catch (const InputError& e) {
      report(e);
    }
  }
  std::stable_sort(problems.begin(), problems.end(), [](const Problem& a, const Problem& b) {
    return std::pair{a.where.line, a.where.column} < std::pair{b.where.line, b.where.column};
  });  // in file order (an object's keys come sorted by name)
  if (!problems.empty()) throw InputError(problems);
  return out;
}

}  // namespace palplab::analysis
