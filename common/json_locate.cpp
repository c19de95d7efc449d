#include "common/json_locate.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/escape.hpp"
#include "common/file_kind.hpp"
#include "common/read_file.hpp"

namespace palplab::json {

namespace {
// A UTF-8 byte order mark opens the text: it is no character of line 1 (editors do not show
// it), and a file saved with one (Windows Notepad) had every location at 1:1 and its duplicate
// keys unseen (review 2026-12-07).
bool has_bom(std::string_view t) {
  return t.size() >= 3 && t.compare(0, 3, "\xEF\xBB\xBF") == 0;
}
}  // namespace

TextPos offset_to_pos(std::string_view text, std::size_t offset) {
  if (offset > text.size()) offset = text.size();
  TextPos p;
  p.line = 1;
  p.offset = static_cast<long>(offset);
  std::size_t line_start = 0;
  for (std::size_t i = 0; i < offset; ++i)
    if (text[i] == '\n') {
      ++p.line;
      line_start = i + 1;
    }
  if (line_start == 0 && has_bom(text) && offset >= 3) line_start = 3;
  p.column = 1 + static_cast<int>(utf8_length(text.substr(line_start, offset - line_start)));
  return p;
}

namespace {

bool is_identifier(std::string_view k) {
  if (k.empty()) return false;
  for (std::size_t i = 0; i < k.size(); ++i) {
    char c = k[i];
    bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' ||
              (i > 0 && c >= '0' && c <= '9');
    if (!ok) return false;
  }
  return true;
}

// Recursive scanner over valid JSON text that records value and key offsets per path.
class Scanner {
 public:
  Scanner(std::string_view t, std::unordered_map<std::string, std::pair<long, long>>& out,
          std::vector<std::pair<std::string, std::pair<long, long>>>& dups)
      : t_(t), out_(out), dups_(dups) {}

  void run() {
    if (has_bom(t_)) i_ = 3;  // a UTF-8 byte order mark (Notepad's): nlohmann skips it too
    skip_ws();
    value("$", -1);
  }

 private:
  void skip_ws() {
    while (i_ < t_.size() && (t_[i_] == ' ' || t_[i_] == '\t' || t_[i_] == '\n' || t_[i_] == '\r'))
      ++i_;
  }
  std::string string_literal() {
    // Decodes escapes well enough for key comparison; \u sequences are decoded to UTF-8.
    std::string s;
    ++i_;  // opening quote
    while (i_ < t_.size() && t_[i_] != '"') {
      char c = t_[i_++];
      if (c != '\\') {
        s += c;
        continue;
      }
      if (i_ >= t_.size()) break;
      char e = t_[i_++];
      switch (e) {
        case 'n':
          s += '\n';
          break;
        case 't':
          s += '\t';
          break;
        case 'r':
          s += '\r';
          break;
        case 'b':
          s += '\b';
          break;
        case 'f':
          s += '\f';
          break;
        case 'u': {
          unsigned cp = 0;
          for (int k = 0; k < 4 && i_ < t_.size(); ++k, ++i_) {
            char h = t_[i_];
            cp = cp * 16 + (h <= '9' ? h - '0' : (h | 0x20) - 'a' + 10);
          }
          if (cp < 0x80) {
            s += static_cast<char>(cp);
          } else if (cp < 0x800) {
            s += static_cast<char>(0xC0 | (cp >> 6));
            s += static_cast<char>(0x80 | (cp & 0x3F));
          } else {  // surrogate halves are kept as-is; only used for path names
            s += static_cast<char>(0xE0 | (cp >> 12));
            s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
            s += static_cast<char>(0x80 | (cp & 0x3F));
          }
          break;
        }
        default:
          s += e;
      }
    }
    ++i_;  // closing quote
    return s;
  }
  void value(const std::string& path, long key_off) {
    long voff = static_cast<long>(i_);
    auto [it, inserted] = out_.emplace(path, std::make_pair(voff, key_off < 0 ? voff : key_off));
    if (!inserted) {
      // Both definitions at their keys (array elements have none: their values).
      dups_.push_back({path, {it->second.second, key_off < 0 ? voff : key_off}});
      // Later members win in nlohmann::json, so point at the later one.
      it->second = {voff, key_off < 0 ? voff : key_off};
    }
    if (i_ >= t_.size()) return;
    char c = t_[i_];
    if (c == '{') {
      ++i_;
      skip_ws();
      if (i_ < t_.size() && t_[i_] == '}') {
        ++i_;
        return;
      }
      while (i_ < t_.size()) {
        skip_ws();
        long koff = static_cast<long>(i_);
        std::string k = string_literal();
        skip_ws();
        ++i_;  // ':'
        skip_ws();
        value(path_key(path, k), koff);
        skip_ws();
        if (i_ < t_.size() && t_[i_] == ',') {
          ++i_;
          continue;
        }
        ++i_;  // '}'
        break;
      }
    } else if (c == '[') {
      ++i_;
      skip_ws();
      if (i_ < t_.size() && t_[i_] == ']') {
        ++i_;
        return;
      }
      std::size_t n = 0;
      while (i_ < t_.size()) {
        skip_ws();
        value(path_index(path, n++), -1);
        skip_ws();
        if (i_ < t_.size() && t_[i_] == ',') {
          ++i_;
          continue;
        }
        ++i_;  // ']'
        break;
      }
    } else if (c == '"') {
      string_literal();
    } else {
      // number, true, false, null
      while (i_ < t_.size() && t_[i_] != ',' && t_[i_] != '}' && t_[i_] != ']' && t_[i_] != ' ' &&
             t_[i_] != '\n' && t_[i_] != '\r' && t_[i_] != '\t')
        ++i_;
    }
  }

