#include "results/store.hpp"

#include <fcntl.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <utility>

#include "common/escape.hpp"
#include "common/format.hpp"
#include "common/input_error.hpp"
#include "common/inputs.hpp"
#include "common/remove_on_signal.hpp"
#include "results/measure_kind.hpp"

namespace fs = std::filesystem;

namespace palplab::results {

namespace {

// A failed SQLite call. On the writer's own statements it is an internal error; reading a
// user's database (Store's read_* functions, via `reading`) turns it into an InputError that
// names the file. `code` is the primary result code (SQLITE_CORRUPT, SQLITE_ERROR, ...),
// `detail` SQLite's message without the statement.
struct SqliteError : std::runtime_error {
  SqliteError(int code_, std::string detail_, const std::string& what)
      : std::runtime_error(what), code(code_), detail(std::move(detail_)) {}
  int code;
  std::string detail;
};

// RAII prepared statement. Every value goes through bind_*; no SQL is built from data.
class Stmt {
 public:
  Stmt(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &st_, nullptr) != SQLITE_OK)
      throw SqliteError(sqlite3_errcode(db) & 0xff, sqlite3_errmsg(db),
                        std::string("sqlite prepare: ") + sqlite3_errmsg(db) + " in: " + sql);
  }
  ~Stmt() { sqlite3_finalize(st_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  Stmt& bind(int i, const std::string& s) {
    check(sqlite3_bind_text(st_, i, s.data(), static_cast<int>(s.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Stmt& bind(int i, double v) {
    check(sqlite3_bind_double(st_, i, v));
    return *this;
  }
  Stmt& bind(int i, long long v) {
    check(sqlite3_bind_int64(st_, i, v));
    return *this;
  }
  Stmt& bind(int i, int v) { return bind(i, static_cast<long long>(v)); }
  Stmt& bind_null(int i) {
    check(sqlite3_bind_null(st_, i));
    return *this;
  }
  Stmt& bind_blob(int i, const std::string& b) {
    check(sqlite3_bind_blob(st_, i, b.data(), static_cast<int>(b.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Stmt& bind_opt_text(int i, const std::string& s) { return s.empty() ? bind_null(i) : bind(i, s); }

  bool step() {
    int rc = sqlite3_step(st_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw SqliteError(rc & 0xff, sqlite3_errmsg(db_),
                      std::string("sqlite step: ") + sqlite3_errmsg(db_));
  }
  void run() {
    step();
    sqlite3_reset(st_);
    sqlite3_clear_bindings(st_);
  }
  std::string text(int c) const {
    auto p = sqlite3_column_text(st_, c);
    return p ? std::string(reinterpret_cast<const char*>(p), sqlite3_column_bytes(st_, c)) : "";
  }
  std::string blob(int c) const {
    auto p = sqlite3_column_blob(st_, c);
    return p ? std::string(static_cast<const char*>(p), sqlite3_column_bytes(st_, c)) : "";
  }
  double real(int c) const { return sqlite3_column_double(st_, c); }
  long long integer(int c) const { return sqlite3_column_int64(st_, c); }
  bool null(int c) const { return sqlite3_column_type(st_, c) == SQLITE_NULL; }
  int type(int c) const { return sqlite3_column_type(st_, c); }

 private:
  void check(int rc) {
    if (rc != SQLITE_OK)
      throw SqliteError(rc & 0xff, sqlite3_errmsg(db_),
                        std::string("sqlite bind: ") + sqlite3_errmsg(db_));
  }
  sqlite3* db_;
  sqlite3_stmt* st_ = nullptr;
};

void exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  if (const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err); rc != SQLITE_OK) {
    std::string m = err ? err : "?";
    sqlite3_free(err);
    throw SqliteError(rc & 0xff, m, "sqlite: " + m);
  }
}

// Ends a failed write transaction and rethrows what failed (inside a catch block). SQLite has
// already rolled back after some errors (a full disk): a ROLLBACK then fails with "no
// transaction is active", which used to replace the real error ("internal error: cannot
// rollback"). A full disk or an I/O error is said as such (exit 2), with what is kept.
[[noreturn]] void roll_back_and_rethrow(sqlite3* db, const std::string& path) {
  if (!sqlite3_get_autocommit(db)) sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
  try {
    throw;
  } catch (const SqliteError& e) {
    if (e.code != SQLITE_FULL && e.code != SQLITE_IOERR) throw;
    throw InputError(std::string("cannot write the database: ") +
                         (e.code == SQLITE_FULL ? "the disk is full" : "an input/output error") +
                         " (sqlite: " + e.detail +
                         "); what it held before this write is kept: make room, then continue "
                         "the run with `palplab run STUDY --db " +
                         shell_word(path) + " --resume`",
                     path);
  }
}

// "session 12 (participant P03, phase post_training #1)": where a bad stored value is.
std::string session_label(long long session, const std::string& participant,
                          const std::string& phase, int phase_index) {
  return "session " + std::to_string(session) + " (participant " + participant + ", phase " +
         phase + " #" + std::to_string(phase_index + 1) + ")";
}
std::string session_label(const MeasureRow& r) {
  return session_label(r.session, r.participant, r.phase, r.phase_index);
}

// A stored value as a message shows it: 2.5, inf, 'abc', (a blob), NULL.
std::string stored_value(const Stmt& q, int c) {
  switch (q.type(c)) {
    case SQLITE_INTEGER:
      return std::to_string(q.integer(c));
    case SQLITE_FLOAT:
      return format_shortest(q.real(c));
    case SQLITE_TEXT:
      return "'" + shown_text(q.text(c), 40) + "'";
    case SQLITE_BLOB:
      return "(a blob)";
    default:
      return "NULL";
  }
}

// The typed columns of one row of a user's database, read as the schema types them: a value a
// hand edit (or damage) left there that is not (text in a REAL column, ±inf, a fraction in an
// INTEGER column, NULL in a NOT NULL one) is refused with an InputError naming the table, the
// row, the column and what was expected, instead of being read as 0 or exported as inf. One
// sqlite3_column_type call per value; `row` (a callable giving the row's description) is only
// called on an error.
template <class Row>
class Typed {
 public:
  Typed(const Stmt& q, const std::string& path, const char* table, Row row)
      : q_(q), path_(path), table_(table), row_(std::move(row)) {}

  // REAL column: a finite number (REAL affinity stores numbers as REAL; INTEGER accepted too).
  double real(int c, const char* column) const {
    const int t = q_.type(c);
    if (t == SQLITE_FLOAT || t == SQLITE_INTEGER) {
      const double v = q_.real(c);
      if (std::isfinite(v)) return v;
    }
    fail(c, column, "a finite number");
  }
  // INTEGER column: an integer in [lo, hi].
  long long integer(int c, const char* column, long long lo, long long hi) const {
    if (q_.type(c) == SQLITE_INTEGER) {
      const long long v = q_.integer(c);
      if (v >= lo && v <= hi) return v;
    }
    fail(c, column,
         hi == std::numeric_limits<long long>::max()
             ? "an integer >= " + std::to_string(lo)
             : "an integer from " + std::to_string(lo) + " to " + std::to_string(hi));
  }
  int int32(int c, const char* column) const {
    return static_cast<int>(integer(c, column, 0, std::numeric_limits<int>::max()));
  }
  // Nullable 0/1 switch (NULL = not recorded).
  std::optional<bool> flag(int c, const char* column) const {
    if (q_.null(c)) return std::nullopt;
    return integer(c, column, 0, 1) != 0;
  }
  // TEXT column holding an unsigned 64-bit integer in decimal (seeds).
  std::uint64_t u64(int c, const char* column) const {
    if (q_.type(c) == SQLITE_TEXT) {
      const std::string s = q_.text(c);
      std::uint64_t v = 0;
      const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
      if (r.ec == std::errc() && r.ptr == s.data() + s.size()) return v;
    }
    fail(c, column, "an unsigned 64-bit integer in decimal");
  }

 private:
  [[noreturn]] void fail(int c, const char* column, const std::string& expected) const {
    throw InputError("table " + std::string(table_) + ", row (" + row_() + ") column " + column +
                         ": expected " + expected + ", got " + stored_value(q_, c),
                     path_);
  }
  const Stmt& q_;
  const std::string& path_;
  const char* table_;
  Row row_;
};

sqlite3* open_db(const std::string& path, int flags) {
  note_input(path);  // never written through by an output (common/inputs.hpp)
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, flags, nullptr) != SQLITE_OK) {
    std::string m = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    throw InputError("cannot open database: " + m, path);
  }
  sqlite3_busy_timeout(db, 10000);
  return db;
}

// What reading a user's database failed on, said about the file: exit 2 with the reason, never
// an "internal error" (a damaged file, tables dropped or edited by hand, a foreign schema).
InputError read_error(const std::string& path, const SqliteError& e) {
  switch (e.code) {
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return InputError("damaged or truncated database (sqlite: " + e.detail + ")", path);
    case SQLITE_ERROR:  // no such table/column: not the schema palplab wrote
      return InputError("not a complete palplab results database (sqlite: " + e.detail + ")", path);
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return InputError("the database is locked by another process (sqlite: " + e.detail + ")",
                        path);
    default:
      return InputError("cannot read the database (sqlite: " + e.detail + ")", path);
  }
}

// Runs `f` (a read of the user's database at `path`), turning SQLite failures into InputError.
template <class F>
auto reading(const std::string& path, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const SqliteError& e) {
    throw read_error(path, e);
  }
}

void put_varint(std::string& out, std::uint64_t v) {
  while (v >= 0x80) {
    out += static_cast<char>((v & 0x7F) | 0x80);
    v >>= 7;
  }
  out += static_cast<char>(v);
}

}  // namespace

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// ---- sample encoding 'qdv1': per sample 7 integers (x, y, z in um; Fx, Fy, Fz in 0.1 mN;
// node + 1), each stored as the zigzag varint of its difference to the previous sample's
// (the first sample of a blob is relative to 0).
std::string encode_samples(const SampleSeries& s, std::size_t begin, std::size_t end) {
  std::string out;
  out.reserve((end - begin) * 9);
  long long prev[7] = {0, 0, 0, 0, 0, 0, 0};
  for (std::size_t i = begin; i < end; ++i) {
    long long q[7];
    for (int k = 0; k < 3; ++k) q[k] = std::llround(s.x[3 * i + k] * 1e6);
    for (int k = 0; k < 3; ++k) q[3 + k] = std::llround(s.F[3 * i + k] * 1e4);
    q[6] = s.node[i] + 1;
    for (int k = 0; k < 7; ++k) {
      long long d = q[k] - prev[k];
      put_varint(out, (static_cast<std::uint64_t>(d) << 1) ^ static_cast<std::uint64_t>(d >> 63));
      prev[k] = q[k];
    }
  }
  return out;
}

void decode_samples(const std::string& blob, std::size_t n, double t0, double dt,
                    SampleSeries& out) {
  (void)t0;
  (void)dt;
  long long prev[7] = {0, 0, 0, 0, 0, 0, 0};
  std::size_t p = 0;
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 7; ++k) {
      std::uint64_t v = 0;
      int shift = 0;
      while (true) {
        if (p >= blob.size()) throw std::runtime_error("corrupt sample blob (truncated)");
        auto b = static_cast<unsigned char>(blob[p++]);
        v |= static_cast<std::uint64_t>(b & 0x7F) << shift;
        if (!(b & 0x80)) break;
        shift += 7;
      }
      long long d = static_cast<long long>(v >> 1) ^ -static_cast<long long>(v & 1);
      prev[k] += d;
    }
    for (int k = 0; k < 3; ++k) out.x.push_back(prev[k] * 1e-6);
    for (int k = 0; k < 3; ++k) out.F.push_back(prev[3 + k] * 1e-4);
    out.node.push_back(static_cast<int>(prev[6] - 1));
  }
}

Store::Store(sqlite3* db, std::string path)
    : db_(db), path_(std::move(path)), mu_(std::make_unique<std::mutex>()) {}
Store::Store(Store&& o) noexcept
    : db_(std::exchange(o.db_, nullptr)),
      path_(std::move(o.path_)),
      mu_(std::move(o.mu_)),
      lock_fd_(std::exchange(o.lock_fd_, -1)),
      version_(o.version_) {}
Store& Store::operator=(Store&& o) noexcept {
  if (this != &o) {
    if (db_) sqlite3_close(db_);
    if (lock_fd_ >= 0) ::close(lock_fd_);
    db_ = std::exchange(o.db_, nullptr);
    path_ = std::move(o.path_);
    mu_ = std::move(o.mu_);
    lock_fd_ = std::exchange(o.lock_fd_, -1);
    version_ = o.version_;
  }
  return *this;
}
Store::~Store() {
  if (db_) sqlite3_close(db_);
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the writer's lock
}

namespace {

// The directory a database's -wal/-shm files go to.
fs::path dir_of(const std::string& path) {
  fs::path d = fs::path(path).parent_path();
  return d.empty() ? fs::path(".") : d;
}

// Writing needs the file and its directory (SQLite's WAL creates PATH-wal and PATH-shm there).
void require_writable(const std::string& path, bool file_exists) {
  const fs::path d = dir_of(path);
  std::error_code ec;
  const auto st = fs::status(d, ec);
  if (!fs::exists(st))
    throw InputError("cannot create the database: its directory " + d.string() + " does not exist",
                     path);
  if (!fs::is_directory(st))
    throw InputError("cannot create the database: " + d.string() + " is not a directory", path);
  if (::access(d.c_str(), W_OK) != 0)
    throw InputError("cannot write the database: its directory " + d.string() +
                         " is read-only (palplab writes PATH, PATH-wal and PATH-shm there)",
                     path);
  if (file_exists && ::access(path.c_str(), W_OK) != 0)
    throw InputError("cannot write the database: the file is read-only", path);
  // SQLite creates PATH-wal and PATH-shm with the database file's permissions: after a read of
  // a read-only file, then `chmod u+w` of the file alone, they stay read-only.
  for (const char* suffix : {"-wal", "-shm"})
    if (file_exists && fs::exists(path + suffix, ec) &&
        ::access((path + suffix).c_str(), W_OK) != 0)
      throw InputError(std::string("cannot write the database: its ") + suffix +
                           " file is read-only (make it writable like the database, or delete "
                           "it if it is empty)",
                       path);
}

// An exclusive advisory lock held by the one writer (flock: independent of SQLite's own
// fcntl locks, released by the kernel when the process ends, even on kill -9).
int lock_exclusive(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(std::string("cannot open database: ") + std::strerror(errno), path);
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    throw InputError(
        "the database is in use by another palplab process (a run or resume is writing it); "
        "wait for it to finish",
        path);
  }
  return fd;
}

// What a read-only look at `path` finds: not SQLite at all, an SQLite file SQLite reports as
// damaged (a truncated copy: SQLITE_CORRUPT / SQLITE_NOTADB, or a failing quick_check), an
// SQLite file without palplab's meta table, or a palplab results database.
struct Probe {
  enum Kind { kNotSqlite, kDamaged, kNotPalplab, kPalplab, kUnreadable } kind = kNotSqlite;
  std::string detail;  // kDamaged: SQLite's words; kUnreadable: theirs and the system's reason
};

// An SQLite URI naming exactly `path`: SQLite decodes %HH and ends the path at '?' or '#', so
// "x%41.db" would name xA.db and "a#b.db" a; every byte outside a safe set is %-encoded (a
// leading "//" too: it would start an authority).
std::string sqlite_uri(const std::string& path, const std::string& query) {
  static const char* hex = "0123456789ABCDEF";
  std::string out = "file:";
  for (std::size_t i = 0; i < path.size(); ++i) {
    const auto c = static_cast<unsigned char>(path[i]);
    const bool safe = std::isalnum(c) || c == '.' || c == '_' || c == '-' || c == '~' ||
                      (c == '/' && !(i == 1 && path[0] == '/'));
    if (safe) {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out + "?" + query;
}

Probe probe_db(const std::string& path) {
  static const std::string kMagic("SQLite format 3\0", 16);
  {
    std::ifstream in(path, std::ios::binary);
    char head[100] = {};
    in.read(head, sizeof head);
    const auto got = static_cast<std::size_t>(in.gcount());
    if (got == 0 || kMagic.compare(0, std::min<std::size_t>(got, 16), head,
                                   std::min<std::size_t>(got, 16)) != 0)
      return {Probe::kNotSqlite, ""};
    if (got < 100)  // the start of an SQLite file, cut inside its 100-byte header
      return {Probe::kDamaged,
              "the file ends inside the 100-byte SQLite header, at byte " + std::to_string(got)};
  }
  sqlite3* db = nullptr;
  const std::string uri = sqlite_uri(path, "mode=ro");
  if (sqlite3_open_v2(uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) !=
      SQLITE_OK) {
    sqlite3_close(db);
    return {Probe::kNotPalplab, ""};
  }
  Probe out{Probe::kNotPalplab, ""};
  sqlite3_stmt* st = nullptr;
  int rc = sqlite3_prepare_v2(db, "SELECT value FROM meta WHERE key = 'schema_version'", -1, &st,
                              nullptr);
  if (rc == SQLITE_OK) rc = sqlite3_step(st);
  // An I/O failure (a full disk or a file-size limit when SQLite makes PATH-shm for a WAL
  // database) says nothing of the file's content: it is said as such, not as "not palplab's".
  auto io_failure = [&](int code) {
    const int c = code & 0xff;
    if (c != SQLITE_IOERR && c != SQLITE_FULL && c != SQLITE_CANTOPEN && c != SQLITE_NOMEM)
      return false;
    const int sys = sqlite3_system_errno(db);
    out = {Probe::kUnreadable, std::string(sqlite3_errmsg(db)) +
                                   (sys != 0 ? std::string(": ") + std::strerror(sys) : "")};
    return true;
  };
  if (rc == SQLITE_ROW) {
    out.kind = Probe::kPalplab;
  } else if ((rc & 0xff) == SQLITE_CORRUPT || (rc & 0xff) == SQLITE_NOTADB) {
    out = {Probe::kDamaged, sqlite3_errmsg(db)};
  } else if (!io_failure(rc)) {
    // No meta table: another SQLite file, or one damaged where the meta table was. Only
    // here (a refusal anyway) does the whole file get checked.
    sqlite3_finalize(st);
    st = nullptr;
    rc = sqlite3_prepare_v2(db, "PRAGMA quick_check(1)", -1, &st, nullptr);
    if (rc == SQLITE_OK) rc = sqlite3_step(st);
    if (rc == SQLITE_ROW) {
      const auto* t = sqlite3_column_text(st, 0);
      const std::string r = t ? reinterpret_cast<const char*>(t) : "";
      if (r != "ok") out = {Probe::kDamaged, "quick_check: " + r};
    } else if ((rc & 0xff) == SQLITE_CORRUPT || (rc & 0xff) == SQLITE_NOTADB) {
      out = {Probe::kDamaged, sqlite3_errmsg(db)};
    } else {
      io_failure(rc);
    }
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  return out;
}

std::string damaged(const std::string& detail) {
  return "damaged or truncated database (sqlite: " + detail + ")";
}

}  // namespace

bool Store::is_empty_leftover(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(path, ec))) return false;
  if (fs::file_size(path, ec) == 0 && !ec) return true;
  if (probe_db(path).kind != Probe::kNotPalplab) return false;
  // An SQLite file without a single table or index (its uncommitted -wal frames, if any, are
  // not part of it).
  sqlite3* db = nullptr;
  const std::string uri = sqlite_uri(path, "mode=ro");
  bool empty = false;
  if (sqlite3_open_v2(uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) ==
      SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db, "SELECT COUNT(*) FROM sqlite_master", -1, &st, nullptr) ==
            SQLITE_OK &&
        sqlite3_step(st) == SQLITE_ROW)
      empty = sqlite3_column_int64(st, 0) == 0;
    sqlite3_finalize(st);
  }
  sqlite3_close(db);
  return empty;
}

// A run killed inside its first transaction (the schema, before the file is switched to WAL)
// leaves PATH-journal, a hot rollback journal: read-only connections cannot read the file until
// it is rolled back, which SQLite does on the first read of a read-write connection. Only
// writers call this (SQLite's own recovery, as any writer's first read would do it).
namespace {
void roll_back_hot_journal(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path + "-journal", ec)) return;
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr) == SQLITE_OK)
    sqlite3_exec(db, "SELECT COUNT(*) FROM sqlite_master", nullptr, nullptr, nullptr);
  sqlite3_close(db);
}
}  // namespace

