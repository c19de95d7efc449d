#include "analysis/csv.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/input_error.hpp"

namespace palplab::analysis {

namespace {

InputError error_at(const std::string& file, int line, int column, std::string what) {
  return InputError(SourceLocation{file, line, column}, std::move(what));
}

}  // namespace

CsvTable parse_csv(std::string_view text, const std::string& file) {
  CsvTable t;
  t.file = file;
  size_t i = 0;
  // A UTF-8 byte-order mark (Excel writes one) is not part of the first column name.
  if (text.substr(0, 3) == "\xEF\xBB\xBF") i = 3;
  int line = 1;
  bool have_header = false;
  const size_t n = text.size();
  while (i < n) {
    const int record_line = line;
    std::vector<std::string> fields;
    std::string field;
    bool record_done = false;
    while (!record_done) {
      field.clear();
      if (i < n && text[i] == '"') {
        const int quote_line = line;
        ++i;
        bool closed = false;
        while (i < n) {
          char c = text[i];
          if (c == '"') {
            if (i + 1 < n && text[i + 1] == '"') {
              field += '"';
              i += 2;
              continue;
            }
            ++i;
            closed = true;
            break;
          }
          if (c == '\n') ++line;
          field += c;
          ++i;
        }
        if (!closed)
          throw error_at(file, quote_line, 0,
                         "unterminated quoted field (a '\"' opened here is never closed)");
        if (i < n && text[i] != ',' && text[i] != '\n' && text[i] != '\r')
          throw error_at(file, line, 0,
                         "unexpected character after a closing quote; inside a quoted field "
                         "write a quote as \"\"");
      } else {
        while (i < n && text[i] != ',' && text[i] != '\n' && text[i] != '\r') {
          if (text[i] == '"')
            throw error_at(file, line, 0,
                           "a '\"' inside an unquoted field; quote the whole field and write "
                           "the quote as \"\"");
          field += text[i];
          ++i;
        }
      }
      fields.push_back(field);
      if (i >= n) {
        record_done = true;
      } else if (text[i] == ',') {
        ++i;
      } else {  // line end: \n, \r\n or a lone \r
        if (text[i] == '\r') ++i;
        if (i < n && text[i] == '\n') ++i;
        ++line;
        record_done = true;
      }
    }
    // Blank lines (a single empty field) are skipped: editors leave them at the end of files.
    if (fields.size() == 1 && fields[0].empty()) continue;
    if (!have_header) {
      t.header = std::move(fields);
      have_header = true;
      for (size_t a = 0; a < t.header.size(); ++a) {
        if (t.header[a].empty())
          throw error_at(file, record_line, 0,
                         "empty column name in the header (column " + std::to_string(a + 1) + ")");
        for (size_t b = 0; b < a; ++b)
          if (t.header[a] == t.header[b])
            throw error_at(file, record_line, 0, "duplicate column name '" + t.header[a] + "'");
      }
      continue;
    }
    if (fields.size() != t.header.size())
      throw error_at(file, record_line, 0,
                     "expected " + std::to_string(t.header.size()) +
                         " fields (as in the header), got " + std::to_string(fields.size()));
    t.rows.push_back(std::move(fields));
    t.line.push_back(record_line);
  }
  if (!have_header) throw InputError("empty CSV file: expected a header row", file);
  return t;
}

CsvTable read_csv(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot open CSV file (does it exist and is it readable?)", path);
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_csv(ss.str(), path);
}

int column_index(const CsvTable& t, std::string_view name) {
  for (size_t c = 0; c < t.header.size(); ++c)
    if (t.header[c] == name) return static_cast<int>(c);
  std::string avail;
  for (size_t c = 0; c < t.header.size(); ++c) avail += (c ? ", " : "") + t.header[c];
  throw InputError(SourceLocation{t.file, 1},
                   "no column '" + std::string(name) + "' in the header; columns are: " + avail);
}

double parse_number(const CsvTable& t, int row, int col) {
  const std::string& s = t.rows[row][col];
  size_t b = s.find_first_not_of(" \t");
  size_t e = s.find_last_not_of(" \t");
  std::string v = b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  auto fail = [&](const std::string& why) {
    return InputError(
        SourceLocation{t.file, t.line[row]},
        "column '" + t.header[col] + "' (field " + std::to_string(col + 1) + "): " + why);
  };
  if (v.empty()) throw fail("empty value; expected a number (missing data are not allowed)");
  errno = 0;
  char* end = nullptr;
  double x = std::strtod(v.c_str(), &end);
  if (end != v.c_str() + v.size() || !std::isfinite(x) || errno == ERANGE)
    throw fail("expected a finite number, got '" + s + "'");
  return x;
}

}  // namespace palplab::analysis
