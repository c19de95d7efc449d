#pragma once
// Text from user files (ids, names, paths) shown on a terminal: control characters are written
// as escapes (\x1b, \u009b) so that an escape sequence in a name can never recolour, move the
// cursor of, or retitle the researcher's terminal, and bytes that are no UTF-8 (a binary file's,
// Latin-1 text) as \xNN. Newlines and tabs are kept when asked to (for whole multi-line
// outputs); printable text and other UTF-8 pass unchanged.
#include <cstdio>
#include <string>
#include <string_view>

namespace palplab {

// UTF-8 text counted in characters (code points), as columns and lengths are said to users:
// a continuation byte (10xxxxxx) belongs to the character before it.
inline bool utf8_continuation(char c) {
  return (static_cast<unsigned char>(c) & 0xC0) == 0x80;
}

inline std::size_t utf8_length(std::string_view s) {
  std::size_t n = 0;
  for (char c : s) n += !utf8_continuation(c);
  return n;
}

// The byte length of `s`'s first `max_chars` characters (all of `s` when it is shorter): where
// to cut it without splitting a character.
inline std::size_t utf8_prefix(std::string_view s, std::size_t max_chars) {
  std::size_t cut = 0;
  for (std::size_t chars = 0; cut < s.size() && chars < max_chars; ++chars) {
    ++cut;  // the lead byte, then its continuation bytes
    while (cut < s.size() && utf8_continuation(s[cut])) ++cut;
  }
  return cut;
}

// The code point of the UTF-8 character at s[i] and its length in bytes (*length); an ill-formed
// or cut sequence is U+FFFD of length 1, so a scan always advances.
inline char32_t utf8_code_point(std::string_view s, std::size_t i, std::size_t* length) {
  const auto c = static_cast<unsigned char>(s[i]);
  *length = 1;
  if (c < 0x80) return c;
  const std::size_t n = c >= 0xC2 && c <= 0xDF   ? 1
                        : c >= 0xE0 && c <= 0xEF ? 2
                        : c >= 0xF0 && c <= 0xF4 ? 3
                                                 : 0;
  if (n == 0 || i + n >= s.size()) return 0xFFFD;
  char32_t cp = c & (0x3F >> n);
  for (std::size_t k = 1; k <= n; ++k) {
    if (!utf8_continuation(s[i + k])) return 0xFFFD;
    cp = cp << 6 | (static_cast<unsigned char>(s[i + k]) & 0x3F);
  }
  if ((n == 2 && (cp < 0x800 || (cp >= 0xD800 && cp <= 0xDFFF))) ||
      (n == 3 && (cp < 0x10000 || cp > 0x10FFFF)))
    return 0xFFFD;
  *length = n + 1;
  return cp;
}

// The columns a terminal gives `s`: one per character, two for East Asian wide and fullwidth
// ones, none for combining marks and zero-width characters (printf's "%-14s" pads by bytes:
// "Ärzte" and "日本" shifted the columns of a text table; review 2026-12-07).
inline std::size_t display_width(std::string_view s) {
  std::size_t w = 0;
  for (std::size_t i = 0, len = 0; i < s.size(); i += len) {
    const char32_t cp = utf8_code_point(s, i, &len);
    if ((cp >= 0x300 && cp <= 0x36F) || (cp >= 0x200B && cp <= 0x200F)) continue;
    const bool wide = (cp >= 0x1100 && cp <= 0x115F) ||
                      (cp >= 0x2E80 && cp <= 0xA4CF && cp != 0x303F) ||
                      (cp >= 0xAC00 && cp <= 0xD7A3) || (cp >= 0xF900 && cp <= 0xFAFF) ||
                      (cp >= 0xFE30 && cp <= 0xFE4F) || (cp >= 0xFF00 && cp <= 0xFF60) ||
                      (cp >= 0xFFE0 && cp <= 0xFFE6) || (cp >= 0x1F300 && cp <= 0x1F64F) ||
                      (cp >= 0x20000 && cp <= 0x3FFFD);
    w += wide ? 2 : 1;
  }
  return w;
}
// The printf field width ("%-*s") that makes `s` take `columns` terminal columns.
inline int printf_width(std::string_view s, int columns) {
  return columns + static_cast<int>(s.size()) - static_cast<int>(display_width(s));
}

inline std::string escape_controls(std::string_view s, bool keep_newlines = true) {
  std::string out;
  out.reserve(s.size());
  char buf[8];
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if ((c == '\n' || c == '\t') && keep_newlines) {
      out += static_cast<char>(c);
    } else if (c < 0x20 || c == 0x7f) {
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else if (c < 0x80) {
      out += static_cast<char>(c);
    } else {
      std::size_t n = 1;
      const char32_t cp = utf8_code_point(s, i, &n);
      if (cp >= 0x80 && cp <= 0x9F) {  // C1 controls (U+0080..U+009F)
        std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(cp));
        out += buf;
      } else if (cp == 0xFFFD && n == 1) {  // a byte of no UTF-8 character (binary, Latin-1)
        std::snprintf(buf, sizeof buf, "\\x%02x", c);
        out += buf;
      } else {
        out.append(s.substr(i, n));
      }
      i += n - 1;
    }
  }
  return out;
}

