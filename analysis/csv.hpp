#pragma once
// RFC 4180 CSV reader: comma-separated fields, optional double quotes around a field ("" is a
// literal quote inside), CRLF or LF line ends, quoted fields may span lines. The first record is
// the header. Every problem throws palplab::InputError with the file and the 1-based line number
// of the record (the physical line on which the record starts), so a researcher can find it.
// The text must be UTF-8 (a Latin-1 / Windows-1252 file is an error at its first non-UTF-8 byte,
// saying how to convert it): labels go into JSON output, which is UTF-8 only.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "common/escape.hpp"

namespace palplab::analysis {

struct CsvTable {
  std::string file;                            // file name used in error messages
  std::vector<std::string> header;             // #columns column names
  std::vector<std::vector<std::string>> rows;  // #rows by #columns fields (unquoted)
  std::vector<int> line;                       // #rows 1-based line where each row starts
  // #rows x #columns, row-major: 1-based line and column (Unicode code points, as editors count)
  // where each field starts.
  std::vector<int> field_line, field_column;
};

// Parses CSV text. `file` only labels error messages.
CsvTable parse_csv(std::string_view text, const std::string& file = {});
// Largest CSV read (1 GiB: a measures table of thousands of studies; a samples.csv of a long
// study may be larger: select its rows first). Checked while reading.
inline constexpr std::size_t kMaxCsvFileBytes = 1024u * 1024 * 1024;
// Reads and parses a file; a missing or unreadable file, a directory or one above
// kMaxCsvFileBytes is an InputError.
CsvTable read_csv(const std::string& path);

// Text from the input (a CSV field, a column name, a group label) as messages show it: cut and
// escaped by common/escape.hpp's shown_text.
using ::palplab::shown_text;
// Column names for a message: the first `max_columns` through shown_text, each between `quote`s,
// separated by ", ", then "… (N columns)" when there are more.
std::string shown_columns(const std::vector<std::string>& header, std::string_view quote = "",
                          std::size_t max_columns = 20);

// `s` without its leading and trailing blanks (spaces and tabs): a cell as typed in a spreadsheet.
std::string trim_blanks(const std::string& s);

// Index of column `name`; throws InputError listing the available columns (shown_columns) when
// it is absent.
int column_index(const CsvTable& t, std::string_view name);
// " (the header is one column, 'a;b': is the file separated by ';'? ...)" when the header is one
// column holding ';' or a tab (a spreadsheet's export read as one column), else empty: added
// to the messages that list or count the columns.
std::string separator_hint(const std::vector<std::string>& header);

// The largest magnitude a CSV number may have: squares and sums of squares of larger values
// overflow a double (1.8e308).
inline constexpr double kMaxCsvMagnitude = 1e150;

// Strict number parsing of one field: a decimal number [+-]digits[.digits][(e|E)[+-]digits]
// (surrounding blanks allowed; no hexadecimal, inf or nan) of magnitude <= kMaxCsvMagnitude;
// otherwise
// InputError "file:line:column: column 'c' (field k): expected ..., got '...'" (the field and
// the column name through shown_text).
double parse_number(const CsvTable& t, int row, int col);

}  // namespace palplab::analysis
