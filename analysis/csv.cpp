#include "analysis/csv.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "common/read_file.hpp"

namespace palplab::analysis {

std::string separator_hint(const std::vector<std::string>& header) {
  if (header.size() != 1) return {};
  for (const char* sep : {";", "\t"})
    if (header[0].find(sep) != std::string::npos)
      return std::string(" (the header is one column, '") + shown_text(header[0]) +
             "': is the file separated by " + (sep[0] == ';' ? "';'" : "tabs") +
             "? palplab reads comma-separated files, RFC 4180, with '.' as the decimal point)";
  return {};
}

namespace {

InputError error_at(const std::string& file, int line, int column, std::string what) {
  return InputError(SourceLocation{file, line, column}, std::move(what));
}

// The whole text must be UTF-8: the first ill-formed byte is an error at its line:column.
void require_utf8(std::string_view text, const std::string& file) {
  // UTF-16 (Excel's "Unicode text", PowerShell's default) starts with its byte order mark, or
  // has a zero byte beside each ASCII one: not Latin-1, so not that advice.
  // UTF-32 likewise (three zero bytes; it was called UTF-16, or Latin-1, or a NUL-filled column).
  if (const char* enc = wide_unicode(text))
    throw error_at(file, 1, 1,
                   std::string("the file is ") + enc +
                       ", not UTF-8: CSV files are read as UTF-8; save it as UTF-8 (Excel: \"CSV "
                       "UTF-8\"; or iconv -f " +
                       enc + " -t UTF-8 IN.csv > OUT.csv)");
  int line = 1, column = 1;
  for (size_t i = 0; i < text.size();) {
    size_t len = 1;
    if (utf8_code_point(text, i, &len) == 0xFFFD && len == 1) {  // ill-formed (U+FFFD is 3 bytes)
      char hex[8];
      const auto b = static_cast<unsigned char>(text[i]);
      std::snprintf(hex, sizeof hex, "0x%02X", b);
      // A lead byte followed by continuation bytes is UTF-8 gone wrong (a surrogate, an overlong
      // form, a code point above U+10FFFF, or a character cut off at the end), not Latin-1: the
      // Latin-1 advice was given for those too (review 2026-12-06, eighth).
      const size_t need = b >= 0xF0 ? 3 : b >= 0xE0 ? 2 : 1;  // continuation bytes of the lead
      size_t k = 1;
      while (i + k < text.size() && k <= need && utf8_continuation(text[i + k])) ++k;
      const bool cut_off = b >= 0xC2 && b <= 0xF4 && i + k == text.size() && k <= need;
      if (cut_off || (b >= 0xC0 && k > 1))
        throw error_at(file, line, column,
                       std::string("byte ") + hex +
                           (cut_off ? " begins a UTF-8 character that the file cuts off (a "
                                      "truncated file?)"
                                    : " begins an ill-formed UTF-8 sequence (a surrogate, an "
                                      "overlong form or a code point above U+10FFFF: written by "
                                      "a faulty encoder, or damaged)") +
                           "; CSV files are read as UTF-8");
      throw error_at(file, line, column,
                     std::string("byte ") + hex +
                         " is not UTF-8: CSV files are read as UTF-8, and this one looks like "
                         "Latin-1 / Windows-1252 (e.g. an accented label); save it as UTF-8 "
                         "(Excel: \"CSV UTF-8\"; or iconv -f WINDOWS-1252 -t UTF-8 IN.csv > "
                         "OUT.csv)");
    }
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
    i += len;
  }
}

// [+-]digits[.digits][(e|E)[+-]digits], at least one mantissa digit (".5" and "5." are allowed).
bool decimal_form(std::string_view v) {
  size_t i = 0, digits = 0;
  if (i < v.size() && (v[i] == '+' || v[i] == '-')) ++i;
  for (; i < v.size() && v[i] >= '0' && v[i] <= '9'; ++i) ++digits;
  if (i < v.size() && v[i] == '.')
    for (++i; i < v.size() && v[i] >= '0' && v[i] <= '9'; ++i) ++digits;
  if (digits == 0) return false;
  if (i < v.size() && (v[i] == 'e' || v[i] == 'E')) {
    ++i;
    if (i < v.size() && (v[i] == '+' || v[i] == '-')) ++i;
    size_t e = 0;
    for (; i < v.size() && v[i] >= '0' && v[i] <= '9'; ++i) ++e;
    if (e == 0) return false;
  }
  return i == v.size();
}

}  // namespace

CsvTable parse_csv(std::string_view text, const std::string& file) {
  CsvTable t;
  t.file = file;
  require_utf8(text, file);
  size_t i = 0;
  // A UTF-8 byte-order mark (Excel writes one) is not part of the first column name (nor is a
  // second one, left by a tool that prepended its own).
  while (text.substr(i, 3) == "\xEF\xBB\xBF") i += 3;
  int line = 1;
  // Field columns: code points from the start of the current line, counted incrementally.
  size_t line_start = i, counted_to = i;
  int counted = 0;
  std::vector<int> f_line, f_col;  // the current record's fields
  bool have_header = false;
  const size_t n = text.size();
  while (i < n) {
    const int record_line = line;
    std::vector<std::string> fields;
    std::string field;
    bool record_done = false;
    f_line.clear();
    f_col.clear();
    while (!record_done) {
      field.clear();
      if (counted_to < line_start) counted_to = line_start, counted = 0;
      if (counted_to < i) {
        counted += utf8_length(std::string_view(text).substr(counted_to, i - counted_to));
        counted_to = i;
      }
      f_line.push_back(line);
      f_col.push_back(counted + 1);
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
          if (c == '\n') {
            ++line;
            line_start = i + 1;
          }
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
        line_start = i;
        record_done = true;
      }
    }
    // Blank lines (a single empty field) are skipped: editors leave them at the end of files.
    if (fields.size() == 1 && fields[0].empty()) continue;
    if (!have_header) {
      t.header = std::move(fields);
      have_header = true;
      // Blanks around a name are not part of it ("participant, group"), as around a value.
      for (auto& name : t.header) name = trim_blanks(name);
      for (size_t a = 0; a < t.header.size(); ++a) {
        if (t.header[a].empty())
          throw error_at(file, record_line, 0,
                         "empty column name in the header (column " + std::to_string(a + 1) + ")");
        for (size_t b = 0; b < a; ++b)
          if (t.header[a] == t.header[b])
            throw error_at(file, record_line, 0,
                           "duplicate column name '" + shown_text(t.header[a]) + "'");
      }
      continue;
    }
    if (fields.size() != t.header.size())
      throw error_at(file, record_line, 0,
                     "expected " + std::to_string(t.header.size()) +
                         " fields (as in the header), got " + std::to_string(fields.size()) +
                         separator_hint(t.header));
    t.rows.push_back(std::move(fields));
    t.line.push_back(record_line);
    t.field_line.insert(t.field_line.end(), f_line.begin(), f_line.end());
    t.field_column.insert(t.field_column.end(), f_col.begin(), f_col.end());
  }
  if (!have_header) throw InputError("empty CSV file: expected a header row", file);
  return t;
}

