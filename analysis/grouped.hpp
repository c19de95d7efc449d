#pragma once
// From a CSV table to a one-way design: pick the value and group columns, keep the rows that
// pass the --where filters, parse the values (exactly centred, decimal.hpp) and split them by
// group in order of first appearance. Every problem is an InputError with the CSV line.
#include <string>
#include <vector>

#include "analysis/anova.hpp"
#include "analysis/csv.hpp"

namespace palplab::analysis {

// "COL=VALUE": keep rows whose column COL equals VALUE (exact text match after trimming
// blanks). Several filters on the same column are alternatives (OR); filters on different
// columns must all hold (AND).
struct WhereFilter {
  std::string column, value;
};
// Parses "COL=VALUE" (the first '=' splits); InputError when there is no '=' or COL is empty.
WhereFilter parse_where(const std::string& spec);

struct GroupedData {
  std::string value_column, group_column;
  std::vector<std::string> names;       // #groups group labels, first-appearance order
  Groups values;                        // #groups samples, as deviations from `offset`
  std::vector<std::vector<int>> lines;  // CSV line of every value
  double offset = 0;                    // value = offset + deviation (decimal.hpp)
  int rows_used = 0;
  int rows_skipped_empty = 0;  // rows left out because the value was empty (skip_empty)
};

// Throws InputError for: a missing column, a non-numeric or empty value (with its line), no
// row left after filtering, fewer than `min_groups` groups, a group with fewer than
// `min_per_group` values (with the line of its values). With `skip_empty`, rows whose value is
// empty or "NA" (how palplab export and R write an undefined measure) are left out and
// counted instead of being an error; any other non-numeric text is still an error. A group
// label that is empty or "NA" (undefined, as R writes it) is an InputError, or with
// `skip_empty` a row left out and counted in rows_skipped_empty too.
GroupedData group_table(const CsvTable& t, const std::string& value_column,
                        const std::string& group_column, const std::vector<WhereFilter>& where,
                        int min_per_group = 2, int min_groups = 2, bool skip_empty = false);

}  // namespace palplab::analysis

namespace palplab::analysis {
// Indices of the rows of `t` that pass the --where filters (same rules as group_table); a
// filter on a missing column is an InputError listing the columns.
std::vector<int> filter_rows(const CsvTable& t, const std::vector<WhereFilter>& where);
// Why `where` (`shown` as the user wrote it: "--where measure=x" or a JSON array) keeps no row
// of `t`: how filters combine and the values their columns hold (the first 10 of each), so
// that a misspelt value is seen. The text of an InputError's message.
std::string no_row_matches(const CsvTable& t, const std::vector<WhereFilter>& where,
                           const std::string& shown);
// The same filters as the command line shows them: "--where a=b --where c=d".
std::string shown_where_flags(const std::vector<WhereFilter>& where);
// The tidy tables palplab writes (`export`'s measures.csv, `calibrate --human`) hold every
// measure in one value column: a `measure` or `unit` column (other than `value_column`) with
// more than one value among `rows` means numbers of different quantities pooled into one
// analysis (accuracy in %, times in s and forces in N as one variable). InputError at the
// first row that differs, naming both values and how to select one: `select` + "measure=X" +
// `select_end` ("--where " for a flag; "a \"where\" entry \"" and "\"" in a JSON file).
void check_one_measure(const CsvTable& t, const std::vector<int>& rows,
                       const std::string& value_column, const std::string& select,
                       const std::string& select_end = "");
}  // namespace palplab::analysis