bool Store::remove_empty_leftover(const std::string& path) {
  // Only writers call this: refused before the probe's read-only open creates PATH-wal/-shm.
  require_writable(path, true);
  roll_back_hot_journal(path);
  if (!is_empty_leftover(path)) return false;
  const int fd = lock_exclusive(path);  // then looked at again: nobody may have started meanwhile
  if (!is_empty_leftover(path)) {
    ::close(fd);
    throw InputError(
        "another palplab process started a run in this database meanwhile; nothing was replaced",
        path);
  }
  std::error_code ec;
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) fs::remove(path + suffix, ec);
  ::close(fd);
  return true;
}

void Store::remove_existing(const std::string& path) {
  std::error_code ec;
  const auto st = fs::symlink_status(path, ec);
  if (ec || !fs::exists(st)) return;
  if (!fs::is_regular_file(st))
    throw InputError(
        "refusing to replace it: not a regular file (--force only replaces a palplab "
        "results database)",
        path);
  // (Before the look inside: in a read-only directory a WAL database cannot even be opened, and
  // "not a palplab results database" would be the wrong reason.)
  require_writable(path, true);
  if (remove_empty_leftover(path)) return;
  if (const Probe p = probe_db(path); p.kind == Probe::kUnreadable)
    throw InputError("refusing to replace it: cannot read it (" + p.detail + ")", path);
  else if (p.kind == Probe::kDamaged)
    throw InputError("refusing to replace it: " + damaged(p.detail) +
                         "; palplab cannot tell whether it is a results database (if it is, "
                         "move or delete it yourself)",
                     path);
  else if (p.kind != Probe::kPalplab)
    throw InputError(
        "refusing to replace it: not a palplab results database (--force only "
        "replaces a database written by palplab run)",
        path);
  const int fd = lock_exclusive(path);  // not while another process writes it
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(path + suffix, ec);
  ::close(fd);
}