  std::string_view t_;
  std::size_t i_ = 0;
  std::unordered_map<std::string, std::pair<long, long>>& out_;
  std::vector<std::pair<std::string, std::pair<long, long>>>& dups_;
};

}  // namespace

std::string path_key(std::string_view parent, std::string_view key) {
  std::string s(parent);
  if (is_identifier(key)) {
    s += '.';
    s += key;
  } else {
    s += "[\"";
    for (char c : key) {
      if (c == '"' || c == '\\') s += '\\';
      s += c;
    }
    s += "\"]";
  }
  return s;
}

std::string path_index(std::string_view parent, std::size_t index) {
  return std::string(parent) + "[" + std::to_string(index) + "]";
}

std::string normalize_path(std::string_view p) {
  if (!p.empty() && p[0] == '$') return std::string(p);
  std::string out = "$";
  std::size_t i = 0;
  while (i < p.size()) {
    if (p[i] != '/') {
      ++i;
      continue;
    }
    std::size_t j = p.find('/', i + 1);
    if (j == std::string_view::npos) j = p.size();
    std::string tok;
    for (std::size_t k = i + 1; k < j; ++k) {
      if (p[k] == '~' && k + 1 < j) {
        tok += p[k + 1] == '1' ? '/' : '~';
        ++k;
      } else {
        tok += p[k];
      }
    }
    bool numeric = !tok.empty() && tok.find_first_not_of("0123456789") == std::string::npos;
    out = numeric ? path_index(out, std::stoul(tok)) : path_key(out, tok);
    i = j;
  }
  return out;
}

namespace {

// Line/column of many offsets in one pass over the text (one offset_to_pos per value would be
// quadratic in the file size: validate time grew with the square of the number of groups).
class PosTable {
 public:
  PosTable(std::string_view text, std::vector<long> offsets) {
    std::sort(offsets.begin(), offsets.end());
    offsets.erase(std::unique(offsets.begin(), offsets.end()), offsets.end());
    TextPos p{1, 1, 0};
    std::size_t i = has_bom(text) ? 3 : 0;  // the mark is no column
    for (long off : offsets) {
      const std::size_t target = std::min(static_cast<std::size_t>(off), text.size());
      for (; i < target; ++i) {
        if (text[i] == '\n') {
          ++p.line;
          p.column = 1;
        } else if (!utf8_continuation(text[i])) {
          ++p.column;
        }
      }
      p.offset = off;
      pos_.emplace(off, p);
    }
  }
  TextPos at(long off) const { return pos_.at(off); }

