#pragma once
// RFC 4180 CSV reader: comma-separated fields, optional double quotes around a field ("" is a
// literal quote inside), CRLF or LF line ends, quoted fields may span lines. The first record is
// the header. Every problem throws palplab::InputError with the file and the 1-based line number
// of the record (the physical line on which the record starts), so a researcher can find it.
#include <string>
#include <string_view>
#include <vector>

namespace palplab::analysis {

struct CsvTable {
  std::string file;                            // file name used in error messages
  std::vector<std::string> header;             // #columns column names
  std::vector<std::vector<std::string>> rows;  // #rows by #columns fields (unquoted)
  std::vector<int> line;                       // #rows 1-based line where each row starts
};

// Parses CSV text. `file` only labels error messages.
CsvTable parse_csv(std::string_view text, const std::string& file = {});
// Reads and parses a file; a missing or unreadable file is an InputError.
CsvTable read_csv(const std::string& path);

// Index of column `name`; throws InputError listing the available columns when it is absent.
int column_index(const CsvTable& t, std::string_view name);

// Strict number parsing of one field (surrounding blanks allowed, nothing else): throws
// InputError "file:line: column 'c': expected a number, got '...'".
double parse_number(const CsvTable& t, int row, int col);

}  // namespace palplab::analysis