namespace {

// Schema 1/2 -> 3: the sessions table gains the attempt/status/trainee/device/started_at/
// abort_reason columns and its UNIQUE key becomes (participant, ordinal, attempt). SQLite cannot
// change a table constraint in place, so the table is rebuilt (the documented 12-step
// procedure: foreign keys off, new table, copy, drop, rename), all in one transaction; session
// ids are kept, so measures/events/samples still refer to the same rows.
void migrate_sessions_to_v3(sqlite3* db) {
  exec(db, "PRAGMA foreign_keys=OFF");
  exec(db, "BEGIN IMMEDIATE");
  try {
    exec(db,
         "CREATE TABLE sessions_v3 (session INTEGER PRIMARY KEY, participant TEXT NOT NULL "
         "REFERENCES participants (participant), ordinal INTEGER NOT NULL, phase TEXT NOT NULL, "
         "phase_index INTEGER NOT NULL, prototype TEXT NOT NULL, instructor TEXT, study_offset "
         "REAL NOT NULL, day INTEGER NOT NULL, duration REAL NOT NULL, steps INTEGER NOT NULL, "
         "wall_duration REAL NOT NULL, loop_median REAL NOT NULL, loop_p99 REAL NOT NULL, seed "
         "TEXT NOT NULL, state_after TEXT NOT NULL, completed_at TEXT NOT NULL, attempt INTEGER "
         "NOT NULL DEFAULT 0, status TEXT NOT NULL DEFAULT 'complete', trainee TEXT NOT NULL "
         "DEFAULT 'virtual', device TEXT, started_at TEXT, abort_reason TEXT, UNIQUE "
         "(participant, ordinal, attempt));"
         "INSERT INTO sessions_v3 (session, participant, ordinal, phase, phase_index, prototype, "
         "instructor, study_offset, day, duration, steps, wall_duration, loop_median, loop_p99, "
         "seed, state_after, completed_at) SELECT session, participant, ordinal, phase, "
         "phase_index, prototype, instructor, study_offset, day, duration, steps, wall_duration, "
         "loop_median, loop_p99, seed, state_after, completed_at FROM sessions;"
         "DROP TABLE sessions;"
         "ALTER TABLE sessions_v3 RENAME TO sessions;"
         "UPDATE meta SET value = '3' WHERE key = 'schema_version';"
         "INSERT OR REPLACE INTO meta(key, value) VALUES ('migrated_to_3_at', '" +
             utc_now() +
             "');"
             "PRAGMA user_version = 3;");
    exec(db, "COMMIT");
  } catch (...) {
    if (!sqlite3_get_autocommit(db)) sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
    exec(db, "PRAGMA foreign_keys=ON");
    throw;
  }
  exec(db, "PRAGMA foreign_keys=ON");
}

// Schema 3 -> 4: phases and sessions gain their (nullable) transparency column; old rows read
// NULL (not recorded). Adding a nullable column needs no table rebuild.
// (A database begun as version 1 has no phases table: only sessions change.)
void migrate_to_v4(sqlite3* db) {
  bool phases = false;
  {
    Stmt q(db, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'phases'");
    phases = q.step();
  }
  exec(db, "BEGIN IMMEDIATE");
  try {
    if (phases) exec(db, "ALTER TABLE phases ADD COLUMN transparency INTEGER;");
    exec(db,
         "ALTER TABLE sessions ADD COLUMN transparency INTEGER;"
         "UPDATE meta SET value = '4' WHERE key = 'schema_version';"
         "INSERT OR REPLACE INTO meta(key, value) VALUES ('migrated_to_4_at', '" +
             utc_now() +
             "');"
             "PRAGMA user_version = 4;");
    exec(db, "COMMIT");
  } catch (...) {
    if (!sqlite3_get_autocommit(db)) sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

}  // namespace

namespace {

using TableColumns = std::vector<std::pair<std::string, std::vector<std::string>>>;

// The tables and columns a database of schema `version` has: those of results/schema.sql less
// what later versions added (version 2: study_groups, phases, thresholds; 3: the sessions
// columns of human sessions; 4: the transparency columns).
TableColumns expected_tables(int version) {
  static const TableColumns current = [] {
    sqlite3* mem = nullptr;
    sqlite3_open(":memory:", &mem);
    std::unique_ptr<sqlite3, int (*)(sqlite3*)> hold(mem, sqlite3_close);
    exec(mem, schema_sql());
    TableColumns out;
    Stmt t(mem, "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY rowid");
    while (t.step()) {
      out.push_back({t.text(0), {}});
      Stmt c(mem, "SELECT name FROM pragma_table_info(?1) ORDER BY cid");
      c.bind(1, t.text(0));
      while (c.step()) out.back().second.push_back(c.text(0));
    }
    return out;
  }();
  auto added_after = [version](const std::string& table, const std::string& column) {
    if (version < 2 && (table == "study_groups" || table == "phases" || table == "thresholds"))
      return true;
    if (version < 3 && table == "sessions" &&
        (column == "attempt" || column == "status" || column == "trainee" || column == "device" ||
         column == "started_at" || column == "abort_reason"))
      return true;
    return version < 4 && (table == "sessions" || table == "phases") && column == "transparency";
  };
  TableColumns out;
  for (const auto& [table, columns] : current) {
    if (added_after(table, "")) continue;
    std::vector<std::string> keep;
    for (const auto& c : columns)
      if (!added_after(table, c)) keep.push_back(c);
    out.push_back({table, keep});
  }
  return out;
}

// Every table (and column) that schema `version` has is there: a table dropped or a column
// lost (a hand edit, a foreign tool) is said when the database is opened, naming it, instead
// of as an SQL error in the middle of a report.
void check_tables(sqlite3* db, int version, const std::string& path) {
  for (const auto& [table, columns] : expected_tables(version)) {
    Stmt q(db, "SELECT name FROM pragma_table_info(?1)");
    q.bind(1, table);
    std::vector<std::string> have;
    while (q.step()) have.push_back(q.text(0));
    if (have.empty())
      throw InputError("not a complete palplab results database: table \"" + table +
                           "\" is missing (schema version " + std::to_string(version) + ")",
                       path);
    std::string missing;
    for (const auto& c : columns)
      if (std::find(have.begin(), have.end(), c) == have.end())
        missing += (missing.empty() ? "" : ", ") + c;
    if (!missing.empty())
      throw InputError("not a complete palplab results database: table \"" + table +
                           "\" lacks the column(s) " + missing + " (schema version " +
                           std::to_string(version) + ")",
                       path);
  }
}

// Rows that refer to a row that is not there (a hand edit with foreign keys off, a foreign tool):
// the readers join the tables, so a session of a participant the database does not hold (and
// its measures, events and samples) would be left out of every export and report without a
// word. (Samples are stored one row per second of a session: a scan is cheap.)
void check_references(sqlite3* db, int version, const std::string& path) {
  struct Ref {
    const char *table, *held, *sql;
  };
  // Each names the referring row and the value it refers to as stored (a hand edit may have put
  // 2.5 or 'abc' there, which must not be shown as 2 or 0).
  const Ref refs[] = {
      {"sessions", "participants",
       "SELECT 'session ' || x.session, 'participant ' || quote(x.participant) FROM sessions x "
       "LEFT JOIN participants p ON p.participant = x.participant WHERE p.participant IS NULL "
       "LIMIT 1"},
      {"measures", "sessions",
       "SELECT 'measure ' || quote(x.name), 'session ' || quote(x.session) FROM measures x "
       "LEFT JOIN sessions s ON s.session = x.session WHERE s.session IS NULL LIMIT 1"},
      {"events", "sessions",
       "SELECT 'event ' || quote(x.kind), 'session ' || quote(x.session) FROM events x "
       "LEFT JOIN sessions s ON s.session = x.session WHERE s.session IS NULL LIMIT 1"},
      {"samples", "sessions",
       "SELECT 'samples of second ' || quote(x.second), 'session ' || quote(x.session) FROM "
       "samples x LEFT JOIN sessions s ON s.session = x.session WHERE s.session IS NULL LIMIT 1"},
  };
  // The first row `r` finds: "table T: ROW names VALUE" + `why`.
  const auto refuse = [&](const Ref& r, const std::string& why) {
    Stmt q(db, r.sql);
    if (!q.step()) return;
    throw InputError("not a consistent palplab results database: table " + std::string(r.table) +
                         ": " + escape_controls(q.text(0), false) + " names " +
                         escape_controls(q.text(1), false) + why,
                     path);
  };
  for (const Ref& r : refs)
    refuse(r, ", which table " + std::string(r.held) +
                  " does not hold (edited by hand or by another tool? its rows would be left out "
                  "of every export and report)");
  // The study's structure (schema 2 on): a participant of a group the study does not declare
  // was dropped from every analysis (its group printed in the provenance only), a session of an
  // undeclared phase or beyond its phase's sessions was exported and analysed as given, a
  // status other than complete/running/aborted was taken as not complete (review 2026-12-07).
  if (version < 2) return;
  const Ref structure[] = {
      {"participants", "study_groups",
       "SELECT 'participant ' || quote(x.participant), 'group ' || quote(x.grp) FROM "
       "participants x WHERE EXISTS (SELECT 1 FROM study_groups) AND x.grp NOT IN (SELECT grp "
       "FROM study_groups) LIMIT 1"},
      {"sessions", "phases",
       "SELECT 'session ' || x.session, 'phase ' || quote(x.phase) FROM sessions x WHERE EXISTS "
       "(SELECT 1 FROM phases) AND x.phase NOT IN (SELECT phase FROM phases) LIMIT 1"},
      {"sessions", "prototypes",
       "SELECT 'session ' || x.session, 'prototype ' || quote(x.prototype) FROM sessions x WHERE "
       "EXISTS (SELECT 1 FROM prototypes) AND x.prototype NOT IN (SELECT prototype FROM "
       "prototypes) LIMIT 1"},
  };
  for (const Ref& r : structure)
    refuse(r, ", which the study's table " + std::string(r.held) +
                  " does not declare (edited by hand or by another tool?)");
  {
    Stmt q(db,
           "SELECT 'session ' || x.session, quote(x.phase_index), p.sessions, quote(x.phase) FROM "
           "sessions x JOIN phases p ON p.phase = x.phase WHERE typeof(x.phase_index) = "
           "'integer' AND typeof(p.sessions) = 'integer' AND p.sessions >= 1 AND (x.phase_index < "
           "0 OR x.phase_index "
           ">= p.sessions) LIMIT 1");
    if (q.step())
      throw InputError("not a consistent palplab results database: table sessions: " +
                           escape_controls(q.text(0), false) + " has phase_index " + q.text(1) +
                           (q.integer(1) < 0 ? std::string(" (of phase ")
                                             : " (its session " + std::to_string(q.integer(1) + 1) +
                                                   " of phase ") +
                           escape_controls(q.text(3), false) + "), which has " + q.text(2) +
                           " session(s): expected 0 to " + std::to_string(q.integer(2) - 1) +
                           " (edited by hand or by another tool?)",
                       path);
  }
  {
    // One complete session per participant, phase and number: two were exported as two rows
    // of one session (review of the fix, 2026-12-07). (Aborted attempts of a human session
    // share their number with the complete one.)
    const std::string complete = version >= 3 ? " AND a.status = 'complete' AND b.status = "
                                                "'complete'"
                                              : "";
    const std::string sql =
        "SELECT 'session ' || b.session, a.session, quote(a.participant), quote(a.phase), "
        "a.phase_index FROM sessions a JOIN sessions b ON a.participant = b.participant AND "
        "a.phase = b.phase AND a.phase_index = b.phase_index AND a.session < b.session" +
        complete + " LIMIT 1";
    Stmt q(db, sql.c_str());
    if (q.step())
      throw InputError("not a consistent palplab results database: table sessions: " +
                           escape_controls(q.text(0), false) + " is session " + q.text(1) +
                           " again (participant " + escape_controls(q.text(2), false) + ", phase " +
                           escape_controls(q.text(3), false) + ", phase_index " + q.text(4) +
                           "; edited by hand or by another tool?)",
                       path);
  }
  {
    // Values the report and export read as they are: a phase kind 'bogus', a duration of -1 s,
    // an MPF of -2 N (printed, then said to be missing), feature_identified 2 (a CI of [-4.9,
    // 7.9]), a measure's unit changed to kN (its column relabelled) were taken (review
    // 2026-12-07). Each query gives the row and what is wrong with it.
    const char* const values[] = {
        "SELECT 'phase ' || quote(phase), 'kind ' || quote(kind) || ': expected pre_training, "
        "training, post_training or other' FROM phases WHERE kind NOT IN ('pre_training', "
        "'training', 'post_training', 'other') LIMIT 1",
        // Numbers out of range (a value that is no number at all is said by the readers,
        // with the participant it belongs to).
        "SELECT 'phase ' || quote(phase), 'session_duration ' || quote(session_duration) || ': "
        "expected a duration in s > 0' FROM phases WHERE typeof(session_duration) IN "
        "('integer', 'real') AND NOT session_duration > 0 LIMIT 1",
        "SELECT 'thresholds of phase ' || quote(phase) || ', region ' || quote(region), 'ST ' || "
        "quote(st) || ', MPF ' || quote(mpf) || ', SFT ' || quote(sft) || ': expected forces in "
        "N > 0 with ST < SFT and MPF <= SFT' FROM thresholds WHERE (typeof(st) IN ('integer', "
        "'real') AND NOT st > 0) OR (typeof(mpf) IN ('integer', 'real') AND NOT mpf > 0) OR "
        "(typeof(sft) IN ('integer', 'real') AND NOT sft > 0) OR (typeof(st) IN ('integer', "
        "'real') AND typeof(sft) IN ('integer', 'real') AND NOT st < sft) OR (typeof(mpf) IN "
        "('integer', 'real') AND typeof(sft) IN ('integer', 'real') AND NOT mpf <= sft) LIMIT 1",
        "SELECT 'phase ' || quote(phase), 'sessions ' || quote(sessions) || ': expected a count "
        ">= 1' FROM phases WHERE typeof(sessions) = 'integer' AND sessions < 1 LIMIT 1",
    };
    // The measures palplab computes, with their units and ranges (results::kMeasureKinds).
    std::string known;
    for (const MeasureKind& k : kMeasureKinds) {
      const bool bounded = std::isfinite(k.hi);
      char hi[32];
      std::snprintf(hi, sizeof hi, "%.17g", k.hi);
      known += std::string(known.empty() ? "" : ", ") + "('" + std::string(k.name) + "', '" +
               std::string(k.unit) + "', " + (bounded ? hi : "NULL") + ", '" +
               (bounded ? "in [0, " + std::string(hi) + "]" : std::string(">= 0")) + "')";
    }
    const std::string measures_sql =
        "WITH k(name, unit, hi, range) AS (VALUES " + known +
        ") SELECT 'measure ' || quote(m.name) || ' of session ' || m.session, 'value ' || CASE "
        "typeof(m.value) WHEN 'real' THEN printf('%.10g', m.value) ELSE quote(m.value) END || "
        "' with unit ' || quote(m.unit) || ': expected a number ' || k.range || ' with unit ' "
        "|| k.unit FROM measures m JOIN k ON k.name = m.name WHERE m.unit IS NOT k.unit OR "
        "(typeof(m.value) IN ('integer', 'real') AND (m.value < 0 OR m.value > "
        "coalesce(k.hi, m.value))) LIMIT 1";
    std::vector<const char*> queries(std::begin(values), std::end(values));
    queries.push_back(measures_sql.c_str());
    for (const char* sql : queries) {
      Stmt q(db, sql);
      if (q.step())
        throw InputError(
            "not a consistent palplab results database: " + escape_controls(q.text(0), false) +
                " has " + escape_controls(q.text(1), false) +
                " (edited by hand or by another tool?)",
            path);
    }
  }
  if (version < 3) return;
  Stmt q(db,
         "SELECT 'session ' || x.session, quote(x.status) FROM sessions x WHERE x.status NOT IN "
         "('complete', 'running', 'aborted') LIMIT 1");
  if (q.step())
    throw InputError("not a consistent palplab results database: table sessions: " +
                         escape_controls(q.text(0), false) + " has status " +
                         escape_controls(q.text(1), false) +
                         ": expected 'complete', 'running' or 'aborted' (edited by hand or by "
                         "another tool?)",
                     path);
}

std::string not_palplab() {
  return "not a palplab results database (expected schema version " +
         std::to_string(kSchemaVersion) + ")";
}

void require_name(const std::string& path) {
  if (path.empty())
    throw InputError("no database file name given (an empty path): expected FILE.db");
}

}  // namespace

Store Store::create(const std::string& path) {
  require_name(path);
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw InputError("is a directory (expected a results database file)", path);
  if (fs::exists(path)) throw InputError("database already exists", path);
  require_writable(path, false);
  sqlite3* db = open_db(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX);
  Store s(db, path);
  s.lock_fd_ = lock_exclusive(path);
  exec(db, "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON;");
  // The schema and its meta rows in one transaction: an interruption leaves an empty file (see
  // is_empty_leftover) or a palplab database, never tables without a schema_version.
  exec(db, "BEGIN;" + schema_sql());
  Stmt(db, "INSERT INTO meta(key, value) VALUES ('schema_version', ?1)")
      .bind(1, std::to_string(kSchemaVersion))
      .run();
  Stmt(db, "INSERT INTO meta(key, value) VALUES ('created_at', ?1)").bind(1, utc_now()).run();
  exec(db, "COMMIT;");
  return s;
}

Store Store::open(const std::string& path, bool exclusive) {
  require_name(path);
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError("no such database", path);
  if (fs::is_directory(path, ec))
    throw InputError("is a directory (expected a results database file)", path);
  // A FIFO or a device would block the first read (a hang, review 2026-12-06) or be no file.
  if (!fs::is_regular_file(path, ec))
    throw InputError("is not a regular file (a FIFO or a device; expected a results database file)",
                     path);
  if (::access(path.c_str(), R_OK) != 0)
    throw InputError(std::string("cannot read the database: ") + std::strerror(errno), path);
  // A writer is refused before the probe below opens the file: that read-only open creates
  // PATH-wal and PATH-shm in a writable directory, which a refused resume left behind.
  if (exclusive) require_writable(path, true);
  if (::access(dir_of(path).c_str(), W_OK) == 0) {
    // (In a read-only directory a WAL database may be unreadable without its -shm file: the
    // immutable open below decides then.)
    const Probe p = probe_db(path);
    if (p.kind == Probe::kDamaged) throw InputError(damaged(p.detail), path);
    if (p.kind == Probe::kUnreadable)
      throw InputError("cannot read the database (" + p.detail + ")", path);
    if (p.kind != Probe::kPalplab)
      throw InputError(fs::file_size(path, ec) == 0 ? "is empty: " + not_palplab() : not_palplab(),
                       path);
  }
  sqlite3* db = nullptr;
  const bool can_write =
      ::access(dir_of(path).c_str(), W_OK) == 0 && ::access(path.c_str(), W_OK) == 0;
  if (exclusive) {
    db = open_db(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_FULLMUTEX);
  } else if (can_write) {
    db = open_db(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_FULLMUTEX);
  } else if (fs::file_size(path + "-wal", ec) > 0 && !ec) {
    // Read-only, with writes not yet copied into the file (a run killed before its checkpoint):
    // they are in PATH-wal, which SQLite reads read-only only through an existing PATH-shm. An
    // immutable open would silently drop them (sessions missing from export and report).
    std::error_code e2;
    if (!fs::exists(path + "-shm", e2) || ::access((path + "-shm").c_str(), R_OK) != 0)
      throw InputError(
          "its last writes are in " + fs::path(path + "-wal").filename().string() +
              ", which cannot be read in a read-only place without its -shm file; copy the "
              "database and its -wal file to a writable directory and read the copy",
          path);
    db = open_db(path, SQLITE_OPEN_READONLY | SQLITE_OPEN_FULLMUTEX);
  } else {
    // Reading from a read-only place (an archive, a mounted share): no -shm can be created, so
    // the file is opened as immutable (nobody may write it meanwhile).
    db = open_db(sqlite_uri(path, "immutable=1"),
                 SQLITE_OPEN_READONLY | SQLITE_OPEN_URI | SQLITE_OPEN_FULLMUTEX);
  }
  Store s(db, path);
  if (exclusive) s.lock_fd_ = lock_exclusive(path);
  long long version = -1;
  try {
    Stmt q(db, "PRAGMA user_version");
    if (q.step()) version = q.integer(0);
    Stmt m(db, "SELECT value FROM meta WHERE key = 'schema_version'");
    if (!m.step()) throw InputError(not_palplab() + ": its meta table has no schema_version", path);
  } catch (const SqliteError& e) {
    if (e.code == SQLITE_CORRUPT || e.code == SQLITE_NOTADB)
      throw InputError(damaged(e.detail), path);
    throw InputError(not_palplab(), path);
  }
  if (version < kOldestReadableSchemaVersion || version > kSchemaVersion)
    throw InputError("results schema version " + std::to_string(version) +
                         " is not supported (expected " +
                         std::to_string(kOldestReadableSchemaVersion) + " to " +
                         std::to_string(kSchemaVersion) + ")",
                     path);
  s.version_ = static_cast<int>(version);
  reading(path, [&] {
    check_tables(db, s.version_, path);
    check_references(db, s.version_, path);
    if (exclusive && s.version_ < 3) {
      migrate_sessions_to_v3(db);
      s.version_ = 3;
    }
    if (exclusive && s.version_ == 3) {
      migrate_to_v4(db);
      s.version_ = 4;
    }
    if (exclusive || can_write)
      exec(db, "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=ON;");
  });
  return s;
}

std::string Store::incomplete_warning() const {
  return reading(path_, [&]() -> std::string {
    StudyRecord st = read_study();
    if (!st.finished_at.empty()) return "";
    std::size_t n = 0;
    {
      std::lock_guard lock(*mu_);
      Stmt q(db_, version_ >= 3 ? "SELECT COUNT(*) FROM sessions WHERE status = 'complete'"
                                : "SELECT COUNT(*) FROM sessions");
      if (q.step()) n = static_cast<std::size_t>(q.integer(0));
    }
    return "warning: " + path_ + " is INCOMPLETE: the run started " + st.started_at +
           " has not finished (" + std::to_string(n) + (n == 1 ? " session" : " sessions") +
           " stored); results cover only those sessions. Continue it with "
           "`palplab run STUDY --db " +
           shell_word(path_) + " --resume` (virtual participants), or `palplab run STUDY --db " +
           shell_word(path_) + " --human --participant ID` (a person's sessions).";
  });
}

void Store::write_study(const StudyRecord& s, const std::vector<PrototypeRecord>& prototypes,
                        const std::vector<ParticipantRecord>& participants) {
  std::lock_guard lock(*mu_);
  exec(db_, "BEGIN IMMEDIATE");
  try {
    insert_study(s, prototypes, participants);
    exec(db_, "COMMIT");
  } catch (...) {
    roll_back_and_rethrow(db_, path_);
  }
}

void Store::write_start(const StudyRecord& s, const std::vector<PrototypeRecord>& prototypes,
                        const std::vector<ParticipantRecord>& participants,
                        const StudyStructure& structure,
                        const std::map<std::string, std::string>& meta) {
  std::lock_guard lock(*mu_);
  exec(db_, "BEGIN IMMEDIATE");
  try {
    for (const auto& [key, value] : meta)
      Stmt(db_, "INSERT OR REPLACE INTO meta(key, value) VALUES (?1, ?2)")
          .bind(1, key)
          .bind(2, value)
          .run();
    insert_study(s, prototypes, participants);
    insert_structure(structure);
    exec(db_, "COMMIT");
  } catch (...) {
    roll_back_and_rethrow(db_, path_);
  }
}

void Store::insert_study(const StudyRecord& s, const std::vector<PrototypeRecord>& prototypes,
                         const std::vector<ParticipantRecord>& participants) {
  {
    Stmt(db_,
         "INSERT INTO study(id, study_id, title, json, sha256, palplab_version, git_commit, seed, "
         "started_at, finished_at) VALUES (1, ?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)")
        .bind(1, s.study_id)
        .bind(2, s.title)
        .bind(3, s.json)
        .bind(4, s.sha256)
        .bind(5, s.palplab_version)
        .bind(6, s.git_commit)
        .bind(7, std::to_string(s.seed))
        .bind(8, s.started_at)
        .bind_opt_text(9, s.finished_at)
        .run();
    Stmt pr(db_, "INSERT INTO prototypes(prototype, path, sha256, json) VALUES (?1, ?2, ?3, ?4)");
    for (const auto& p : prototypes)
      pr.bind(1, p.prototype).bind(2, p.path).bind(3, p.sha256).bind(4, p.json).run();
    Stmt pa(db_,
            "INSERT INTO participants(participant, grp, number, seed) VALUES (?1, ?2, ?3, ?4)");
    for (const auto& p : participants)
      pa.bind(1, p.participant)
          .bind(2, p.group)
          .bind(3, p.number)
          .bind(4, std::to_string(p.seed))
          .run();
  }
}

void Store::write_session(SessionData& d) {
  std::lock_guard lock(*mu_);
  exec(db_, "BEGIN IMMEDIATE");
  try {
    const SessionRecord& r = d.session;
    Stmt s(db_,
           "INSERT INTO sessions(participant, ordinal, phase, phase_index, prototype, instructor, "
           "study_offset, day, duration, steps, wall_duration, loop_median, loop_p99, seed, "
           "state_after, completed_at, attempt, status, trainee, device, started_at, "
           "abort_reason, transparency) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, "
           "?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20, ?21, ?22, ?23)");
    if (r.transparency)
      s.bind(23, *r.transparency ? 1 : 0);
    else
      s.bind_null(23);
    s.bind(17, r.attempt).bind(18, r.status).bind(19, r.trainee).bind_opt_text(20, r.device);
    s.bind_opt_text(21, r.started_at).bind_opt_text(22, r.abort_reason);
    s.bind(1, r.participant).bind(2, r.ordinal).bind(3, r.phase).bind(4, r.phase_index);
    s.bind(5, r.prototype).bind_opt_text(6, r.instructor).bind(7, r.study_offset).bind(8, r.day);
    s.bind(9, r.duration).bind(10, r.steps).bind(11, r.wall_duration).bind(12, r.loop_median);
    s.bind(13, r.loop_p99).bind(14, std::to_string(r.seed)).bind(15, r.state_after);
    s.bind(16, r.completed_at.empty() ? utc_now() : r.completed_at).run();
    long long id = sqlite3_last_insert_rowid(db_);
    d.session.session = id;
    Stmt m(db_, "INSERT INTO measures(session, name, value, unit) VALUES (?1, ?2, ?3, ?4)");
    for (const auto& x : d.measures) {
      m.bind(1, id).bind(2, x.name).bind(4, x.unit);
      if (x.value && std::isfinite(*x.value))
        m.bind(3, *x.value);
      else
        m.bind_null(3);
      m.run();
    }
    Stmt e(db_, "INSERT INTO events(session, t, kind, value, region) VALUES (?1, ?2, ?3, ?4, ?5)");
    for (const auto& x : d.events)
      e.bind(1, id).bind(2, x.t).bind(3, x.kind).bind(4, x.value).bind_opt_text(5, x.region).run();
    const SampleSeries& ss = d.samples;
    if (ss.size() > 0) {
      Stmt b(db_,
             "INSERT INTO samples(session, second, t0, dt, n, encoding, data) VALUES (?1, ?2, ?3, "
             "?4, ?5, 'qdv1', ?6)");
      const std::size_t per =
          std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(1.0 / ss.dt)));
      for (std::size_t i = 0, sec = 0; i < ss.size(); i += per, ++sec) {
        std::size_t end = std::min(ss.size(), i + per);
        b.bind(1, id)
            .bind(2, static_cast<long long>(sec))
            .bind(3, ss.t0 + i * ss.dt)
            .bind(4, ss.dt);
        b.bind(5, static_cast<long long>(end - i)).bind_blob(6, encode_samples(ss, i, end)).run();
      }
    }
    exec(db_, "COMMIT");
  } catch (...) {
    roll_back_and_rethrow(db_, path_);
  }
}

void Store::set_finished(const std::string& finished_at) {
  std::lock_guard lock(*mu_);
  Stmt(db_, "UPDATE study SET finished_at = ?1 WHERE id = 1").bind(1, finished_at).run();
}

bool Store::has_study() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    Stmt q(db_, "SELECT COUNT(*) FROM study");
    return q.step() && q.integer(0) > 0;
  });
}