CsvTable read_csv(const std::string& path) {
  // A directory opens as an empty stream on Linux: say what it is, not "empty CSV file".
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError("is a directory, expected a CSV file", path);
  // Bounded: a CSV of measures is megabytes; /dev/zero or a pipe that never ends stops here.
  return parse_csv(read_file_bounded(path, kMaxCsvFileBytes, "CSV file"), path);
}

std::string shown_columns(const std::vector<std::string>& header, std::string_view quote,
                          size_t max_columns) {
  std::string out;
  for (size_t c = 0; c < header.size() && c < max_columns; ++c)
    out += (c ? ", " : "") + std::string(quote) + shown_text(header[c]) + std::string(quote);
  if (header.size() > max_columns)
    out += ", \u2026 (" + std::to_string(header.size()) + " columns)";
  return out;
}

int column_index(const CsvTable& t, std::string_view name) {
  for (size_t c = 0; c < t.header.size(); ++c)
    if (t.header[c] == name) return static_cast<int>(c);
  throw InputError(SourceLocation{t.file, 1},
                   "no column '" + shown_text(name) + "' in the header; columns are: " +
                       shown_columns(t.header) + separator_hint(t.header));
}

double parse_number(const CsvTable& t, int row, int col) {
  const std::string& s = t.rows[row][col];
  size_t b = s.find_first_not_of(" \t");
  size_t e = s.find_last_not_of(" \t");
  std::string v = b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  const size_t k = static_cast<size_t>(row) * t.header.size() + static_cast<size_t>(col);
  const bool located = k < t.field_line.size();  // tables built by hand have no positions
  auto fail = [&](const std::string& why) {
    return InputError(SourceLocation{t.file, located ? t.field_line[k] : t.line[row],
                                     located ? t.field_column[k] : 0},
                      "column '" + shown_text(t.header[col]) + "' (field " +
                          std::to_string(col + 1) + "): " + why);
  };
  if (v.empty()) throw fail("empty value; expected a number (missing data are not allowed)");
  // The field as a message shows it: a long one cut to its start and length (shown_text).
  auto shown = [&] { return shown_text(s); };
  if (!decimal_form(v))
    throw fail("expected a decimal number ([+-]digits[.digits][e[+-]digits]), got '" + shown() +
               "'");
  char* end = nullptr;
  double x = std::strtod(v.c_str(), &end);
  // Only overflow is an error (strtod returns inf). strtod reports underflow with ERANGE too,
  // but a value below the normal range (1e-320, a subnormal) or below the smallest double
  // (1e-400, read as 0) is a valid, correctly rounded number.
  if (end != v.c_str() + v.size() || !std::isfinite(x))
    throw fail("expected a number within the range of a double (|x| < 1.8e308), got '" + shown() +
               "'");
  // Squares of larger values (and sums of them) overflow a double: SDs and sums of squares would
  // be inf next to finite, scale-free statistics (F, t) and some tests would go wrong (Tukey q 0).
  if (std::fabs(x) > kMaxCsvMagnitude)
    throw fail("the magnitude of '" + shown() +
               "' is above 1e150: the statistics square values and sum the squares, which "
               "overflows a double beyond that; rescale the column (e.g. other units)");
  return x;
}

std::string trim_blanks(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return {};
  const size_t e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

}  // namespace palplab::analysis
