#include "analysis/grouped.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string_view>

#include "analysis/decimal.hpp"
#include "analysis/summary.hpp"
#include "common/input_error.hpp"

namespace palplab::analysis {

namespace {
// The most groups a one-way analysis takes. Every pair of groups gets a Welch t-test with an
// interval of Cohen's d (a noncentral-t root search), a Mann–Whitney test, a Tukey–Kramer and a
// Games–Howell comparison (each a studentized-range integral): about 1 ms of CPU per pair, and
// k(k-1)/2 pairs. 100 groups are 4 950 pairs (~5 s); 300 groups took 44 s and 50 000 groups
// (1.25e9 pairs) ran out of memory. Checked after the scan, before any value is stored.
constexpr size_t kMaxGroups = 100;
// The smallest spread of the values (largest |deviation|) the statistics can square: the
// counterpart of kMaxCsvMagnitude (csv.hpp).
constexpr double kMinCsvSpread = 1e-150;
}  // namespace

WhereFilter parse_where(const std::string& spec) {
  size_t eq = spec.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(SourceLocation{"--where"}, "expected COLUMN=VALUE, got '" + spec + "'");
  return {trim_blanks(spec.substr(0, eq)), trim_blanks(spec.substr(eq + 1))};
}

GroupedData group_table(const CsvTable& t, const std::string& value_column,
                        const std::string& group_column, const std::vector<WhereFilter>& where,
                        int min_per_group, int min_groups, bool skip_empty) {
  GroupedData g;
  g.value_column = value_column;
  g.group_column = group_column;
  const int vc = column_index(t, value_column);
  const int gc = column_index(t, group_column);
  // column -> accepted values
  std::map<int, std::vector<std::string>> filters;
  for (const auto& w : where) filters[column_index(t, w.column)].push_back(w.value);

  std::vector<std::string_view> texts;
  std::vector<int> group_of, line_of;
  std::map<std::string, int> index;
  for (size_t r = 0; r < t.rows.size(); ++r) {
    bool keep = true;
    for (const auto& [col, accepted] : filters) {
      std::string v = trim_blanks(t.rows[r][col]);
      bool any = false;
      for (const auto& a : accepted) any = any || v == a;
      keep = keep && any;
    }
    if (!keep) continue;
    if (skip_empty) {
      const std::string v = trim_blanks(t.rows[r][vc]), label = trim_blanks(t.rows[r][gc]);
      if (v.empty() || v == "NA" || label.empty() || label == "NA") {
        ++g.rows_skipped_empty;
        continue;
      }
    }
    // Validates, with the line, before use (a long bad field is shown cut, shown_text). An
    // undefined value (empty or NA, as palplab's own measures.csv writes one) says how to leave
    // such rows out: stats and recheck both have --skip-empty.
    try {
      parse_number(t, static_cast<int>(r), vc);
    } catch (const InputError& e) {
      const std::string v = trim_blanks(t.rows[r][vc]);
      if (!v.empty() && v != "NA") throw;
      std::vector<Problem> ps = e.problems();
      ps.front().what += " (an undefined value: --skip-empty leaves such rows out and counts them)";
      throw InputError(ps);
    }
    std::string name = trim_blanks(t.rows[r][gc]);
    // "NA" is R's undefined label (lmm drops such rows): not a group of its own.
    if (name.empty() || name == "NA")
      throw InputError(SourceLocation{t.file, t.line[r]},
                       "column '" + group_column + "': " +
                           (name.empty() ? "empty group label" : "undefined group label NA") +
                           " (--skip-empty leaves such rows out and counts them)");
    auto [it, fresh] = index.emplace(name, static_cast<int>(g.names.size()));
    if (fresh) g.names.push_back(name);
    texts.push_back(t.rows[r][vc]);
    group_of.push_back(it->second);
    line_of.push_back(t.line[r]);
  }
  if (g.names.size() > kMaxGroups) {
    const size_t k = g.names.size();
    throw InputError(
        SourceLocation{t.file},
        "column '" + group_column + "' has " + std::to_string(k) +
            " groups in the rows used; at most " + std::to_string(kMaxGroups) +
            " are supported (every pair of groups is tested: " + std::to_string(k * (k - 1) / 2) +
            " pairs here, " + std::to_string(kMaxGroups * (kMaxGroups - 1) / 2) +
            " at the limit); is '" + group_column +
            "' the grouping column (not an id)? Use --where to select groups");
  }
  if (texts.empty()) {
    if (!where.empty() && filter_rows(t, where).empty())
      throw InputError(no_row_matches(t, where, shown_where_flags(where)));
    std::string what = "no data rows";
    if (!where.empty()) what += " match the --where filters";
    if (g.rows_skipped_empty > 0)
      what += " (" + std::to_string(g.rows_skipped_empty) +
              " with an empty value or group label skipped)";
    throw InputError(what, t.file);
  }
  auto cv = centre_decimals(texts);
  // The statistics square the deviations (from the centre, or the values themselves) and sum
  // the squares: when all of them are below 1e-150 (e.g. values of 1e-200 or subnormals such as
  // 1e-320) the squares underflow and SDs, sums of squares and intervals come out 0 beside a
  // finite F. Single tiny values beside larger ones are fine.
  double spread = 0;
  for (double d : cv.dev) spread = std::max(spread, std::fabs(d));
  if (spread > 0 && spread < kMinCsvSpread) {
    char by[32];
    std::snprintf(by, sizeof by, "%.3g", spread);
    throw InputError(SourceLocation{t.file},
                     "column '" + value_column + "': the values used differ from " +
                         (cv.centre == 0 ? "0" : "their median") + " by at most " + by +
                         ": below 1e-150 the statistics, which square and sum the "
                         "differences, underflow a double (SDs and sums of squares would be "
                         "0); rescale the column (e.g. other units)");
  }
  g.offset = cv.centre;
  g.values.assign(g.names.size(), {});
  g.lines.assign(g.names.size(), {});
  for (size_t i = 0; i < texts.size(); ++i) {
    g.values[group_of[i]].push_back(cv.dev[i]);
    g.lines[group_of[i]].push_back(line_of[i]);
  }
  g.rows_used = static_cast<int>(texts.size());
  for (size_t k = 0; k < g.names.size(); ++k)
    if (static_cast<int>(g.values[k].size()) < min_per_group) {
      std::string lines;
      for (int l : g.lines[k]) lines += (lines.empty() ? "" : ", ") + std::to_string(l);
      throw InputError(SourceLocation{t.file, g.lines[k].front()},
                       "group '" + shown_text(g.names[k]) + "' (column '" + group_column +
                           "') has " + std::to_string(g.values[k].size()) + " value(s) (line " +
                           lines + "); every group needs at least " +
                           std::to_string(min_per_group));
    }
  if (static_cast<int>(g.names.size()) < min_groups)
    throw InputError(SourceLocation{t.file}, "column '" + group_column + "' has " +
                                                 std::to_string(g.names.size()) +
                                                 " group(s) in the rows used; at least " +
                                                 std::to_string(min_groups) + " are needed");
  return g;
}

}  // namespace palplab::analysis