long long Store::count_run_rows() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    std::vector<std::string> tables;
    {
      Stmt q(db_,
             "SELECT name FROM sqlite_master WHERE type = 'table' AND name != 'meta' AND "
             "name NOT LIKE 'sqlite_%'");
      while (q.step()) tables.push_back(q.text(0));
    }
    long long n = 0;
    for (const auto& t : tables) {
      const std::string sql = "SELECT COUNT(*) FROM \"" + t + "\"";
      Stmt q(db_, sql.c_str());
      if (q.step()) n += q.integer(0);
    }
    return n;
  });
}

std::optional<std::string> Store::read_meta(const std::string& key) const {
  return reading(path_, [&]() -> std::optional<std::string> {
    std::lock_guard lock(*mu_);
    Stmt q(db_, "SELECT value FROM meta WHERE key = ?1");
    q.bind(1, key);
    if (!q.step()) return std::nullopt;
    return q.text(0);
  });
}

bool Store::has_samples() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    Stmt q(db_, "SELECT EXISTS (SELECT 1 FROM samples WHERE n > 0)");
    return q.step() && q.integer(0) != 0;
  });
}

void Store::write_meta(const std::string& key, const std::string& value) {
  std::lock_guard lock(*mu_);
  Stmt(db_, "INSERT OR REPLACE INTO meta(key, value) VALUES (?1, ?2)")
      .bind(1, key)
      .bind(2, value)
      .run();
}