 private:
  std::unordered_map<long, TextPos> pos_;
};

}  // namespace

JsonLocator::JsonLocator(std::string_view text) {
  std::unordered_map<std::string, std::pair<long, long>> raw;
  std::vector<std::pair<std::string, std::pair<long, long>>> dups;
  Scanner(text, raw, dups).run();
  std::vector<long> offs;
  offs.reserve(2 * raw.size() + 2 * dups.size());
  for (auto& [path, o] : raw) offs.insert(offs.end(), {o.first, o.second});
  for (auto& [path, o] : dups) offs.insert(offs.end(), {o.first, o.second});
  PosTable pos(text, std::move(offs));
  entries_.reserve(raw.size());
  for (auto& [path, o] : raw) entries_[path] = Entry{pos.at(o.first), pos.at(o.second)};
  for (auto& [path, o] : dups) {
    // The values under a repeated key repeat its path's children: only the key is a duplicate
    // (`"w": [[0]], "w": [[1]]` was reported at $.w, $.w[0] and $.w[0][0]). A key repeated
    // inside one copy is a duplicate of its own (inside the first copy it was hidden: review
    // 2026-12-06, fifth; inside the kept, later copy too: seventh): only a pair that straddles
    // the parent's repeat (its earlier half before the parent's later key) is dropped.
    const bool under_another = std::any_of(dups.begin(), dups.end(), [&](const auto& e) {
      return e.first.size() < path.size() && path.compare(0, e.first.size(), e.first) == 0 &&
             (path[e.first.size()] == '.' || path[e.first.size()] == '[') &&
             o.first < e.second.second && o.second >= e.second.second;
    });
    if (under_another) continue;
    DuplicateKey d;
    d.path = path;
    d.first = pos.at(o.first);
    d.second = pos.at(o.second);
    duplicates_.push_back(d);
  }
}

const JsonLocator::Entry* JsonLocator::find(std::string_view path) const {
  std::string p = normalize_path(path);
  while (true) {
    auto it = entries_.find(p);
    if (it != entries_.end()) return &it->second;
    if (p.size() <= 1) return nullptr;
    // Strip the last component: ".key", "[n]" or "[\"key\"]".
    std::size_t cut = std::string::npos;
    if (p.back() == ']') {
      // find the matching '[' (keys in brackets may contain ']' only escaped inside quotes)
      bool quoted = p.size() >= 2 && p[p.size() - 2] == '"';
      if (quoted) {
        std::size_t q = p.rfind("[\"", p.size() - 2);
        cut = q;
      } else {
        cut = p.rfind('[');
      }
    } else {
      cut = p.rfind('.');
    }
    if (cut == std::string::npos || cut == 0) {
      p = "$";
    } else {
      p.resize(cut);
    }
  }
}

TextPos JsonLocator::value(std::string_view path) const {
  const Entry* e = find(path);
  return e ? e->value : TextPos{};
}

TextPos JsonLocator::key(std::string_view path) const {
  const Entry* e = find(path);
  return e ? e->key : TextPos{};
}

bool JsonLocator::contains(std::string_view path) const {
  return entries_.count(normalize_path(path)) > 0;
}

SourceLocation JsonLocator::locate(const std::string& file, std::string_view path,
                                   bool at_key) const {
  TextPos p = at_key ? key(path) : value(path);
  SourceLocation loc;
  loc.file = file;
  loc.line = p.line;
  loc.column = p.column;
  loc.json_path = normalize_path(path);
  return loc;
}

std::size_t too_deep_at(std::string_view t) {
  int depth = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c == '"') {  // skip the string
      for (++i; i < t.size() && t[i] != '"'; ++i)
        if (t[i] == '\\') ++i;
    } else if (c == '{' || c == '[') {
      if (++depth > kMaxDepth) return i;
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
  return std::string_view::npos;
}

namespace {

// Checks made before nlohmann sees the text, so that hostile input ends in a located error:
// nesting deeper than kMaxDepth (the recursive locator and the DOM would otherwise use memory and
// stack without bound) and number literals that overflow a double (nlohmann throws an unlocated
// out_of_range for 1e400). Text that is not JSON is left to the parser's own syntax errors.
// Returns the number of member keys in the text (a ':' outside a string follows each key and
// nothing else in valid JSON).
std::size_t prescan(std::string_view t, const std::string& file) {
  auto fail = [&](std::size_t off, const std::string& what) {
    TextPos p = offset_to_pos(t, off);
    SourceLocation loc;
    loc.file = file;
    loc.line = p.line;
    loc.column = p.column;
    throw InputError(loc, what);
  };
  if (const std::size_t deep = too_deep_at(t); deep != std::string_view::npos)
    fail(deep, "invalid JSON: nested deeper than " + std::to_string(kMaxDepth) +
                   " levels (palplab files need a few)");
  std::size_t keys = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c == ':') {
      ++keys;
    } else if (c == '"') {  // skip the string
      for (++i; i < t.size() && t[i] != '"'; ++i)
        if (t[i] == '\\') ++i;
    } else if (c == '-' || (c >= '0' && c <= '9')) {
      std::size_t j = i;
      while (j < t.size() && (std::isdigit(static_cast<unsigned char>(t[j])) || t[j] == '-' ||
                              t[j] == '+' || t[j] == '.' || t[j] == 'e' || t[j] == 'E'))
        ++j;
      const std::string lit(t.substr(i, j - i));
      if (lit.size() > 1 || std::isdigit(static_cast<unsigned char>(c))) {
        const double x = std::strtod(lit.c_str(), nullptr);
        const std::string shown = lit.size() > 40 ? lit.substr(0, 40) + "..." : lit;
        if (std::isinf(x))
          fail(i, "number " + shown +
                      " is out of range (a JSON number must fit a double, |x| <= 1.8e308)");
        // A nonzero number below the smallest double was read as 0 ("got 0.0" said of 1e-400:
        // review 2026-12-06, eighth).
        const std::string mantissa = lit.substr(0, lit.find_first_of("eE"));
        if (x == 0 && mantissa.find_first_of("123456789") != std::string::npos)
          fail(i, "number " + shown +
                      " underflows to 0 (a nonzero JSON number must fit a double, |x| >= "
                      "4.9e-324): write 0, or the value in other units");
      }
      i = j - 1;
    }
  }
  return keys;
}