// Text from user input (a CSV field, a column name, a trace field, a mesh keyword) as messages
// show it: control characters escaped (escape_controls), cut after `max_chars` characters
// (UTF-8 code points, never inside one) with "… (N bytes)": a 10 MB field made a 10 MB message.
inline std::string shown_text(std::string_view s, std::size_t max_chars = 60) {
  const std::size_t cut = utf8_prefix(s, max_chars);
  if (cut == s.size()) return escape_controls(s, false);
  return escape_controls(s.substr(0, cut), false) + "\u2026 (" + std::to_string(s.size()) +
         " bytes)";
}

// "UTF-32", "UTF-16" or nullptr: whether `text` is wide Unicode (an editor's "Unicode" save),
// with or without its byte-order mark, either byte order — an ASCII character has three or one
// zero bytes beside it. JSON and CSV files are read as UTF-8 and say so at 1:1.
inline const char* wide_unicode(std::string_view text) {
  const auto u = [&](std::size_t i) {
    return i < text.size() ? int(static_cast<unsigned char>(text[i])) : -1;
  };
  const auto ascii = [](int c) { return c >= 0x09 && c < 0x80; };
  if ((u(0) == 0xFF && u(1) == 0xFE && u(2) == 0 && u(3) == 0) ||
      (u(0) == 0 && u(1) == 0 && u(2) == 0xFE && u(3) == 0xFF) ||
      (ascii(u(0)) && u(1) == 0 && u(2) == 0 && u(3) == 0) ||
      (u(0) == 0 && u(1) == 0 && u(2) == 0 && ascii(u(3))))
    return "UTF-32";
  if ((u(0) == 0xFF && u(1) == 0xFE) || (u(0) == 0xFE && u(1) == 0xFF) ||
      (ascii(u(0)) && u(1) == 0 && u(3) == 0) || (u(0) == 0 && ascii(u(1)) && u(2) == 0))
    return "UTF-16";
  return nullptr;
}

// Whether `s` is well-formed UTF-8 (no overlong forms, surrogates or code points above
// U+10FFFF): names from user files go into JSON, which holds UTF-8 only.
inline bool is_valid_utf8(std::string_view s) {
  for (std::size_t i = 0, n = 0; i < s.size(); i += n)
    if (utf8_code_point(s, i, &n) == 0xFFFD && n == 1) return false;  // U+FFFD itself is 3 bytes
  return true;
}

// Text from user files (ids, names, paths) written into Markdown (a table cell, a list item, a
// heading): the characters that would end a table cell (|), open inline HTML (<) or a code span
// (`), or escape what follows (\) are backslash-escaped (CommonMark lets any ASCII punctuation
// be), so a name renders as written and never as markup: a test id "<script>" stays text.
// '<' is escaped where it could open markup (before a letter, '/', '!' or '?': a tag, a
// comment, an autolink) and '&' where it could start an entity (before a letter or '#'), so
// that "p < .001" and "A & B" stay as written in the Markdown source.
inline std::string markdown_text(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    const char next = i + 1 < s.size() ? s[i + 1] : '\0';
    const bool letter = (next >= 'a' && next <= 'z') || (next >= 'A' && next <= 'Z');
    if (c == '|' || c == '`' || c == '\\' ||
        (c == '<' && (letter || next == '/' || next == '!' || next == '?')) ||
        (c == '&' && (letter || next == '#')))
      out += '\\';
    out += c;
  }
  return out;
}

// `arg` as one shell word (single-quoted unless it is plain), for a command line a message
// tells the user to run: a database path with a space or a '#' printed unquoted broke the
// `--resume` command a warning suggested (review 2026-12-07).
inline std::string shell_word(const std::string& arg) {
  if (!arg.empty() && arg.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                                            "0123456789_./-+=:,@%") == std::string::npos)
    return arg;
  std::string q = "'";
  for (char c : arg) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace palplab