StudyRecord Store::read_study() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    Stmt q(db_,
           "SELECT study_id, title, json, sha256, palplab_version, git_commit, seed, started_at, "
           "finished_at FROM study WHERE id = 1");
    if (!q.step()) throw InputError("the database has no study record (an aborted start?)", path_);
    StudyRecord s;
    s.study_id = q.text(0);
    s.title = q.text(1);
    s.json = q.text(2);
    s.sha256 = q.text(3);
    s.palplab_version = q.text(4);
    s.git_commit = q.text(5);
    s.seed = Typed(q, path_, "study", [] { return std::string("id 1"); }).u64(6, "seed");
    s.started_at = q.text(7);
    s.finished_at = q.null(8) ? "" : q.text(8);
    return s;
  });
}

std::vector<PrototypeRecord> Store::read_prototypes() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    Stmt q(db_, "SELECT prototype, path, sha256, json FROM prototypes ORDER BY prototype");
    std::vector<PrototypeRecord> out;
    while (q.step()) out.push_back({q.text(0), q.text(1), q.text(2), q.text(3)});
    return out;
  });
}

void Store::write_structure(const StudyStructure& st) {
  std::lock_guard lock(*mu_);
  exec(db_, "BEGIN IMMEDIATE");
  try {
    insert_structure(st);
    exec(db_, "COMMIT");
  } catch (...) {
    roll_back_and_rethrow(db_, path_);
  }
}