// The members of every object in j (nlohmann keeps one member per distinct key).
std::size_t count_members(const nlohmann::json& j) {
  std::size_t n = 0;
  if (j.is_object()) n += j.size();
  if (j.is_structured())
    for (const auto& v : j) n += count_members(v);
  return n;
}

}  // namespace

nlohmann::json parse_located(std::string_view text, const std::string& file,
                             std::vector<Problem>* duplicates) {
  // nlohmann's lexer takes a NUL byte for the end of the input: what followed it was ignored (a
  // study whose keys after a NUL were "missing", garbage after a valid document accepted).
  if (const auto nul = text.find('\0'); nul != std::string_view::npos) {
    const TextPos p = offset_to_pos(text, nul);
    // UTF-16 or UTF-32 (a file saved as "Unicode" by some editors) has NULs beside every ASCII
    // character.
    const char* const encoding = wide_unicode(text);
    const bool wide = encoding != nullptr;
    // palplab's own binary files, named where JSON goes (a scene given as the prototype: `probe
    // A.psim`; the results database as the study), are said by name.
    const char* kind = binary_file_kind(text);
    const std::string own = !kind ? std::string()
                            : text[0] == 'P'
                                ? std::string(kind) +
                                      ": give it with --scene, and the prototype's JSON file or id "
                                      "where a prototype goes"
                                : std::string(kind) + " (a results database?), not a JSON file";
    throw InputError(SourceLocation{file, wide || kind ? 1 : p.line, wide || kind ? 1 : p.column},
                     wide ? std::string("invalid JSON: the file is ") + encoding +
                                " text (expected UTF-8: save it as UTF-8)"
                     : kind ? "not JSON: the file is " + own
                            : std::string("invalid JSON: a NUL byte (JSON text has none: a binary "
                                          "file, or text damaged by a NUL)"));
  }
  const std::size_t keys = prescan(text, file);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text.begin(), text.end());
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte counts the characters read, so the offending character is at e.byte - 1.
    std::size_t off = e.byte > 0 ? e.byte - 1 : 0;
    TextPos p = offset_to_pos(text, off);
    std::string msg = e.what();
    // Drop nlohmann's "[json.exception.parse_error.101] parse error at line 3, column 5: ".
    auto colon = msg.find(": ", msg.find("parse error"));
    if (colon != std::string::npos) msg = msg.substr(colon + 2);
    SourceLocation loc;
    loc.file = file;
    loc.line = p.line;
    loc.column = p.column;
    throw InputError(loc, "invalid JSON: " + msg);
  } catch (const nlohmann::json::exception& e) {  // e.g. out_of_range: never an exit 3
    throw InputError(std::string("invalid JSON: ") + e.what(), file);
  }
  // A repeated key leaves fewer members than keys in the text; only then is the text located
  // (the locator records every value's path and position: most of the time parsing took).
  if (count_members(j) == keys) return j;
  JsonLocator loc(text);
  if (!loc.duplicates().empty()) {
    std::vector<Problem> ps;
    for (auto& d : loc.duplicates()) {
      SourceLocation where;
      where.file = file;
      where.line = d.second.line;
      where.column = d.second.column;
      where.json_path = d.path;
      ps.push_back({where, "duplicate key (also defined at line " + std::to_string(d.first.line) +
                               ", column " + std::to_string(d.first.column) +
                               "); each key may appear once"});
    }
    if (!duplicates) throw InputError(std::move(ps));
    duplicates->insert(duplicates->end(), ps.begin(), ps.end());
  }
  return j;
}

nlohmann::json parse_file_located(const std::string& path, std::string* text_out,
                                  std::vector<Problem>* duplicates) {
  // A palplab JSON file (study, prototype, material table, reported statistics) is kilobytes.
  std::string text = read_file_bounded(path, kMaxJsonFileBytes, "JSON file");
  nlohmann::json j = parse_located(text, path, duplicates);
  if (text_out) *text_out = std::move(text);
  return j;
}

}  // namespace palplab::json