namespace palplab::analysis {
std::string no_row_matches(const CsvTable& t, const std::vector<WhereFilter>& where,
                           const std::string& shown) {
  std::vector<std::string> columns;
  for (const auto& w : where)
    if (std::find(columns.begin(), columns.end(), w.column) == columns.end())
      columns.push_back(w.column);
  std::string held;
  for (const auto& c : columns) {
    const int col = column_index(t, c);
    std::vector<std::string> values;
    bool more = false;
    for (const auto& row : t.rows) {
      const std::string v = trim_blanks(row[col]);  // as the filters compare
      if (std::find(values.begin(), values.end(), v) != values.end()) continue;
      if (values.size() == 10) {
        more = true;
        break;
      }
      values.push_back(v);
    }
    held += "; column '" + shown_text(c) + "' holds ";
    for (size_t k = 0; k < values.size(); ++k)
      held += (k ? ", '" : "'") + shown_text(values[k]) + "'";
    if (more) held += " and more";
  }
  return "no row of " + t.file + " matches " + shown + " (" + std::to_string(t.rows.size()) +
         " data row" + (t.rows.size() == 1 ? "" : "s") +
         "; filters on the same column are alternatives, filters on different columns must all "
         "hold)" +
         held;
}

std::string shown_where_flags(const std::vector<WhereFilter>& where) {
  std::string s;
  for (const auto& w : where) {
    if (!s.empty()) s += ' ';
    s.append("--where ").append(shown_text(w.column)).append("=").append(shown_text(w.value));
  }
  return s;
}

void check_one_measure(const CsvTable& t, const std::vector<int>& rows,
                       const std::string& value_column, const std::string& select,
                       const std::string& select_end) {
  auto column = [&](const std::string& name) {
    for (std::size_t c = 0; c < t.header.size(); ++c)
      if (t.header[c] == name && name != value_column) return static_cast<int>(c);
    return -1;
  };
  for (const char* name : {"measure", "unit"}) {
    const int c = column(name);
    if (c < 0 || rows.empty()) continue;
    const std::string first = trim_blanks(t.rows[rows[0]][c]);
    for (const int r : rows) {
      const std::string v = trim_blanks(t.rows[r][c]);
      if (v == first) continue;
      throw InputError(SourceLocation{t.file, t.line[r]},
                       std::string("the rows analysed mix ") + name + "s: '" + shown_text(first) +
                           "' (line " + std::to_string(t.line[rows[0]]) + ") and '" +
                           shown_text(v) + "' (column '" + name +
                           "'); analyse one at a time with " + select + name + "=" +
                           shown_text(first) + select_end);
    }
  }
}

std::vector<int> filter_rows(const CsvTable& t, const std::vector<WhereFilter>& where) {
  std::map<int, std::vector<std::string>> filters;
  for (const auto& w : where) filters[column_index(t, w.column)].push_back(w.value);
  std::vector<int> kept;
  for (size_t r = 0; r < t.rows.size(); ++r) {
    bool keep = true;
    for (const auto& [col, accepted] : filters) {
      std::string v = trim_blanks(t.rows[r][col]);
      bool any = false;
      for (const auto& a : accepted) any = any || v == a;
      keep = keep && any;
    }
    if (keep) kept.push_back(static_cast<int>(r));
  }
  return kept;
}
}  // namespace palplab::analysis