void Store::insert_structure(const StudyStructure& st) {
  if (version_ < 2)
    throw InputError("results schema version " + std::to_string(version_) +
                         " has no study structure tables; a run needs a new database",
                     path_);
  {
    Stmt g(db_, "INSERT INTO study_groups(grp, position, prototype) VALUES (?1, ?2, ?3)");
    for (std::size_t i = 0; i < st.groups.size(); ++i)
      g.bind(1, st.groups[i].group)
          .bind(2, static_cast<int>(i))
          .bind(3, st.groups[i].prototype)
          .run();
    Stmt p(db_,
           version_ >= 4
               ? "INSERT INTO phases(phase, position, kind, sessions, session_duration, haptic, "
                 "visual_deformation, audio, instructed, feature, transparency) VALUES (?1, ?2, "
                 "?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)"
               : "INSERT INTO phases(phase, position, kind, sessions, session_duration, haptic, "
                 "visual_deformation, audio, instructed, feature) VALUES (?1, ?2, ?3, ?4, ?5, ?6, "
                 "?7, ?8, ?9, ?10)");
    Stmt t(db_, "INSERT INTO thresholds(phase, region, st, mpf, sft) VALUES (?1, ?2, ?3, ?4, ?5)");
    auto cue = [&](int i, const std::optional<bool>& c) -> Stmt& {
      return c ? p.bind(i, *c ? 1 : 0) : p.bind_null(i);
    };
    for (std::size_t i = 0; i < st.phases.size(); ++i) {
      const PhaseRecord& ph = st.phases[i];
      p.bind(1, ph.phase).bind(2, static_cast<int>(i)).bind(3, ph.kind).bind(4, ph.sessions);
      p.bind(5, ph.session_duration);
      cue(6, ph.haptic);
      cue(7, ph.visual_deformation);
      cue(8, ph.audio);
      if (version_ >= 4) cue(11, ph.transparency);
      p.bind(9, ph.instructed ? 1 : 0).bind(10, ph.feature).run();
      for (const auto& r : ph.thresholds)
        t.bind(1, ph.phase).bind(2, r.region).bind(3, r.st).bind(4, r.mpf).bind(5, r.sft).run();
    }
  }
}

StudyStructure Store::read_structure() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    StudyStructure out;
    if (version_ < 2) return out;
    out.has_structure = true;
    Stmt g(db_, "SELECT grp, prototype FROM study_groups ORDER BY position");
    while (g.step()) out.groups.push_back({g.text(0), g.text(1)});
    Stmt p(db_, version_ >= 4
                    ? "SELECT phase, kind, sessions, session_duration, haptic, visual_deformation, "
                      "audio, instructed, feature, transparency FROM phases ORDER BY position"
                    : "SELECT phase, kind, sessions, session_duration, haptic, visual_deformation, "
                      "audio, instructed, feature FROM phases ORDER BY position");
    // Numbers as the schema types them (a hand edit is refused, not read as 0: Typed).
    const Typed pc(p, path_, "phases", [&] { return "phase " + p.text(0); });
    while (p.step()) {
      PhaseRecord r;
      r.phase = p.text(0);
      r.kind = p.text(1);
      r.sessions = pc.int32(2, "sessions");
      r.session_duration = pc.real(3, "session_duration");
      r.haptic = pc.flag(4, "haptic");
      r.visual_deformation = pc.flag(5, "visual_deformation");
      r.audio = pc.flag(6, "audio");
      r.instructed = pc.integer(7, "instructed", 0, 1) != 0;
      r.feature = p.text(8);
      if (version_ >= 4) r.transparency = pc.flag(9, "transparency");
      out.phases.push_back(r);
    }
    Stmt t(db_, "SELECT phase, region, st, mpf, sft FROM thresholds ORDER BY phase, region");
    const Typed tc(t, path_, "thresholds",
                   [&] { return "phase " + t.text(0) + ", region " + t.text(1); });
    while (t.step())
      for (auto& r : out.phases)
        if (r.phase == t.text(0))
          r.thresholds.push_back(
              {t.text(1), tc.real(2, "st"), tc.real(3, "mpf"), tc.real(4, "sft")});
    return out;
  });
}

std::vector<ParticipantRecord> Store::read_participants() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    Stmt q(db_, "SELECT participant, grp, number, seed FROM participants ORDER BY number");
    std::vector<ParticipantRecord> out;
    const Typed col(q, path_, "participants", [&] { return "participant " + q.text(0); });
    while (q.step())
      out.push_back({q.text(0), q.text(1), col.int32(2, "number"), col.u64(3, "seed")});
    return out;
  });
}

namespace {

std::vector<SessionRecord> read_session_rows(sqlite3* db, const std::string& path, int version,
                                             bool complete_only, const std::string& participant) {
  std::string sql =
      "SELECT s.session, s.participant, s.ordinal, s.phase, s.phase_index, s.prototype, "
      "s.instructor, s.study_offset, s.day, s.duration, s.steps, s.wall_duration, "
      "s.loop_median, s.loop_p99, s.seed, s.state_after, s.completed_at";
  if (version >= 3)
    sql += ", s.attempt, s.status, s.trainee, s.device, s.started_at, s.abort_reason";
  if (version >= 4) sql += ", s.transparency";
  sql += " FROM sessions s JOIN participants p ON p.participant = s.participant WHERE 1";
  if (version >= 3 && complete_only) sql += " AND s.status = 'complete'";
  if (!participant.empty()) sql += " AND s.participant = ?1";
  sql +=
      version >= 3 ? " ORDER BY p.number, s.ordinal, s.attempt" : " ORDER BY p.number, s.ordinal";
  Stmt q(db, sql.c_str());
  if (!participant.empty()) q.bind(1, participant);
  std::vector<SessionRecord> out;
  // session is the INTEGER PRIMARY KEY (always an integer); participant and phase are text.
  const Typed col(q, path, "sessions", [&] {
    return "session " + std::to_string(q.integer(0)) + ", participant " + q.text(1) + ", phase " +
           q.text(3);
  });
  while (q.step()) {
    SessionRecord r;
    r.session = q.integer(0);
    r.participant = q.text(1);
    r.ordinal = col.int32(2, "ordinal");
    r.phase = q.text(3);
    r.phase_index = col.int32(4, "phase_index");
    r.prototype = q.text(5);
    r.instructor = q.null(6) ? "" : q.text(6);
    r.study_offset = col.real(7, "study_offset");
    r.day = col.int32(8, "day");
    r.duration = col.real(9, "duration");
    r.steps = col.integer(10, "steps", 0, std::numeric_limits<long long>::max());
    r.wall_duration = col.real(11, "wall_duration");
    r.loop_median = col.real(12, "loop_median");
    r.loop_p99 = col.real(13, "loop_p99");
    r.seed = col.u64(14, "seed");
    r.state_after = q.text(15);
    r.completed_at = q.text(16);
    if (version >= 3) {
      r.attempt = col.int32(17, "attempt");
      r.status = q.text(18);
      r.trainee = q.text(19);
      r.device = q.null(20) ? "" : q.text(20);
      r.started_at = q.null(21) ? "" : q.text(21);
      r.abort_reason = q.null(22) ? "" : q.text(22);
    }
    if (version >= 4) r.transparency = col.flag(23, "transparency");
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace

std::vector<SessionRecord> Store::read_sessions() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    return read_session_rows(db_, path_, version_, true, "");
  });
}

