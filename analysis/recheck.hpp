#pragma once
// Checking printed statistics against raw data (`palplab recheck`). A reported statistic is
// APA text such as "F(2, 27) = 18.65, p < .001" or "t(17.9) = -3.02, p = .056" with the CSV
// columns it refers to; it is recomputed from the raw values and each part (df, statistic,
// p) is classified:
//   consistent         the recomputed value, rounded as printed, equals the printed value
//                      (p-bounds such as "p < .001": the recomputed p satisfies the bound; a
//                      bound that does not hold is inconsistent, never a rounding);
//   rounding           off by at most one unit in the last printed digit (a rounding or
//                      truncation slip, e.g. 18.64 for 18.645...);
//   not recomputable   the raw data do not define the value (no variation within the groups,
//                      a group of the test with fewer than 2 values, one group for an F): the
//                      item says why; never graded from a NaN;
//   inconsistent       anything else (with the recomputed value).
// The verdict of a statistic is its worst part, in the order consistent < rounding < not
// recomputable < inconsistent (a part that can be recomputed and disagrees is inconsistent even
// when another part cannot be recomputed). REPORTED.json: docs/FORMATS.md.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/csv.hpp"
#include "common/input_error.hpp"

namespace palplab::analysis {

// Parsed APA text. `decimals` count the printed digits after the point.
struct ApaStatistic {
  char kind = 'F';          // 'F' or 't'
  double df1 = 0, df2 = 0;  // F(df1, df2); t(df1)
  int df1_decimals = 0, df2_decimals = 0;
  double value = 0;
  int value_decimals = 0;
  std::string p_relation;  // "=", "<" or ">"
  double p = 0;
  int p_decimals = 0;
};
// Throws InputError (at `where`) when the text is not of the forms above or prints an
// impossible value: a df <= 0, a negative F, p outside [0, 1], "p < 0" or "p > 1".
ApaStatistic parse_apa(const std::string& text, const SourceLocation& where);

struct RecheckPart {
  std::string name;       // "df", "df1", "df2", "statistic", "p"
  std::string reported;   // as printed
  double recomputed = 0;  // NaN when not recomputable
  std::string verdict;    // "consistent", "rounding", "not recomputable", "inconsistent"
};
struct RecheckItem {
  std::string id, text, test;
  std::vector<RecheckPart> parts;
  std::string verdict;         // worst of the parts
  std::string recomputed_apa;  // empty when a part is not recomputable
  std::string reason;          // why parts are not recomputable; empty when every part is
  int rows_skipped_empty = 0;  // rows left out for an empty value (skip_empty)
};

// Recomputes every statistic of a REPORTED.json document on `table`. `file` labels errors;
// with the document's `text` (json::parse_json_file), errors also give its line:column. Bad
// input (no statistics, unknown or inapplicable keys, impossible printed values, duplicate ids)
// is an InputError at its JSON path. With `skip_empty`, rows whose value is empty or NA
// (undefined measures in palplab's own export) are left out and counted, as `stats --skip-empty`.
std::vector<RecheckItem> recheck(const nlohmann::json& reported, const CsvTable& table,
                                 const std::string& file, std::string_view text = {},
                                 bool skip_empty = false);

// Classifies a printed number against a recomputed one (decimals as printed); a recomputed
// value that is not finite is "not recomputable".
std::string classify_number(double reported, int decimals, double recomputed);
// Classifies a printed p ("=", "<", ">") against a recomputed p.
std::string classify_p(const std::string& relation, double reported, int decimals,
                       double recomputed);

}  // namespace palplab::analysis