std::vector<SessionRecord> Store::read_attempts(const std::string& participant) const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    return read_session_rows(db_, path_, version_, false, participant);
  });
}

void Store::begin_session(SessionRecord& r) {
  std::lock_guard lock(*mu_);
  Stmt s(db_,
         "INSERT INTO sessions(participant, ordinal, phase, phase_index, prototype, instructor, "
         "study_offset, day, duration, steps, wall_duration, loop_median, loop_p99, seed, "
         "state_after, completed_at, attempt, status, trainee, device, started_at, "
         "transparency) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, 0, 0, 0, 0, 0, ?9, ?10, '', ?11, "
         "'running', ?12, ?13, ?14, ?15)");
  if (r.transparency)
    s.bind(15, *r.transparency ? 1 : 0);
  else
    s.bind_null(15);
  s.bind(1, r.participant).bind(2, r.ordinal).bind(3, r.phase).bind(4, r.phase_index);
  s.bind(5, r.prototype).bind_opt_text(6, r.instructor).bind(7, r.study_offset).bind(8, r.day);
  s.bind(9, std::to_string(r.seed)).bind(10, r.state_after).bind(11, r.attempt);
  s.bind(12, r.trainee).bind_opt_text(13, r.device).bind_opt_text(14, r.started_at).run();
  r.session = sqlite3_last_insert_rowid(db_);
  r.status = "running";
}

void Store::append_session_data(long long id, const std::vector<EventRecord>& events,
                                const SampleSeries& ss, long long first_second, long long steps,
                                double dt) {
  std::lock_guard lock(*mu_);
  exec(db_, "BEGIN IMMEDIATE");
  try {
    Stmt e(db_, "INSERT INTO events(session, t, kind, value, region) VALUES (?1, ?2, ?3, ?4, ?5)");
    for (const auto& x : events)
      e.bind(1, id).bind(2, x.t).bind(3, x.kind).bind(4, x.value).bind_opt_text(5, x.region).run();
    if (ss.size() > 0) {
      Stmt b(db_,
             "INSERT INTO samples(session, second, t0, dt, n, encoding, data) VALUES (?1, ?2, ?3, "
             "?4, ?5, 'qdv1', ?6)");
      const std::size_t per =
          std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(1.0 / ss.dt)));
      long long sec = first_second;
      for (std::size_t i = 0; i < ss.size(); i += per, ++sec) {
        std::size_t end = std::min(ss.size(), i + per);
        b.bind(1, id).bind(2, sec).bind(3, ss.t0 + i * ss.dt).bind(4, ss.dt);
        b.bind(5, static_cast<long long>(end - i)).bind_blob(6, encode_samples(ss, i, end)).run();
      }
    }
    Stmt(db_, "UPDATE sessions SET steps = ?1, duration = ?2 WHERE session = ?3")
        .bind(1, steps)
        .bind(2, static_cast<double>(steps) * dt)
        .bind(3, id)
        .run();
    exec(db_, "COMMIT");
  } catch (...) {
    roll_back_and_rethrow(db_, path_);
  }
}

void Store::finish_session(const SessionData& d) {
  std::lock_guard lock(*mu_);
  exec(db_, "BEGIN IMMEDIATE");
  try {
    const SessionRecord& r = d.session;
    Stmt s(db_,
           "UPDATE sessions SET duration = ?2, steps = ?3, wall_duration = ?4, loop_median = ?5, "
           "loop_p99 = ?6, state_after = ?7, completed_at = ?8, status = ?9, abort_reason = ?10 "
           "WHERE session = ?1");
    s.bind(1, r.session).bind(2, r.duration).bind(3, r.steps).bind(4, r.wall_duration);
    s.bind(5, r.loop_median).bind(6, r.loop_p99).bind(7, r.state_after);
    s.bind(8, r.status == "complete" ? (r.completed_at.empty() ? utc_now() : r.completed_at)
                                     : std::string());
    s.bind(9, r.status).bind_opt_text(10, r.abort_reason).run();
    Stmt m(db_, "INSERT INTO measures(session, name, value, unit) VALUES (?1, ?2, ?3, ?4)");
    for (const auto& x : d.measures) {
      m.bind(1, r.session).bind(2, x.name).bind(4, x.unit);
      if (x.value && std::isfinite(*x.value))
        m.bind(3, *x.value);
      else
        m.bind_null(3);
      m.run();
    }
    exec(db_, "COMMIT");
  } catch (...) {
    roll_back_and_rethrow(db_, path_);
  }
}

int Store::abort_stale_sessions(const std::string& participant) {
  std::lock_guard lock(*mu_);
  Stmt(db_,
       "UPDATE sessions SET status = 'aborted', abort_reason = 'the process ended during the "
       "session (killed or crashed); the data written up to then is kept' WHERE status = "
       "'running' AND participant = ?1")
      .bind(1, participant)
      .run();
  return sqlite3_changes(db_);
}

std::vector<MeasureRow> Store::read_measures() const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    const std::string sql =
        "SELECT s.participant, p.grp, s.phase, s.ordinal, s.phase_index, s.session, m.name, "
        "m.value, m.unit FROM measures m JOIN sessions s ON s.session = m.session JOIN "
        "participants p ON p.participant = s.participant" +
        std::string(version_ >= 3 ? " WHERE s.status = 'complete'" : "") +
        " ORDER BY p.number, s.ordinal, m.name";
    Stmt q(db_, sql.c_str());
    std::vector<MeasureRow> out;
    // ordinal and phase_index are the session's (table sessions), checked as read_sessions does.
    const Typed session_col(q, path_, "sessions", [&] {
      return "session " + std::to_string(q.integer(5)) + ", participant " + q.text(0) + ", phase " +
             q.text(2);
    });
    while (q.step()) {
      MeasureRow r;
      r.participant = q.text(0);
      r.group = q.text(1);
      r.phase = q.text(2);
      r.ordinal = session_col.int32(3, "ordinal");
      r.phase_index = session_col.int32(4, "phase_index");
      r.session = q.integer(5);
      r.name = q.text(6);
      // REAL affinity stores a number as INTEGER or REAL; text left as text (or a blob) is not a
      // number, and is refused rather than read as 0. NULL = undefined.
      const int type = q.type(7);
      if (type == SQLITE_INTEGER || type == SQLITE_FLOAT) {
        r.value = q.real(7);
        if (!std::isfinite(*r.value))  // palplab stores a non-finite value as NULL
          throw InputError(session_label(r) + ": measure \"" + r.name + "\": value " +
                               format_shortest(*r.value) +
                               " is not finite (a value must be a number or NULL)",
                           path_);
      } else if (type != SQLITE_NULL) {
        throw InputError(session_label(r) + ": measure \"" + r.name + "\": value " +
                             stored_value(q, 7) +
                             " is not a number (a value must be a number or NULL)",
                         path_);
      }
      r.unit = q.text(8);
      out.push_back(std::move(r));
    }
    return out;
  });
}

namespace {
// "session 12 (participant P03, phase post_training #1)" for a session id, looked up when a
// message needs it (its phase_index only when that is an integer).
std::string describe_session(sqlite3* db, long long session) {
  Stmt w(db, "SELECT participant, phase, phase_index FROM sessions WHERE session = ?1");
  w.bind(1, session);
  if (!w.step()) return "session " + std::to_string(session);
  if (w.type(2) != SQLITE_INTEGER)
    return "session " + std::to_string(session) + " (participant " + w.text(0) + ", phase " +
           w.text(1) + ")";
  return session_label(session, w.text(0), w.text(1), static_cast<int>(w.integer(2)));
}
}  // namespace

std::vector<EventRecord> Store::read_events(long long session) const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    Stmt q(db_,
           "SELECT t, kind, value, region, rowid FROM events WHERE session = ?1 ORDER BY rowid");
    q.bind(1, session);
    // Where a bad value is: its session, the event's kind, its t when that is a number, and the
    // rowid (to find the row with SQL).
    const Typed col(q, path_, "events", [&] {
      const int tt = q.type(0);
      const bool t_ok = (tt == SQLITE_FLOAT || tt == SQLITE_INTEGER) && std::isfinite(q.real(0));
      return describe_session(db_, session) + ", kind " + shown_text(q.text(1), 40) +
             (t_ok ? ", t " + format_shortest(q.real(0)) : std::string()) + ", rowid " +
             std::to_string(q.integer(4));
    });
    std::vector<EventRecord> out;
    while (q.step()) {
      const double t = col.real(0, "t");
      out.push_back({t, q.text(1), col.real(2, "value"), q.null(3) ? "" : q.text(3)});
    }
    return out;
  });
}

SampleSeries Store::read_samples(long long session) const {
  return reading(path_, [&] {
    std::lock_guard lock(*mu_);
    // Which session a bad row belongs to, said with its participant and phase.
    auto where = [&](long long second) {
      return "samples of " + describe_session(db_, session) + ", second " + std::to_string(second);
    };
    Stmt q(db_,
           "SELECT t0, dt, n, encoding, data, second FROM samples WHERE session = ?1 ORDER BY "
           "second");
    q.bind(1, session);
    const Typed col(q, path_, "samples", [&] {
      return describe_session(db_, session) + ", second " + stored_value(q, 5);
    });
    SampleSeries out;
    bool first = true;
    while (q.step()) {
      const long long second = col.integer(5, "second", 0, std::numeric_limits<long long>::max());
      if (q.text(3) != "qdv1")
        throw InputError(where(second) + ": unknown sample encoding \"" +
                             shown_text(q.text(3), 40) + "\" (expected qdv1)",
                         path_);
      const double t0 = col.real(0, "t0");
      const double dt = col.real(1, "dt");
      const long long n = col.integer(2, "n", 0, std::numeric_limits<long long>::max());
      if (!(dt > 0.0))
        throw InputError(where(second) + ": damaged sample row (expected dt > 0)", path_);
      if (first) {
        out.t0 = t0;
        out.dt = dt;
        first = false;
      } else {
        // The rows of a session are contiguous (each starts where the one before ended): a row
        // deleted by hand made every later sample read as 1 s earlier.
        const double expected = out.t0 + static_cast<double>(out.size()) * out.dt;
        if (dt != out.dt || !(std::abs(t0 - expected) <= 0.5 * dt))
          throw InputError(where(second) + ": the samples are not contiguous (this row starts at " +
                               format_shortest(t0) + " s with step " + format_shortest(dt) +
                               " s; the rows before end at " + format_shortest(expected) +
                               " s with step " + format_shortest(out.dt) +
                               " s): a row is missing or edited; the database is damaged",
                           path_);
      }
      try {
        decode_samples(q.blob(4), static_cast<std::size_t>(n), t0, dt, out);
      } catch (const std::runtime_error& e) {
        throw InputError(where(second) + ": " + e.what() + ", " + std::to_string(n) +
                             " samples expected; the database is damaged",
                         path_);
      }
    }
    // Every step of a complete session is one sample (unless the run stored none): rows deleted
    // at the start or the end (the contiguity check above sees only gaps between rows) leave
    // fewer (review 2026-12-06, second: 59 of 60 s exported without a word).
    Stmt s(db_,
           "SELECT steps, status, (SELECT value FROM meta WHERE key = 'samples') FROM sessions "
           "WHERE session = ?1");
    s.bind(1, session);
    if (s.step() && s.type(0) == SQLITE_INTEGER && s.type(1) == SQLITE_TEXT &&
        s.text(1) == "complete" &&
        (out.size() > 0 || (s.type(2) == SQLITE_TEXT && s.text(2) == "full"))) {
      const long long steps = s.integer(0);
      if (static_cast<long long>(out.size()) != steps)
        throw InputError("samples of " + describe_session(db_, session) + ": " +
                             std::to_string(out.size()) + " stored, but the session ran " +
                             std::to_string(steps) + " steps (one sample each" +
                             (out.size() == 0 ? ", the run stored them: --samples full" : "") +
                             "): rows are missing or edited; the database is damaged",
                         path_);
    }
    return out;
  });
}

namespace {
std::string csv(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string o = "\"";
  for (char c : s) {
    if (c == '"') o += '"';
    o += c;
  }
  return o + "\"";
}
// The export's files: each is written as NAME.partial and renamed over NAME only when every
// file is complete, so an export that fails half-way (a damaged database) leaves the files of an
// earlier export as they were; the partial files are removed.
class Outputs {
 public:
  std::ofstream open(const fs::path& p) {
    std::error_code ec;
    if (fs::is_directory(p, ec))
      throw InputError("is a directory (expected the export's file " + p.filename().string() +
                           "; move it out of the way)",
                       p.string());
    fs::path part = p;
    part += ".partial";
    std::ofstream o(part, std::ios::binary);
    if (!o) throw InputError("cannot write (expected a writable directory)", part.string());
    files_.push_back({part, p});
    on_signal_.push_back(std::make_unique<RemoveOnSignal>(part.string()));
    return o;
  }
  void check(const std::ofstream& o) const {
    if (!o) throw InputError("cannot write (disk full?)", files_.back().first.string());
  }
  // A file of an earlier export that this one does not write: removed when this export commits
  // (before its files are renamed into place; if it cannot be removed, nothing is replaced).
  void remove_on_commit(const fs::path& p) { stale_.push_back(p); }
  // The stale files removed by commit().
  std::vector<std::string> commit() {
    std::vector<std::string> removed;
    for (const auto& p : stale_) {
      std::error_code ec;
      fs::remove(p, ec);
      if (ec)
        throw InputError("cannot remove " + p.filename().string() +
                             " of an earlier export (this export does not write it, and the "
                             "directory must not mix two exports): " +
                             ec.message(),
                         p.string());
      removed.push_back(p.string());
    }
    stale_.clear();
    for (const auto& [part, final] : files_) {
      std::error_code ec;
      fs::rename(part, final, ec);
      if (ec)
        throw InputError("cannot rename " + part.filename().string() + " to " +
                             final.filename().string() + ": " + ec.message(),
                         final.string());
    }
    files_.clear();
    on_signal_.clear();
    return removed;
  }
  ~Outputs() {
    std::error_code ec;
    for (const auto& f : files_) fs::remove(f.first, ec);
  }

 private:
  std::vector<std::pair<fs::path, fs::path>> files_;
  // The partial files are removed if the export is interrupted (SIGINT, SIGTERM) before commit.
  std::vector<std::unique_ptr<RemoveOnSignal>> on_signal_;
  std::vector<fs::path> stale_;
};
}  // namespace

ExportSummary export_csv(const Store& store, const std::string& dir, bool samples) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw InputError(fs::exists(fs::status(dir, ec)) && !fs::is_directory(fs::status(dir, ec))
                         ? std::string("exists and is not a directory (expected the export "
                                       "directory)")
                         : "cannot create the export directory: " + ec.message(),
                     dir);
  std::map<std::string, std::string> group_of;
  for (const auto& p : store.read_participants()) group_of[p.participant] = p.group;
  Outputs files;
  {
    const auto measures = store.read_measures();
    auto o = files.open(fs::path(dir) / "measures.csv");
    o << "participant,group,phase,session,measure,value,unit\n";
    for (const auto& r : measures)
      o << csv(r.participant) << ',' << csv(r.group) << ',' << csv(r.phase) << ','
        << (r.phase_index + 1) << ',' << csv(r.name) << ','
        << (r.value ? format_shortest(*r.value) : "") << ',' << csv(r.unit) << '\n';
    o.flush();
    files.check(o);
  }
  auto sessions = store.read_sessions();
  {
    auto o = files.open(fs::path(dir) / "sessions.csv");
    o << "participant,group,phase,session,ordinal,prototype,instructor,study_offset_s,day,"
         "duration_s,steps,wall_duration_s,loop_median_s,loop_p99_s,seed,completed_at,"
         "session_id\n";
    // `ordinal` is written 1-based (the database's is 0-based), like `session`: a contract of
    // sessions.csv (docs/FORMATS.md), kept for the scripts that read it. `session_id` is the
    // database's id (sessions.session), which `trace-export --session` takes.
    for (const auto& s : sessions)
      o << csv(s.participant) << ',' << csv(group_of[s.participant]) << ',' << csv(s.phase) << ','
        << (s.phase_index + 1) << ',' << (s.ordinal + 1) << ',' << csv(s.prototype) << ','
        << csv(s.instructor) << ',' << format_shortest(s.study_offset) << ',' << s.day << ','
        << format_shortest(s.duration) << ',' << s.steps << ',' << format_shortest(s.wall_duration)
        << ',' << format_shortest(s.loop_median) << ',' << format_shortest(s.loop_p99) << ','
        << s.seed << ',' << csv(s.completed_at) << ',' << s.session << '\n';
    o.flush();
    files.check(o);
  }
  {
    auto o = files.open(fs::path(dir) / "events.csv");
    o << "participant,group,phase,session,t,kind,value,region\n";
    for (const auto& s : sessions)
      for (const auto& e : store.read_events(s.session))
        o << csv(s.participant) << ',' << csv(group_of[s.participant]) << ',' << csv(s.phase) << ','
          << (s.phase_index + 1) << ',' << format_shortest(e.t) << ',' << csv(e.kind) << ','
          << format_shortest(e.value) << ',' << csv(e.region) << '\n';
    o.flush();
    files.check(o);
  }
  if (samples) {
    auto o = files.open(fs::path(dir) / "samples.csv");
    o << "participant,group,phase,session,t,x,y,z,fx,fy,fz,contact_node\n";
    for (const auto& s : sessions) {
      SampleSeries ss = store.read_samples(s.session);
      std::string prefix = csv(s.participant) + ',' + csv(group_of[s.participant]) + ',' +
                           csv(s.phase) + ',' + std::to_string(s.phase_index + 1) + ',';
      for (std::size_t i = 0; i < ss.size(); ++i) {
        char buf[256];
        std::snprintf(buf, sizeof buf, "%.6f,%.6f,%.6f,%.6f,%.4f,%.4f,%.4f,%d\n",
                      ss.t0 + (i + 1) * ss.dt, ss.x[3 * i], ss.x[3 * i + 1], ss.x[3 * i + 2],
                      ss.F[3 * i], ss.F[3 * i + 1], ss.F[3 * i + 2], ss.node[i]);
        o << prefix << buf;
      }
    }
    o.flush();
    files.check(o);
  } else {
    // A samples.csv left by an earlier `--samples` export (perhaps of another database) would
    // sit beside this export's files as if it belonged to them: removed, and said.
    const fs::path old = fs::path(dir) / "samples.csv";
    std::error_code ec;
    const auto st = fs::symlink_status(old, ec);
    if (fs::exists(st) && !fs::is_directory(st)) files.remove_on_commit(old);
  }
  return {files.commit()};
}

}  // namespace palplab::results
