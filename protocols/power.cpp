#include "protocols/power.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <new>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#ifdef PALPLAB_MPI
#include <mpi.h>
#endif

#include "analysis/anova.hpp"
#include "analysis/descriptives.hpp"
#include "analysis/svg.hpp"
#include "analysis/two_sample.hpp"
#include "common/escape.hpp"
#include "common/file_kind.hpp"
#include "common/input_error.hpp"
#include "common/json_locate.hpp"
#include "common/nan.hpp"
#include "common/seed.hpp"
#include "common/write_file.hpp"
#include "protocols/input_pins.hpp"
#include "protocols/plan.hpp"
#include "protocols/runner.hpp"
#include "results/sha256.hpp"

namespace fs = std::filesystem;

namespace palplab::protocols {

namespace {

using Clock = std::chrono::steady_clock;

nlohmann::json num_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nullptr;
}
double num_or_nan(const nlohmann::json& j) {
  return j.is_number() ? j.get<double>() : kNaN;
}

// Type-7 quantile (linear interpolation) of sorted values.
double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return kNaN;
  const double h = (sorted.size() - 1) * q;
  const std::size_t lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  const double w = h - lo, a = sorted[lo], b = sorted[hi];
  // Finite values whose difference overflows (an edited g of -1.7e308 and 1.7e308) have opposite
  // signs, and then the weighted sum cannot overflow.
  return std::isfinite(b - a) ? a + w * (b - a) : (1 - w) * a + w * b;
}

// Which process this is when launched by mpirun with an MPI build; a single process otherwise.
struct Ranks {
  int rank = 0, size = 1;
  bool mpi = false;
};

#ifdef PALPLAB_MPI
bool launched_by_mpirun() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"})
    if (std::getenv(v)) return true;
  return false;
}
#endif

// Once per process: the command starts MPI before its checks (power_rank), run_power asks again.
const Ranks& init_ranks() {
  static const Ranks ranks = [] {
    Ranks r;
#ifdef PALPLAB_MPI
    if (!launched_by_mpirun()) return r;
    int inited = 0;
    MPI_Initialized(&inited);
    if (!inited) MPI_Init(nullptr, nullptr);
    MPI_Comm_rank(MPI_COMM_WORLD, &r.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &r.size);
    r.mpi = true;
#endif
    return r;
  }();
  return ranks;
}

// Concatenated lines of every rank, on rank 0 (others get "").
std::string gather_to_root(const Ranks& r, const std::string& mine) {
#ifdef PALPLAB_MPI
  if (r.mpi) {
    int len = static_cast<int>(mine.size());
    std::vector<int> lens(r.size), displs(r.size);
    MPI_Gather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::string all;
    if (r.rank == 0) {
      int total = 0;
      for (int i = 0; i < r.size; ++i) displs[i] = total, total += lens[i];
      all.resize(total);
    }
    MPI_Gatherv(mine.data(), len, MPI_CHAR, all.data(), lens.data(), displs.data(), MPI_CHAR, 0,
                MPI_COMM_WORLD);
    return all;
  }
#endif
  (void)r;
  return mine;
}

long max_over_ranks(const Ranks& r, long v) {
#ifdef PALPLAB_MPI
  if (r.mpi) {
    long out = v;
    MPI_Allreduce(&v, &out, 1, MPI_LONG, MPI_MAX, MPI_COMM_WORLD);
    return out;
  }
#endif
  (void)r;
  return v;
}

#ifdef PALPLAB_MPI
// The exit code app/main.cpp gives what `error` holds (2 bad input, 1 out of memory, 3 an internal
// error) and its message (MPI only: settle's message to rank 0).
int exit_code_of(std::exception_ptr error, std::string* message) {
  try {
    std::rethrow_exception(error);
  } catch (const InputError& e) {
    *message = e.what();
    return 2;
  } catch (const FailedOnAnotherRank& e) {
    *message = e.what();
    return e.code;
  } catch (const std::bad_alloc&) {
    *message = "out of memory";
    return 1;
  } catch (const std::exception& e) {
    *message = e.what();
    return 3;
  } catch (...) {
    *message = "an unknown error";
    return 3;
  }
}
#endif

// power.hpp settle_ranks: under MPI a collective, so that one rank's error is said once (by
// rank 0) and no rank waits for ever in a collective the failed one never reaches.
void settle(const Ranks& r, std::exception_ptr error) {
#ifdef PALPLAB_MPI
  if (r.mpi) {
    std::string message;
    const int code = error ? exit_code_of(error, &message) : 0;
    std::vector<int> codes(r.size);
    MPI_Allgather(&code, 1, MPI_INT, codes.data(), 1, MPI_INT, MPI_COMM_WORLD);
    const auto first = std::find_if(codes.begin(), codes.end(), [](int c) { return c != 0; });
    if (first == codes.end()) return;
    const int from = static_cast<int>(first - codes.begin()), final_code = *first;
    // The first failed rank's message, for rank 0 when it has none of its own.
    const std::string theirs = gather_to_root(r, r.rank == from ? message : std::string());
    // MPI stays up until end_ranks: rank 0 says the error first (a rank that ended before
    // rank 0 had printed it made mpirun kill rank 0 before it did).
    if (r.rank != 0) throw FailedOnAnotherRank(final_code);
    if (error) std::rethrow_exception(error);
    if (final_code == 2) throw InputError(theirs);
    if (final_code == 1) throw std::bad_alloc();
    throw std::runtime_error(theirs);
  }
#endif
  (void)r;
  if (error) std::rethrow_exception(error);
}

std::string replicate_file(const PowerOptions& o) {
  if (o.shards <= 1) return (fs::path(o.out_dir) / "replicates.jsonl").string();
  return (fs::path(o.out_dir) / ("replicates.shard-" + std::to_string(o.shard + 1) + "-of-" +
                                 std::to_string(o.shards) + ".jsonl"))
      .string();
}

// Cuts a line left half-written by an interruption, so appends start on a fresh line.
void repair_tail(const std::string& path) {
  if (!fs::exists(path)) return;
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    text = ss.str();
  }
  if (text.empty() || text.back() == '\n') return;
  const std::size_t keep = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
  fs::resize_file(path, keep);
}

// The limits `palplab power` writes within (--n 2..100000, --replicates 1..10000000).
constexpr long long kMaxN = 100000, kMaxReplicates = 10000000;

// A JSON value as shown in a message (cut when long).
std::string shown(const nlohmann::json& v) {
  std::string s = v.dump();
  return s.size() > 40 ? s.substr(0, 37) + "..." : s;
}

bool integer_in(const nlohmann::json& v, long long lo, long long hi) {
  if (v.is_number_unsigned()) {
    const std::uint64_t u = v.get<std::uint64_t>();
    return u <= static_cast<std::uint64_t>(hi) && static_cast<long long>(u) >= lo;
  }
  if (v.is_number_integer()) return v.get<long long>() >= lo && v.get<long long>() <= hi;
  return false;
}

// Checks one replicate record (docs/FORMATS.md "Power-analysis and calibration files") so that
// the summary can read it without surprises: InputError at FILE:LINE: $.field.
void check_replicate(const nlohmann::json& r, const std::string& path, int line) {
  auto fail = [&](const std::string& json_path, const std::string& what) {
    return InputError(SourceLocation{path, line, 0, -1, json_path}, what);
  };
  if (!r.is_object())
    throw fail("$",
               "expected a replicate record (a JSON object with study_sha256, study, n, "
               "replicate, seed and tests), got " +
                   shown(r));
  auto member = [&](const char* key, const std::string& expected) -> const nlohmann::json& {
    auto it = r.find(key);
    if (it == r.end()) throw fail("$", "missing \"" + std::string(key) + "\" (" + expected + ")");
    return *it;
  };
  // Names are printed into power.md and messages: a control character (an escape sequence
  // edited into a record) is refused, not echoed to the terminal.
  auto control_free = [&](const nlohmann::json& v, const std::string& json_path) {
    for (const unsigned char c : v.get_ref<const std::string&>())
      if (c < 0x20 || c == 0x7f)
        throw fail(json_path, "expected text without control characters, got " + shown(v));
  };
  for (const char* key : {"study_sha256", "study"}) {
    if (!member(key, "a string").is_string())
      throw fail(std::string("$.") + key, "expected a string, got " + shown(r.at(key)));
    control_free(r.at(key), std::string("$.") + key);
  }
  // Optional (records written before it existed lack it): the prototypes' pin.
  if (auto it = r.find("prototypes_sha256"); it != r.end()) {
    const auto hex = [](const nlohmann::json& v) {
      const auto& s = v.get_ref<const std::string&>();
      return s.size() == 64 && s.find_first_not_of("0123456789abcdef") == std::string::npos;
    };
    if (!it->is_string() || !hex(*it))
      throw fail("$.prototypes_sha256",
                 "expected a SHA-256 (64 lowercase hexadecimal digits), got " + shown(*it));
  }
  const std::string n_what = "the group size, an integer from 2 to " + std::to_string(kMaxN);
  if (!integer_in(member("n", n_what), 2, kMaxN))
    throw fail("$.n", "expected " + n_what + ", got " + shown(r.at("n")));
  const std::string rep_what =
      "the 0-based replicate index, an integer from 0 to " + std::to_string(kMaxReplicates - 1);
  if (!integer_in(member("replicate", rep_what), 0, kMaxReplicates - 1))
    throw fail("$.replicate", "expected " + rep_what + ", got " + shown(r.at("replicate")));
  if (!member("seed", "the replicate's seed").is_number_unsigned() &&
      !(r.at("seed").is_number_integer() && r.at("seed").get<long long>() >= 0))
    throw fail("$.seed",
               "expected the replicate's seed, an integer >= 0, got " + shown(r.at("seed")));
  // Optional (records written before 2026-12-07 lack it): what the run that wrote the record
  // was asked for, so that a merge can see replicates missing above the largest present.
  if (auto it = r.find("plan"); it != r.end()) {
    const std::string plan_what =
        "{\"replicates\": the --replicates asked for, \"n\": the group sizes asked for}";
    if (!it->is_object() || it->size() != 2 || !it->contains("replicates") || !it->contains("n"))
      throw fail("$.plan", "expected " + plan_what + ", got " + shown(*it));
    const std::string reps_what = "an integer from 1 to " + std::to_string(kMaxReplicates);
    if (!integer_in(it->at("replicates"), 1, kMaxReplicates))
      throw fail("$.plan.replicates",
                 "expected " + reps_what + ", got " + shown(it->at("replicates")));
    if (r.at("replicate").get<long long>() >= it->at("replicates").get<long long>())
      throw fail("$.replicate", "replicate index " + shown(r.at("replicate")) +
                                    " is not below the run's $.plan.replicates " +
                                    shown(it->at("replicates")) + " (an edited record)");
    const nlohmann::json& ns = it->at("n");
    if (!ns.is_array() || ns.empty())
      throw fail("$.plan.n",
                 "expected the group sizes asked for, a non-empty array, got " + shown(ns));
    bool own = false;
    for (std::size_t i = 0; i < ns.size(); ++i) {
      if (!integer_in(ns[i], 2, kMaxN))
        throw fail("$.plan.n[" + std::to_string(i) + "]",
                   "expected " + n_what + ", got " + shown(ns[i]));
      for (std::size_t j = 0; j < i; ++j)
        if (ns[j] == ns[i])
          throw fail("$.plan.n[" + std::to_string(i) + "]", "size " + shown(ns[i]) +
                                                                " given twice (already $.plan.n[" +
                                                                std::to_string(j) + "])");
      own = own || ns[i] == r.at("n");
    }
    if (!own)
      throw fail("$.plan.n", "the record's n " + shown(r.at("n")) +
                                 " is not among the run's sizes " + shown(ns) +
                                 " (an edited record)");
  }
  const nlohmann::json& tests = member("tests", "an array of test outcomes");
  if (!tests.is_array())
    throw fail(
        "$.tests",
        "expected an array of {\"id\", \"p\", \"effect\", \"effect_name\"}, got " + shown(tests));
  if (tests.empty()) throw fail("$.tests", "expected at least one test outcome, got []");
  for (std::size_t i = 0; i < tests.size(); ++i) {
    const nlohmann::json& t = tests[i];
    const std::string tp = "$.tests[" + std::to_string(i) + "]";
    if (!t.is_object())
      throw fail(tp, "expected a test outcome {\"id\", \"p\", \"effect\", \"effect_name\"}, got " +
                         shown(t));
    for (const char* key : {"id", "effect_name"}) {
      auto it = t.find(key);
      if (it == t.end() || !it->is_string() ||
          (std::string(key) == "id" && it->get<std::string>().empty()))
        throw fail(tp + "." + key, it == t.end()
                                       ? "missing (expected a string)"
                                       : "expected a non-empty string, got " + shown(*it));
      control_free(*it, tp + "." + key);
    }
    for (std::size_t j = 0; j < i; ++j)
      if (tests[j].is_object() && tests[j].value("id", "") == t.at("id"))
        throw fail(tp + ".id", "duplicate test id " + shown(t.at("id")) + " (already $.tests[" +
                                   std::to_string(j) + "])");
    auto p = t.find("p");
    if (p == t.end() ||
        !(p->is_null() || (p->is_number() && p->get<double>() >= 0 && p->get<double>() <= 1)))
      throw fail(tp + ".p", std::string("expected a p-value in [0, 1] or null (undefined), ") +
                                (p == t.end() ? "missing" : "got " + shown(*p)));
    const bool eta = t.at("effect_name") == "eta_squared";
    auto e = t.find("effect");
    if (e == t.end() ||
        !(e->is_null() ||
          (e->is_number() && (!eta || (e->get<double>() >= 0 && e->get<double>() <= 1)))))
      throw fail(tp + ".effect",
                 std::string("expected the effect size, ") + (eta ? "η² in [0, 1]" : "a number") +
                     ", or null (undefined), " + (e == t.end() ? "missing" : "got " + shown(*e)));
  }
  // The group descriptives of the tested cells (records written before 2026-12-05 have none).
  auto groups = r.find("groups");
  if (groups == r.end()) return;
  const std::string group_what = "{\"cell\", \"group\", \"n\", \"mean\", \"sd\"}";
  if (!groups->is_array())
    throw fail("$.groups", "expected an array of " + group_what + ", got " + shown(*groups));
  if (groups->empty())
    throw fail("$.groups",
               "expected the groups of the tested cells (a study with tests has "
               "them), got []");
  for (std::size_t i = 0; i < groups->size(); ++i) {
    const nlohmann::json& g = (*groups)[i];
    const std::string gp = "$.groups[" + std::to_string(i) + "]";
    if (!g.is_object()) throw fail(gp, "expected " + group_what + ", got " + shown(g));
    for (const char* key : {"cell", "group"}) {
      auto it = g.find(key);
      if (it == g.end() || !it->is_string() || it->get<std::string>().empty())
        throw fail(gp + "." + key, it == g.end()
                                       ? "missing (expected a string)"
                                       : "expected a non-empty string, got " + shown(*it));
      control_free(*it, gp + "." + key);
    }
    for (std::size_t j = 0; j < i; ++j)
      if ((*groups)[j].value("cell", "") == g.at("cell") &&
          (*groups)[j].value("group", "") == g.at("group"))
        throw fail(gp, "group " + shown(g.at("group")) + " of " + shown(g.at("cell")) +
                           " given twice (already $.groups[" + std::to_string(j) + "])");
    auto n = g.find("n");
    if (n == g.end() || !integer_in(*n, 0, kMaxN))
      throw fail(gp + ".n", "expected the number of values, an integer from 0 to " +
                                std::to_string(kMaxN) + ", " +
                                (n == g.end() ? "missing" : "got " + shown(*n)));
    const long long k = n->get<long long>();
    auto m = g.find("mean");
    if (m == g.end() || !(k == 0 ? m->is_null() : m->is_number()))
      throw fail(gp + ".mean", std::string(k == 0 ? "expected null (no values)"
                                                  : "expected the group mean, a number") +
                                   ", " + (m == g.end() ? "missing" : "got " + shown(*m)));
    auto sd = g.find("sd");
    if (sd == g.end() || !(k < 2 ? sd->is_null() : sd->is_number() && sd->get<double>() >= 0))
      throw fail(gp + ".sd", std::string(k < 2 ? "expected null (fewer than 2 values)"
                                               : "expected the group SD, a number >= 0") +
                                 ", " + (sd == g.end() ? "missing" : "got " + shown(*sd)));
  }
}

// The group descriptives a replicate record holds (check_replicate has checked them).
std::vector<GroupDescriptive> record_groups(const nlohmann::json& r) {
  std::vector<GroupDescriptive> out;
  for (const auto& g : r.at("groups"))
    out.push_back({g.at("cell").get<std::string>(), g.at("group").get<std::string>(),
                   g.at("n").get<int>(), num_or_nan(g.at("mean")), num_or_nan(g.at("sd")), kNaN,
                   kNaN});
  return out;
}

struct ReplicateLine {
  nlohmann::json record;
  int line = 0;
};

// The offset of the first byte of `line` that belongs to no UTF-8 character, npos when there is
// none. With `cut_ok`, a character cut short by the end of the line (a lead byte and fewer
// continuation bytes than it announces) is not one: a record cut by an interruption.
std::size_t first_non_utf8(const std::string& line, bool cut_ok) {
  for (std::size_t i = 0; i < line.size();) {
    if (static_cast<unsigned char>(line[i]) < 0x80) {
      ++i;
      continue;
    }
    std::size_t length = 1;
    const char32_t cp = utf8_code_point(line, i, &length);
    if (cp != 0xFFFD || length > 1) {  // (U+FFFD itself is three bytes long)
      i += length;
      continue;
    }
    const auto lead = static_cast<unsigned char>(line[i]);
    const std::size_t wanted = lead >= 0xC2 && lead <= 0xDF   ? 1
                               : lead >= 0xE0 && lead <= 0xEF ? 2
                               : lead >= 0xF0 && lead <= 0xF4 ? 3
                                                              : 0;
    bool cut = cut_ok && wanted > 0 && line.size() - i - 1 < wanted;
    for (std::size_t k = i + 1; cut && k < line.size(); ++k) cut = utf8_continuation(line[k]);
    return cut ? std::string::npos : i;
  }
  return std::string::npos;
}

// Reads and checks every record. A last line without its newline that is not a whole record was
// being written when the run was interrupted: `palplab power` cuts it on resume (repair_tail)
// and simulates that replicate again, so it is an error here rather than silently dropped.
std::vector<ReplicateLine> read_replicates(const std::string& path) {
  std::vector<ReplicateLine> out;
  // A FIFO blocked the open for ever (review 2026-12-06, fifth); a directory or a device is no
  // replicate file either.
  std::error_code ec;
  if (const auto st = fs::status(path, ec); fs::exists(st) && !fs::is_regular_file(st))
    throw InputError(
        "is not a regular file (a directory, a FIFO or a device): expected a replicate file of "
        "palplab power (replicates*.jsonl, JSON lines)",
        path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot read replicate file", path);
  {
    // palplab's own binary files given as replicates are named (a scene file was "invalid
    // literal; last read: 'P'").
    char head[16] = {};
    in.read(head, sizeof head);
    const std::string h(head, static_cast<std::size_t>(in.gcount()));
    if (const char* kind = binary_file_kind(h))
      throw InputError(std::string("not a replicate file: it is ") + kind +
                           (h[0] == 'P' ? "" : " (a results database?)") +
                           "; expected the replicates*.jsonl of palplab power",
                       path);
    in.clear();
    in.seekg(0);
  }
  std::string line;
  int no = 0;
  while (std::getline(in, line)) {
    ++no;
    const bool unterminated = in.eof();
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    // Printing or checking a value nested without bound would recurse without bound.
    if (const std::size_t deep = palplab::json::too_deep_at(line); deep != std::string::npos)
      throw InputError(SourceLocation{path, no, static_cast<int>(deep) + 1},
                       "not a replicate record (JSON line): nested deeper than " +
                           std::to_string(palplab::json::kMaxDepth) + " levels");
    // Binary data (a file that is no text: the head of an executable) is no interrupted record.
    if (line.find('\0') != std::string::npos)
      throw InputError(SourceLocation{path, no, static_cast<int>(line.find('\0')) + 1},
                       "not a replicate file: it holds binary data (a NUL byte); expected the "
                       "replicates*.jsonl of palplab power");
    // Nor are bytes of no UTF-8 character (binary data without a NUL, Latin-1 text): they were
    // a JSON parse error. A character cut by an interruption ends an unterminated last line.
    if (const std::size_t bad = first_non_utf8(line, unterminated); bad != std::string::npos) {
      char byte[8];
      std::snprintf(byte, sizeof byte, "0x%02X", static_cast<unsigned char>(line[bad]));
      throw InputError(
          SourceLocation{path, no, static_cast<int>(utf8_length(line.substr(0, bad))) + 1},
          std::string("not a replicate file: it is not UTF-8 text (byte ") + byte +
              " is no UTF-8 character: binary data, or text in another encoding); "
              "expected the replicates*.jsonl of palplab power");
    }
    nlohmann::json r;
    try {
      r = nlohmann::json::parse(line);
    } catch (const std::exception& e) {
      // A record cut by an interruption begins as every record does.
      if (unterminated && line.compare(line.find_first_not_of(" \t"), 2, "{\"") == 0)
        throw InputError(SourceLocation{path, no, 1},
                         "the last line is incomplete (the run writing this file was interrupted "
                         "mid-line); rerun that `palplab power` command with the same --out (and "
                         "--shard): it resumes, cuts the incomplete line and simulates the "
                         "replicate again. Or delete the line to merge without it");
      // nlohmann's message names the byte and what it expected (a NaN, 1e400, a cut string).
      const auto* pe = dynamic_cast<const nlohmann::json::parse_error*>(&e);
      const int column = pe && pe->byte > 0 ? static_cast<int>(pe->byte) : 1;
      std::string why = e.what();
      if (const auto k = why.find("parse error"); k != std::string::npos) why = why.substr(k);
      // The location is the file's (above): nlohmann's own "at line 1, column 12" is the line's.
      if (const auto k = why.find(" at line "); k != std::string::npos)
        if (const auto c = why.find(": ", k); c != std::string::npos) why.erase(k, c - k);
      throw InputError(SourceLocation{path, no, column},
                       "not a replicate record (JSON line): " + why);
    }
    check_replicate(r, path, no);
    out.push_back({std::move(r), no});
  }
  return out;
}

// The seed of replicate `replicate` of group size `n` (what run_power simulates it with).
std::uint64_t replicate_seed(const Study& study, int n, int replicate) {
  return derive_seed(study.seed, label_hash("power"), static_cast<std::uint64_t>(n),
                     static_cast<std::uint64_t>(replicate));
}

void require_replicate_seed(const Study& study, const nlohmann::json& r, const std::string& file,
                            int line) {
  const int n = r.at("n").get<int>(), rep = r.at("replicate").get<int>();
  const std::uint64_t expected = replicate_seed(study, n, rep);
  if (r.at("seed").get<std::uint64_t>() != expected)
    throw InputError(SourceLocation{file, line, 0, -1, "$.seed"},
                     "replicate n=" + std::to_string(n) + " #" + std::to_string(rep) +
                         " has seed " + r.at("seed").dump() + ", not " + std::to_string(expected) +
                         ", the one derived for it from the study's seed: the record was edited "
                         "(its n or index changed) or simulated with another seed; remove the "
                         "line to simulate that replicate again");
}

}  // namespace

bool significant(double p, double alpha) {
  return std::isfinite(p) && p < alpha;
}

double median_of_counts(const std::vector<long>& counts) {
  long total = 0;
  for (long c : counts) total += c;
  if (total == 0) return kNaN;
  // The values at 0-based ranks (total - 1) / 2 and total / 2.
  auto at_rank = [&](long rank) {
    long seen = 0;
    for (std::size_t k = 0; k < counts.size(); ++k)
      if ((seen += counts[k]) > rank) return static_cast<double>(k);
    return kNaN;  // unreachable: rank < total
  };
  return 0.5 * (at_rank((total - 1) / 2) + at_rank(total / 2));
}

std::vector<SimValue> simulate_study(const Study& study, int jobs) {
  const Plan plan = make_plan(study);
  std::vector<std::vector<SimValue>> per(plan.participants.size());
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex mu;
  auto worker = [&] {
    for (std::size_t i; (i = next++) < plan.participants.size();) {
      try {
        const ParticipantPlan& pp = plan.participants[i];
        auto sessions = simulate_participant(study, pp);
        for (const auto& s : sessions)
          for (const auto& m : s.measures)
            per[i].push_back(
                {pp.id, pp.group, s.session.phase, s.session.phase_index + 1, m.name, m.value});
      } catch (...) {
        std::lock_guard lock(mu);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> threads;
  for (int j = 0; j < std::max(1, jobs); ++j) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  std::vector<SimValue> out;
  for (auto& v : per) out.insert(out.end(), v.begin(), v.end());
  return out;
}

Study resized_study(const Study& study, int n, std::uint64_t seed) {
  if (study.assignment == "explicit")
    throw InputError(
        "the study assigns participants explicitly; group sizes cannot be varied (use "
        "balanced_random assignment for a power analysis)",
        study.file);
  if (n < 2) throw InputError("group size must be >= 2, got " + std::to_string(n));
  // The validator's bound on the plan, for the resized study (a typo such as n = 100000 would
  // otherwise take all memory).
  long long sessions = 0;
  for (const auto& p : study.phases) sessions += p.sessions;
  const long long planned =
      static_cast<long long>(n) * static_cast<long long>(study.groups.size()) * sessions;
  if (planned > kMaxPlannedSessions)
    throw InputError(
        "group size " + std::to_string(n) + ": the study resized to it plans " + std::to_string(n) +
            " x " + std::to_string(study.groups.size()) + " participants x " +
            std::to_string(sessions) + " sessions = " + std::to_string(planned) +
            " sessions; palplab runs at most " + std::to_string(kMaxPlannedSessions) + " per study",
        study.file);
  Study s = study;
  for (auto& g : s.groups) g.size = n;
  s.seed = seed;
  return s;
}

namespace {

bool is_test(const Analysis& a) {
  return a.kind == "anova_oneway" || a.kind == "pairwise_t";
}
std::string cell_id(const Analysis& a) {
  return a.measure + " " + a.phase + (a.pooled ? " pooled" : "");
}
// The values of each group (study order) a declared test takes: its measure in its phase, the
// last session of the phase or all of them pooled (as the report does).
analysis::Groups tested_values(const Study& study, const Analysis& a,
                               const std::vector<SimValue>& values) {
  int last = 0;
  for (const auto& v : values)
    if (v.phase == a.phase && v.measure == a.measure) last = std::max(last, v.session);
  analysis::Groups groups(study.groups.size());
  for (const auto& v : values) {
    if (v.phase != a.phase || v.measure != a.measure || !v.value) continue;
    if (!a.pooled && v.session != last) continue;
    for (std::size_t g = 0; g < study.groups.size(); ++g)
      if (study.groups[g].id == v.group) groups[g].push_back(*v.value);
  }
  return groups;
}

}  // namespace

std::vector<TestOutcome> run_declared_analyses(const Study& study,
                                               const std::vector<SimValue>& values) {
  std::vector<TestOutcome> out;
  for (const auto& a : study.analyses) {
    if (!is_test(a)) continue;
    const analysis::Groups groups = tested_values(study, a, values);
    const std::string base = a.kind + " " + cell_id(a);
    auto enough = [](const std::vector<double>& x) { return x.size() >= 2; };
    if (a.kind == "anova_oneway") {
      TestOutcome t{base, kNaN, kNaN, "eta_squared"};
      if (std::all_of(groups.begin(), groups.end(), enough) && groups.size() >= 2) {
        const analysis::Anova r = analysis::oneway_anova(groups);
        if (r.defined) t.p = r.p, t.effect = r.eta_squared;
      }
      out.push_back(t);
    } else {
      for (std::size_t i = 0; i < groups.size(); ++i)
        for (std::size_t j = i + 1; j < groups.size(); ++j) {
          TestOutcome t{base + (a.welch ? "" : " student") + " " + study.groups[i].id + "-" +
                            study.groups[j].id,
                        kNaN, kNaN, "hedges_g"};
          if (enough(groups[i]) && enough(groups[j])) {
            const analysis::TTest r = a.welch ? analysis::welch_t(groups[i], groups[j])
                                              : analysis::student_t(groups[i], groups[j]);
            if (r.defined) t.p = r.p;
            const analysis::EffectSize e = analysis::cohens_d_point(groups[i], groups[j]);
            if (e.defined) t.effect = e.g;
          }
          out.push_back(t);
        }
    }
  }
  return out;
}

std::vector<GroupDescriptive> tested_group_descriptives(const Study& study,
                                                        const std::vector<SimValue>& values) {
  std::vector<GroupDescriptive> out;
  std::set<std::string> seen;
  for (const auto& a : study.analyses) {
    if (!is_test(a) || !seen.insert(cell_id(a)).second) continue;
    const analysis::Groups groups = tested_values(study, a, values);
    for (std::size_t g = 0; g < groups.size(); ++g) {
      const auto& x = groups[g];
      const analysis::Descriptives d = analysis::describe(x);
      out.push_back({cell_id(a), study.groups[g].id, d.n, x.empty() ? kNaN : d.mean,
                     x.size() < 2 ? kNaN : d.sd, x.size() < 2 ? kNaN : d.ci_low,
                     x.size() < 2 ? kNaN : d.ci_high});
    }
  }
  return out;
}

std::string order_of_means(const std::vector<GroupDescriptive>& groups, const std::string& cell) {
  std::vector<const GroupDescriptive*> of;
  for (const auto& g : groups)
    if (g.cell == cell) {
      if (!std::isfinite(g.mean)) return "";
      of.push_back(&g);
    }
  std::sort(of.begin(), of.end(), [](const GroupDescriptive* a, const GroupDescriptive* b) {
    return a->mean > b->mean || (a->mean == b->mean && a->group < b->group);
  });
  std::string order;
  for (std::size_t i = 0; i < of.size(); ++i)
    order += (i == 0 ? "" : of[i - 1]->mean == of[i]->mean ? " = " : " > ") + of[i]->group;
  return order;
}

std::string compared_order(const std::vector<GroupDescriptive>& groups, const std::string& cell) {
  const std::string order = order_of_means(groups, cell);
  return order.find(" = ") == std::string::npos ? order : "";
}

Comparison compare_with_people(const PeopleVerdicts& people, const std::vector<TestOutcome>& tests,
                               const std::vector<GroupDescriptive>& groups, double alpha) {
  Comparison c;
  std::size_t verdicts = 0;
  for (const auto& t : people.tests) {
    if (!std::isfinite(t.p)) continue;  // no verdict: not compared
    ++verdicts;
    const auto it = std::find_if(tests.begin(), tests.end(),
                                 [&](const TestOutcome& x) { return x.id == t.id; });
    if (it != tests.end() && significant(it->p, alpha) == significant(t.p, alpha))
      c.agree.push_back(t.id);
  }
  c.all_agree = c.agree.size() == verdicts;
  std::set<std::string> cells;
  for (const auto& g : people.groups) cells.insert(g.cell);
  c.all_orders = c.all_inside = true;
  for (const auto& cell : cells) {
    const std::string theirs = compared_order(people.groups, cell);
    if (theirs.empty()) continue;
    if (order_of_means(groups, cell) == theirs)
      c.same_order.push_back(cell);
    else
      c.all_orders = false;
  }
  for (const auto& p : people.groups) {
    if (!std::isfinite(p.ci_low)) continue;
    const auto it = std::find_if(groups.begin(), groups.end(), [&](const GroupDescriptive& g) {
      return g.cell == p.cell && g.group == p.group;
    });
    if (it != groups.end() && it->mean >= p.ci_low && it->mean <= p.ci_high)
      c.inside.push_back(p.cell + "\t" + p.group);
    else
      c.all_inside = false;
  }
  return c;
}

std::optional<std::pair<int, int>> parse_shard(const std::string& text, const std::string& sep) {
  const std::size_t at = text.find(sep);
  if (at == std::string::npos) return std::nullopt;
  // Digits only, no leading zero, stopping once above kMaxShards (no overflow, no wrap-around).
  auto number = [](const std::string& d) -> std::optional<long> {
    if (d.empty() || d.size() > 20 || has_leading_zero(d)) return std::nullopt;
    long v = 0;
    for (const char c : d) {
      if (c < '0' || c > '9') return std::nullopt;
      v = v * 10 + (c - '0');
      if (v > kMaxShards) return std::nullopt;
    }
    return v;
  };
  const auto i = number(text.substr(0, at)), k = number(text.substr(at + sep.size()));
  if (!i || !k || *i < 1 || *i > *k) return std::nullopt;
  return std::make_pair(static_cast<int>(*i), static_cast<int>(*k));
}

bool has_leading_zero(const std::string& digits) {
  return digits.size() > 1 && digits[0] == '0';
}

ReplicateTasks::ReplicateTasks(const std::vector<int>& ns, int replicates, int shard, int shards,
                               const std::set<std::pair<int, int>>& done, int rank, int ranks)
    : ns_(ns),
      done_(done),
      replicates_(std::max(0, replicates)),
      shard_(shard),
      shards_(std::max(1, shards)),
      rank_(rank),
      ranks_(std::max(1, ranks)) {
  // Counted, not listed: every size's indices of this shard, less those done.
  for (size_ = 0; size_ < ns_.size(); ++size_) {
    start_size();
    if (r_ < replicates_) total_ += (replicates_ - 1 - r_) / shards_ + 1;
  }
  for (const auto& [n, r] : done_)
    for (std::size_t i = 0; i < ns_.size(); ++i)
      if (ns_[i] == n && r >= 0 && r < replicates_ &&
          (static_cast<long>(i) * replicates_ + r) % shards_ == shard_)
        --total_;
  size_ = 0;
  start_size();
}

// The first replicate index of size size_ in this shard: (size_ * R + r) % K == shard.
void ReplicateTasks::start_size() {
  const long base = static_cast<long>(size_) * replicates_ % shards_;
  r_ = ((shard_ - base) % shards_ + shards_) % shards_;
}

bool ReplicateTasks::next(ReplicateTask& t) {
  while (size_ < ns_.size()) {
    if (r_ >= replicates_) {
      ++size_;
      start_size();
      continue;
    }
    const int n = ns_[size_], r = static_cast<int>(r_);
    r_ += shards_;
    if (done_.count({n, r})) continue;
    if (position_++ % ranks_ != rank_) continue;
    t = {n, r};
    return true;
  }
  return false;
}

std::vector<int> power_sizes(const Study& study, const PowerOptions& opt) {
  if (!opt.n.empty()) return opt.n;
  for (const auto& g : study.groups)
    if (g.size != study.groups.front().size)
      throw InputError("groups differ in size; give the sizes to simulate with --n", study.file);
  // The study's own size: a group of one has no variance to test (a pilot study of one per
  // group was "group size must be >= 2, got 1" with no file and no way out named).
  if (study.groups.front().size < 2)
    throw InputError("$.groups[*].size: the study's groups have " +
                         std::to_string(study.groups.front().size) +
                         " participant each; a power analysis needs at least 2 per group: give "
                         "the sizes to simulate with --n (e.g. --n 6,8,10)",
                     study.file);
  return {study.groups.front().size};
}

// The prototypes a replicate was simulated with (their files and meshes, input_pins.hpp), one
// SHA-256 over "id=hash" lines in id order: a record names its study by the study file's hash,
// which does not change when a prototype file does (review 2026-12-06, third: a resumed power
// mixed replicates of two contact stiffnesses in one summary, exit 0).
std::string prototypes_sha256(const Study& study) {
  std::string lines;
  for (const auto& [id, file] : study.prototype_files)
    lines += id + "=" + prototype_sha256(file) + "\n";
  return results::sha256_hex(lines);
}

long run_power(const Study& study, const PowerOptions& opt) {
  const Ranks ranks = init_ranks();
  // Held until the run ends: a second `power` on the same replicate file would simulate the
  // same replicates and interleave its lines (review 2026-12-06, third: every replicate twice).
  struct Lock {
    int fd = -1;
    ~Lock() {
      if (fd >= 0) ::close(fd);
    }
  } lock;
  std::vector<int> ns;
  std::string sha, protos, file;
  // Every (n, replicate) has a global index; shard I of K takes index % K == I - 1.
  std::set<std::pair<int, int>> done;
  // Rank 0 reads and checks the files; an error is said by it alone, and every other rank,
  // waiting for what it read, learns of it (settle) rather than waiting for ever.
  std::exception_ptr error;
  try {
    ns = power_sizes(study, opt);
    if (opt.replicates < 1) throw InputError("--replicates must be >= 1");
    if (opt.shards < 1 || opt.shards > kMaxShards || opt.shard < 0 || opt.shard >= opt.shards)
      throw InputError("--shard I/K needs 1 <= I <= K <= " + std::to_string(kMaxShards));
    sha = results::sha256_hex(study.json_text);
    protos = prototypes_sha256(study);
    file = replicate_file(opt);
    if (ranks.rank == 0) {
      std::error_code ec;
      fs::create_directories(opt.out_dir, ec);
      if (!fs::is_directory(opt.out_dir))
        throw InputError("cannot create the output directory", opt.out_dir);
      lock.fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
      if (lock.fd < 0)
        throw InputError(
            std::string("cannot write the replicate file (") + std::strerror(errno) + ")", file);
      if (::flock(lock.fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK)
        throw InputError(
            "is in use: another palplab power is running with this --out (its "
            "replicates would be simulated twice); wait for it, or use another --out",
            file);
      repair_tail(file);
      // (The file exists, created above, even when this shard has nothing to run — K above the
      // replicate count: `palplab merge` takes a shard without its file for a missing one.)
      if (fs::exists(file))
        for (const auto& [r, line] : read_replicates(file)) {
          if (r.at("study_sha256") != sha)
            throw InputError(
                "the replicate file holds another study (SHA-256 differs); use another --out",
                file);
          // (Records written before the prototypes were pinned have no such key.)
          if (r.contains("prototypes_sha256") && r.at("prototypes_sha256") != protos)
            throw InputError(
                SourceLocation{file, line, 0, -1, "$.prototypes_sha256"},
                "replicate simulated with other prototype files than the study's now (a "
                "prototype or its mesh changed since): its results would be mixed with the new "
                "ones; restore them, or use another --out");
          // Its seed is the one derived from the study's seed for its n and index: otherwise
          // the record was edited (a line copied to fill a gap, its index changed) or written
          // for another seed, and it would stand for a replicate never simulated.
          require_replicate_seed(study, r, file, line);
          done.insert({r.at("n").get<int>(), r.at("replicate").get<int>()});
        }
      check_out_dir_study(opt.out_dir, sha);  // its power.json and other shards' files
    }
  } catch (...) {
    error = std::current_exception();
  }
  settle(ranks, error);
  // Every rank needs to know what is done: rank 0 read it; share as text.
  std::string done_text;
  for (const auto& [n, r] : done) done_text += std::to_string(n) + " " + std::to_string(r) + "\n";
#ifdef PALPLAB_MPI
  if (ranks.mpi) {
    long len = static_cast<long>(done_text.size());
    MPI_Bcast(&len, 1, MPI_LONG, 0, MPI_COMM_WORLD);
    done_text.resize(len);
    MPI_Bcast(done_text.data(), static_cast<int>(len), MPI_CHAR, 0, MPI_COMM_WORLD);
    std::istringstream in(done_text);
    for (int n, r; in >> n >> r;) done.insert({n, r});
  }
#endif
  // This shard's missing replicates, in index order (the same sequence on every rank); rank r
  // of K takes every K-th of them. Enumerated round by round, never listed (ReplicateTasks).
  ReplicateTasks tasks(ns, opt.replicates, opt.shard, opt.shards, done, ranks.rank, ranks.size);
  const long total = tasks.total();

  // Rounds: each rank runs up to `jobs` replicates in parallel, then rank 0 appends everything
  // finished in the round (so an interruption loses at most one round).
  const int jobs = std::max(1, opt.jobs);
  const long rounds = max_over_ranks(ranks, (tasks.mine() + jobs - 1) / jobs);
  const auto t0 = Clock::now();
  long finished = 0;
  // A failed simulation on any rank, or rank 0's failed append (settled in the next round),
  // ends the run on every rank.
  for (long round = 0; round < rounds; ++round) {
    std::vector<ReplicateTask> batch;
    for (ReplicateTask t; !error && static_cast<int>(batch.size()) < jobs && tasks.next(t);)
      batch.push_back(t);
    std::vector<std::string> lines(batch.size());
    std::vector<std::thread> threads;
    std::mutex mu;
    // (A thread that cannot be started is an error of this rank like any other: settled.)
    try {
      for (std::size_t k = 0; k < batch.size(); ++k)
        threads.emplace_back([&, k] {
          try {
            const ReplicateTask t = batch[k];
            const std::uint64_t seed = replicate_seed(study, t.n, t.replicate);
            const Study s = resized_study(study, t.n, seed);
            nlohmann::json rec = {{"study_sha256", sha},
                                  {"prototypes_sha256", protos},
                                  {"study", study.id},
                                  {"n", t.n},
                                  {"replicate", t.replicate},
                                  {"seed", seed},
                                  {"plan", {{"replicates", opt.replicates}, {"n", ns}}},
                                  {"tests", nlohmann::json::array()},
                                  {"groups", nlohmann::json::array()}};
            const std::vector<SimValue> values = simulate_study(s, 1);
            for (const auto& o : run_declared_analyses(s, values))
              rec["tests"].push_back({{"id", o.id},
                                      {"p", num_or_null(o.p)},
                                      {"effect", num_or_null(o.effect)},
                                      {"effect_name", o.effect_name}});
            for (const auto& d : tested_group_descriptives(s, values))
              rec["groups"].push_back({{"cell", d.cell},
                                       {"group", d.group},
                                       {"n", d.n},
                                       {"mean", num_or_null(d.mean)},
                                       {"sd", num_or_null(d.sd)}});
            lines[k] = rec.dump() + "\n";
          } catch (...) {
            std::lock_guard lock(mu);
            if (!error) error = std::current_exception();
          }
        });
    } catch (...) {
      std::lock_guard lock(mu);
      if (!error) error = std::current_exception();
    }
    for (auto& t : threads) t.join();
    settle(ranks, error);
    std::string mine_text;
    for (const auto& l : lines) mine_text += l;
    const std::string all = gather_to_root(ranks, mine_text);
    if (ranks.rank == 0) {
      try {
        std::ofstream out(file, std::ios::app | std::ios::binary);
        out << all;
        out.flush();
        if (!out) throw InputError("cannot append to the replicate file", file);
        finished += std::count(all.begin(), all.end(), '\n');
        if (opt.progress)
          opt.progress(finished, total, std::chrono::duration<double>(Clock::now() - t0).count());
      } catch (...) {
        error = std::current_exception();
      }
    }
  }
  settle(ranks, error);
#ifdef PALPLAB_MPI
  if (ranks.mpi) {
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Finalize();
    // Only rank 0 writes the summary.
    if (ranks.rank != 0) return -1;
  }
#endif
  // Every rank's replicates, as rank 0 appended them (a count of this rank's own share made the
  // summary under MPI say "6 replicates run now" for 12; review 2026-12-07).
  return finished;
}

int power_rank() {
  return init_ranks().rank;
}

bool power_under_mpi() {
  return init_ranks().mpi;
}

void end_ranks() {
#ifdef PALPLAB_MPI
  if (!init_ranks().mpi) return;
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (finalized) return;
  MPI_Barrier(MPI_COMM_WORLD);
  MPI_Finalize();
#endif
}

void settle_ranks(std::exception_ptr error) {
  settle(init_ranks(), error);
}

namespace {

// power_summary's group means and orders of the tested cells, from the records that hold them:
// out["groups"] (per cell and group, per n: the group mean's median and 2.5/97.5 % quantiles,
// the SD's median) and out["orders"] (per cell, per n: how many replicates had each order of the
// group means). Neither when no record holds group descriptives.
void add_groups(nlohmann::json& out, const std::map<std::pair<int, int>, nlohmann::json>& reps) {
  struct Acc {
    std::vector<double> means, sds;
  };
  std::vector<std::pair<std::string, std::string>> keys;  // (cell, group), first seen first
  std::map<std::pair<std::string, std::string>, std::map<int, Acc>> acc;
  std::vector<std::string> cells;
  std::map<std::string, std::map<int, std::map<std::string, long>>> orders;  // cell, n, order
  std::map<int, long> with;                                                  // n -> records
  for (const auto& [key, r] : reps) {
    if (!r.contains("groups")) continue;
    ++with[key.first];
    const auto gs = record_groups(r);
    for (const auto& g : gs) {
      const auto k = std::make_pair(g.cell, g.group);
      if (!acc.count(k)) keys.push_back(k);
      Acc& a = acc[k][key.first];
      if (std::isfinite(g.mean)) a.means.push_back(g.mean);
      if (std::isfinite(g.sd)) a.sds.push_back(g.sd);
      if (std::find(cells.begin(), cells.end(), g.cell) == cells.end()) cells.push_back(g.cell);
    }
    std::set<std::string> done;
    for (const auto& g : gs)
      if (done.insert(g.cell).second) {
        const std::string o = order_of_means(gs, g.cell);
        if (!o.empty()) ++orders[g.cell][key.first][o];
      }
  }
  if (with.empty()) return;
  out["groups"] = nlohmann::json::array();
  for (const auto& k : keys) {
    nlohmann::json g = {{"cell", k.first}, {"group", k.second}, {"by_n", nlohmann::json::array()}};
    for (auto& [n, a] : acc[k]) {
      std::sort(a.means.begin(), a.means.end());
      std::sort(a.sds.begin(), a.sds.end());
      g["by_n"].push_back({{"n", n},
                           {"replicates", a.means.size()},
                           {"records", with[n]},
                           {"mean_median", num_or_null(quantile(a.means, 0.5))},
                           {"mean_q025", num_or_null(quantile(a.means, 0.025))},
                           {"mean_q975", num_or_null(quantile(a.means, 0.975))},
                           {"sd_median", num_or_null(quantile(a.sds, 0.5))}});
    }
    out["groups"].push_back(g);
  }
  out["orders"] = nlohmann::json::array();
  for (const auto& c : cells) {
    nlohmann::json o = {{"cell", c}, {"by_n", nlohmann::json::array()}};
    for (const auto& [n, k] : with) {
      // Most frequent first.
      std::vector<std::pair<std::string, long>> by(orders[c][n].begin(), orders[c][n].end());
      std::stable_sort(by.begin(), by.end(),
                       [](const auto& a, const auto& b) { return a.second > b.second; });
      nlohmann::json counts = nlohmann::json::array();
      for (const auto& [order, count] : by) counts.push_back({{"order", order}, {"count", count}});
      o["by_n"].push_back({{"n", n}, {"replicates", k}, {"orders", counts}});
    }
    out["orders"].push_back(o);
  }
}

// power_summary's comparison with the people's results (power.hpp, PeopleVerdicts): each
// replicate compared (compare_with_people) and counted per n, beside what a right model reaches
// at that n (RightModel; null for an n it was not drawn for).
void add_people(nlohmann::json& out, const std::map<std::pair<int, int>, nlohmann::json>& reps,
                const PeopleVerdicts& people, double alpha) {
  for (const auto& t : people.tests)
    if (std::none_of(out.at("tests").begin(), out.at("tests").end(),
                     [&](const nlohmann::json& x) { return x.at("id") == t.id; }))
      throw InputError("the people's test \"" + t.id +
                           "\" is not among the replicates' tests (were they simulated from "
                           "another version of the study?)",
                       people.file);
  const bool groups = out.contains("groups");
  if (groups)
    for (const auto& g : people.groups)
      if (std::none_of(out.at("groups").begin(), out.at("groups").end(),
                       [&](const nlohmann::json& x) {
                         return x.at("cell") == g.cell && x.at("group") == g.group;
                       }))
        throw InputError("the people's group " + g.group + " in " + g.cell +
                             " is not among the replicates' groups (were they simulated from "
                             "another version of the study?)",
                         people.file);
  std::size_t verdicts = 0;
  for (const auto& t : people.tests) verdicts += std::isfinite(t.p);
  struct Counts {
    long replicates = 0, all = 0;
    std::vector<long> agreeing;  // replicates by the number of tests agreeing
    std::map<std::string, long> per_test, same_order, inside;
    long with_groups = 0, all_orders = 0, all_inside = 0, pattern = 0;
  };
  std::map<int, Counts> by_n;
  for (const auto& [key, r] : reps) {
    Counts& a = by_n[key.first];
    if (a.agreeing.empty()) a.agreeing.assign(verdicts + 1, 0);
    ++a.replicates;
    std::vector<TestOutcome> tests;
    for (const auto& t : r.at("tests"))
      tests.push_back({t.at("id").get<std::string>(), num_or_nan(t.at("p")), kNaN, ""});
    const bool has_groups = r.contains("groups");
    const Comparison c = compare_with_people(
        people, tests, has_groups ? record_groups(r) : std::vector<GroupDescriptive>{}, alpha);
    for (const auto& id : c.agree) ++a.per_test[id];
    ++a.agreeing[c.agree.size()];
    a.all += c.all_agree;
    if (!has_groups) continue;  // an older record: verdicts only
    ++a.with_groups;
    for (const auto& cell : c.same_order) ++a.same_order[cell];
    for (const auto& k : c.inside) ++a.inside[k];
    a.all_orders += c.all_orders;
    a.all_inside += c.all_inside;
    a.pattern += c.pattern();
  }
  const double draws = static_cast<double>(people.resamples);
  // A right model's share at n of `count` (a RightModel member), null without draws at n.
  auto right = [&](int n, auto count) -> nlohmann::json {
    const auto it = people.right.find(n);
    if (it == people.right.end() || people.resamples <= 0) return nullptr;
    return count(it->second) / draws;
  };
  auto in = [](const std::map<std::string, long>& m, const std::string& k) {
    const auto it = m.find(k);
    return it == m.end() ? 0L : it->second;
  };
  for (auto& t : out["tests"]) {
    const std::string id = t.at("id").get<std::string>();
    const auto mine = std::find_if(people.tests.begin(), people.tests.end(),
                                   [&](const TestOutcome& x) { return x.id == id; });
    if (mine == people.tests.end()) continue;
    const bool has_verdict = std::isfinite(mine->p);
    t["people"] = {{"p", num_or_null(mine->p)},
                   {"effect", num_or_null(mine->effect)},
                   {"significant",
                    has_verdict ? nlohmann::json(significant(mine->p, alpha)) : nlohmann::json()}};
    for (auto& c : t["by_n"]) {
      const int n = c.at("n").get<int>();
      c["agree"] = has_verdict ? nlohmann::json(in(by_n[n].per_test, id)) : nlohmann::json();
      c["right_model"] =
          has_verdict
              ? right(n, [&](const RightModel& m) { return static_cast<double>(in(m.agree, id)); })
              : nlohmann::json();
    }
  }
  if (groups) {
    for (auto& g : out["groups"]) {
      const auto it =
          std::find_if(people.groups.begin(), people.groups.end(), [&](const GroupDescriptive& x) {
            return x.cell == g.at("cell") && x.group == g.at("group");
          });
      if (it == people.groups.end()) continue;
      g["people"] = {{"n", it->n},
                     {"mean", num_or_null(it->mean)},
                     {"sd", num_or_null(it->sd)},
                     {"ci_low", num_or_null(it->ci_low)},
                     {"ci_high", num_or_null(it->ci_high)}};
      const std::string key = it->cell + "\t" + it->group;
      const bool compared = std::isfinite(it->ci_low);
      for (auto& c : g["by_n"]) {
        const int n = c.at("n").get<int>();
        c["inside"] = compared ? nlohmann::json(in(by_n[n].inside, key)) : nlohmann::json();
        c["right_model"] =
            compared
                ? right(n,
                        [&](const RightModel& m) { return static_cast<double>(in(m.inside, key)); })
                : nlohmann::json();
      }
    }
    for (auto& o : out["orders"]) {
      const std::string cell = o.at("cell").get<std::string>();
      const std::string order = order_of_means(people.groups, cell);
      const bool compared = !compared_order(people.groups, cell).empty();
      o["people"] = {{"order", order.empty() ? nlohmann::json() : nlohmann::json(order)},
                     {"compared", compared}};
      for (auto& c : o["by_n"]) {
        const int n = c.at("n").get<int>();
        c["same"] = compared ? nlohmann::json(in(by_n[n].same_order, cell)) : nlohmann::json();
        c["right_model"] = compared ? right(n,
                                            [&](const RightModel& m) {
                                              return static_cast<double>(in(m.same_order, cell));
                                            })
                                    : nlohmann::json();
      }
    }
  }
  nlohmann::json p = {{"file", people.file},
                      {"n", people.n},
                      {"tests", verdicts},
                      {"resamples", people.resamples},
                      {"seed", std::to_string(people.seed)},
                      {"by_n", nlohmann::json::array()}};
  for (const auto& [n, a] : by_n) {
    const auto ci =
        analysis::wilson_interval(static_cast<int>(a.all), static_cast<int>(a.replicates));
    nlohmann::json b = {{"n", n},
                        {"replicates", a.replicates},
                        {"all_agree", a.all},
                        {"ci_low", ci.low},
                        {"ci_high", ci.high},
                        {"median_agreeing", num_or_null(median_of_counts(a.agreeing))}};
    if (groups) {
      b["group_replicates"] = a.with_groups;
      b["all_orders"] = a.all_orders;
      b["all_inside"] = a.all_inside;
      b["pattern"] = a.pattern;
    }
    const auto it = people.right.find(n);
    if (it != people.right.end() && people.resamples > 0) {
      const RightModel& m = it->second;
      nlohmann::json rm = {{"all_agree", m.all_agree / draws},
                           {"median_agreeing", num_or_null(m.median_agreeing)}};
      if (groups) {
        rm["all_orders"] = m.all_orders / draws;
        rm["all_inside"] = m.all_inside / draws;
        rm["pattern"] = m.pattern / draws;
      }
      b["right_model"] = rm;
    } else {
      b["right_model"] = nullptr;
    }
    p["by_n"].push_back(b);
  }
  out["people"] = p;
}

}  // namespace

bool SummaryScope::covers(int n, int replicate) const {
  return (sizes.empty() || std::find(sizes.begin(), sizes.end(), n) != sizes.end()) &&
         (replicates <= 0 || replicate < replicates);
}

long LeftOut::total() const {
  long t = 0;
  for (const auto& m : {beyond, other_n})
    for (const auto& [n, k] : m) t += k;
  return t;
}

namespace {

// How often a value (the sorted test ids, or cells and groups, of a record) was read.
struct Seen {
  long count = 0, order = 0;  // how many records; the reading order of the first
  std::string at;             // FILE:LINE of the first
};

// The rest of "the replicate's tests" + " differ from those of the replicate at AT ...": the
// record holds `mine`, other than `common`, the value most records hold (`seen`: each value's
// count). " and most others" only when more than half of the records hold `common`; otherwise
// (a 2-2 tie said "and most others") both values are named, with how many records hold each,
// and that no value is held by most records.
std::string held_by(const std::map<std::vector<std::string>, Seen>& seen,
                    const std::vector<std::string>& common, const std::vector<std::string>& mine,
                    const std::string& at, const std::string& kind, const std::string& records,
                    const std::function<std::string(const std::vector<std::string>&)>& show) {
  long all = 0;
  for (const auto& [v, x] : seen) all += x.count;
  const long c = seen.at(common).count, m = seen.at(mine).count;
  if (2 * c > all) return " differ from those of the replicate at " + at + " and most others";
  bool tie = false;
  for (const auto& [v, x] : seen) tie = tie || (v != common && x.count == c);
  const long rest = all - c - m;
  return " " + show(mine) + " differ from those of the replicate at " + at + " " + show(common) +
         ", and no " + kind + " is held by most " + records + (tie ? " (a tie)" : "") + ": " +
         std::to_string(c) + " of the " + std::to_string(all) + " " + records +
         (c == 1 ? " holds" : " hold") + " those, " + std::to_string(m) + " these" +
         (rest > 0 ? ", the other " + std::to_string(rest) + " neither" : std::string()) +
         ", so which are the study's cannot be told from the records";
}

// ("a", "b") for a message, cut when long.
std::string show_list(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& i : items) s += (s.empty() ? "\"" : ", \"") + i + "\"";
  return "(" + shown_text(s, 200) + ")";
}
std::string show_ids(const std::vector<std::string>& ids) {
  return show_list(ids);
}
// "cell\tgroup" as ("A" in "f t", ...).
std::string show_cells(const std::vector<std::string>& cells) {
  std::vector<std::string> shown;
  for (const auto& c : cells) {
    const auto tab = c.find('\t');
    shown.push_back(c.substr(tab + 1) + "\" in \"" + c.substr(0, tab));
  }
  return show_list(shown);
}

}  // namespace

nlohmann::json power_summary(const std::vector<std::string>& files, double alpha,
                             double target_power, const SummaryScope& scope, LeftOut* left_out,
                             const PeopleVerdicts* people) {
  std::map<std::pair<int, int>, nlohmann::json> reps;
  std::map<std::pair<int, int>, std::string> where;      // FILE:LINE each replicate came from
  std::map<std::uint64_t, std::pair<int, int>> seed_of;  // the (n, replicate) of each seed
  std::string sha, study_id;
  std::string first;                     // FILE:LINE of the first replicate read
  std::vector<std::string> first_ids;    // the most common test ids (ties: first read), sorted
  std::vector<std::string> first_cells;  // the most common "cell\tgroup" of records with groups
  std::string first_cells_at;
  std::string protos, protos_at;  // the first record's prototypes_sha256 and its FILE:LINE
  std::map<std::string, std::pair<std::string, std::string>> effect_of;  // id -> (name, FILE:LINE)
  // Every record first: the test ids and the cells most records share are what an odd record
  // is compared with (an edited first record was reported at the second, which was right;
  // review 2026-12-07).
  std::vector<std::pair<std::string, std::vector<ReplicateLine>>> all;
  std::string ids_at;  // FILE:LINE of the first record with the common test ids
  for (const auto& f : files) all.push_back({f, read_replicates(f)});
  auto test_ids = [](const nlohmann::json& r) {
    std::vector<std::string> ids;
    if (r.contains("tests") && r.at("tests").is_array())
      for (const auto& t : r.at("tests")) ids.push_back(t.at("id").get<std::string>());
    std::sort(ids.begin(), ids.end());
    return ids;
  };
  auto cells_of = [](const nlohmann::json& r) {
    std::vector<std::string> cells;
    for (const auto& g : r.at("groups"))
      cells.push_back(g.at("cell").get<std::string>() + "\t" + g.at("group").get<std::string>());
    std::sort(cells.begin(), cells.end());
    return cells;
  };
  std::map<std::vector<std::string>, Seen> ids_seen, cells_seen;
  {
    long order = 0;
    for (const auto& [f, lines] : all)
      for (const auto& [r, line] : lines) {
        const std::string at = f + ":" + std::to_string(line);
        ++order;
        ++ids_seen.try_emplace(test_ids(r), Seen{0, order, at}).first->second.count;
        if (r.contains("groups"))
          ++cells_seen.try_emplace(cells_of(r), Seen{0, order, at}).first->second.count;
      }
    // The most common (ties: the first read), with where it was first read.
    auto most = [](const auto& seen, std::vector<std::string>& value, std::string& at) {
      const Seen* best = nullptr;
      for (const auto& [v, x] : seen)
        if (!best || x.count > best->count || (x.count == best->count && x.order < best->order))
          best = &x, value = v;
      if (best) at = best->at;
    };
    most(ids_seen, first_ids, ids_at);
    most(cells_seen, first_cells, first_cells_at);
  }
  for (auto& [f, lines] : all)
    for (auto& [r, line] : lines) {
      const SourceLocation here{f, line};
      const std::string at = f + ":" + std::to_string(line);
      const std::string s = r.at("study_sha256").get<std::string>();
      if (first.empty()) sha = s, study_id = r.at("study").get<std::string>(), first = at;
      if (s != sha)
        throw InputError(SourceLocation{f, line, 0, -1, "$.study_sha256"},
                         "replicate of another study (SHA-256 " + s.substr(0, 12) +
                             ") than the one at " + first + " (SHA-256 " + sha.substr(0, 12) +
                             "); merge the shards of one study");
      // The same study file has one id: another id with its hash is an edited record.
      if (r.at("study") != study_id)
        throw InputError(SourceLocation{f, line, 0, -1, "$.study"},
                         "study id " + shown(r.at("study")) + " differs from \"" + study_id +
                             "\" at " + first + " (same SHA-256: the record was edited)");
      // Shards simulated with other prototype files (a prototype or its mesh changed between
      // them) are not one study's replicates.
      if (r.contains("prototypes_sha256")) {
        const std::string ps = r.at("prototypes_sha256").get<std::string>();
        if (protos.empty()) {
          protos = ps, protos_at = at;
        } else if (ps != protos) {
          throw InputError(SourceLocation{f, line, 0, -1, "$.prototypes_sha256"},
                           "replicate simulated with other prototype files (SHA-256 " +
                               ps.substr(0, 12) + ") than the one at " + protos_at + " (SHA-256 " +
                               protos.substr(0, 12) +
                               "): a prototype or its mesh changed between the shards; rerun "
                               "those shards with the same files");
        }
      }
      // Every replicate of one study has the same tested cells and groups (when it has them).
      if (r.contains("groups") && cells_of(r) != first_cells)
        throw InputError(SourceLocation{f, line, 0, -1, "$.groups"},
                         "the replicate's groups (cells and groups)" +
                             held_by(cells_seen, first_cells, cells_of(r), first_cells_at,
                                     "set of groups", "records with groups", show_cells) +
                             " (every replicate of a study has the same)");
      const std::pair<int, int> key{r.at("n").get<int>(), r.at("replicate").get<int>()};
      // Every replicate has its own seed (derived from the study's, its n and its index): one
      // seed under two (n, index) is a record copied to fill a gap with its index edited.
      if (auto [it, fresh] = seed_of.emplace(r.at("seed").get<std::uint64_t>(), key);
          !fresh && it->second != key)
        throw InputError(SourceLocation{f, line, 0, -1, "$.seed"},
                         "replicate n=" + std::to_string(key.first) + " #" +
                             std::to_string(key.second) +
                             " has the seed of replicate n=" + std::to_string(it->second.first) +
                             " #" + std::to_string(it->second.second) + " at " + where[it->second] +
                             " (each replicate has a seed of its own: one of the two records "
                             "was copied and its n or index edited)");
      if (auto it = reps.find(key); it != reps.end()) {
        // The same replicate from a palplab before group descriptives (2026-12-05) and after:
        // equal but for "groups", which the newer one adds; keep that one.
        // Runs asked for different plans (a resume with more --replicates or sizes, shards of
        // differently sized runs) simulate a replicate alike: the plan is not compared.
        nlohmann::json a = it->second, b = r;
        a.erase("plan");
        b.erase("plan");
        if (a == b) continue;
        if (a.contains("groups") != b.contains("groups")) {
          a.erase("groups");
          b.erase("groups");
          if (a == b) {
            if (r.contains("groups")) it->second = std::move(r), where[key] = at;
            continue;
          }
        }
        if (a != b)
          throw InputError(here, "replicate n=" + std::to_string(key.first) + " #" +
                                     std::to_string(key.second) + " differs from the one at " +
                                     where[key] +
                                     " (the same replicate must give the same record)");
        continue;
      }
      // Every replicate of one study runs the same declared analyses: the same test ids.
      if (test_ids(r) != first_ids)
        throw InputError(SourceLocation{f, line, 0, -1, "$.tests"},
                         "the replicate's tests" +
                             held_by(ids_seen, first_ids, test_ids(r), ids_at, "set of tests",
                                     "records", show_ids) +
                             " (every replicate of a study has the same tests)");
      // ... each with one effect size (the test's kind fixes it).
      const auto& tests = r.at("tests");
      for (std::size_t i = 0; i < tests.size(); ++i) {
        const std::string id = tests[i].at("id").get<std::string>();
        const std::string name = tests[i].at("effect_name").get<std::string>();
        const auto [it, fresh] = effect_of.emplace(id, std::make_pair(name, at));
        if (!fresh && it->second.first != name)
          throw InputError(
              SourceLocation{f, line, 0, -1, "$.tests[" + std::to_string(i) + "].effect_name"},
              "test \"" + id + "\" reports effect \"" + name + "\" here but \"" + it->second.first +
                  "\" at " + it->second.second +
                  " (a test's effect size is the same in every replicate)");
      }
      reps.emplace(key, std::move(r));
      where.emplace(key, at);
    }
  if (reps.empty()) throw InputError("no replicates found", files.empty() ? "" : files.front());
  // Only the replicates in scope are summarised; the others were checked like them above.
  LeftOut outside;
  for (auto it = reps.begin(); it != reps.end();) {
    const auto [n, replicate] = it->first;
    if (scope.covers(n, replicate)) {
      ++it;
      continue;
    }
    if (scope.covers(n, 0)) {
      ++outside.beyond[n];
      outside.largest[n] = std::max(outside.largest[n], replicate);
    } else {
      ++outside.other_n[n];
    }
    it = reps.erase(it);
  }
  if (left_out) *left_out = outside;
  if (reps.empty())
    throw InputError("none of the replicates found is among those asked for",
                     files.empty() ? "" : files.front());

  struct Cell {
    long reps = 0, significant = 0, undefined = 0;
    std::vector<double> effects;
  };
  std::vector<std::string> ids;  // test order of the first replicate
  std::map<std::string, std::string> effect_name;
  std::map<std::string, std::map<int, Cell>> cells;
  std::map<int, long> per_n;
  for (const auto& [key, r] : reps) {
    ++per_n[key.first];
    for (const auto& t : r.at("tests")) {
      const std::string id = t.at("id").get<std::string>();
      if (!effect_name.count(id)) ids.push_back(id), effect_name[id] = t.value("effect_name", "");
      Cell& c = cells[id][key.first];
      ++c.reps;
      const double p = num_or_nan(t.at("p"));
      if (!std::isfinite(p))
        ++c.undefined;
      else if (p < alpha)
        ++c.significant;
      const double e = num_or_nan(t.at("effect"));
      if (std::isfinite(e)) c.effects.push_back(e);
    }
  }
  nlohmann::json out = {{"study", study_id},
                        {"study_sha256", sha},
                        {"alpha", alpha},
                        {"target_power", target_power},
                        {"replicates", nlohmann::json::object()},
                        {"tests", nlohmann::json::array()}};
  for (const auto& [n, k] : per_n) out["replicates"][std::to_string(n)] = k;
  for (const auto& id : ids) {
    nlohmann::json t = {
        {"id", id}, {"effect_name", effect_name[id]}, {"by_n", nlohmann::json::array()}};
    nlohmann::json smallest = nullptr;
    for (auto& [n, c] : cells[id]) {
      std::sort(c.effects.begin(), c.effects.end());
      // An undefined test counts as not significant; with no defined test at all there is no
      // estimate (0 would read as "the test never detects the effect").
      const bool estimable = c.undefined < c.reps;
      // Wilson's interval (analysis/descriptives.hpp: exactly 0 at k = 0 and 1 at k = n).
      const analysis::ProportionInterval ci =
          analysis::wilson_interval(static_cast<int>(c.significant), static_cast<int>(c.reps));
      const double lo = ci.low, hi = ci.high;
      const double power = estimable ? static_cast<double>(c.significant) / c.reps : kNaN;
      // Summed in long double (analysis::mean): edited effects of 1.7e308 do not overflow it.
      const double mean = analysis::mean(c.effects);
      t["by_n"].push_back({{"n", n},
                           {"replicates", c.reps},
                           {"significant", c.significant},
                           {"undefined", c.undefined},
                           {"power", num_or_null(power)},
                           {"ci_low", estimable ? nlohmann::json(lo) : nlohmann::json()},
                           {"ci_high", estimable ? nlohmann::json(hi) : nlohmann::json()},
                           {"effect_mean", num_or_null(mean)},
                           {"effect_q025", num_or_null(quantile(c.effects, 0.025))},
                           {"effect_median", num_or_null(quantile(c.effects, 0.5))},
                           {"effect_q975", num_or_null(quantile(c.effects, 0.975))}});
      if (smallest.is_null() && estimable && power >= target_power) smallest = n;
    }
    t["smallest_n"] = smallest;
    out["tests"].push_back(t);
  }
  add_groups(out, reps);
  if (people) add_people(out, reps, *people, alpha);
  return out;
}

namespace {

// (I, K) of a file named replicates.shard-I-of-K.jsonl (as replicate_file writes), else nullopt:
// a name that does not parse strictly (parse_shard) is not a shard file.
std::optional<std::pair<int, int>> shard_of(const std::string& path) {
  const std::string name = fs::path(path).filename().string();
  const std::string head = "replicates.shard-", tail = ".jsonl";
  if (name.size() <= head.size() + tail.size() || name.rfind(head, 0) != 0 ||
      name.compare(name.size() - tail.size(), tail.size(), tail) != 0)
    return std::nullopt;
  return parse_shard(name.substr(head.size(), name.size() - head.size() - tail.size()), "-of-");
}

// "0, 2, 4" (the listed ones; when `total` is larger, then ", … and N more").
template <class T>
std::string index_list(const std::vector<T>& v, long total) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  if (total > static_cast<long>(v.size()))
    s += ", … and " + std::to_string(total - static_cast<long>(v.size())) + " more";
  return s;
}

}  // namespace

void check_replicate_seeds(const Study& study, const std::vector<std::string>& files) {
  for (const auto& f : files)
    for (const auto& [r, line] : read_replicates(f)) require_replicate_seed(study, r, f, line);
}

MergeGaps merge_gaps(const std::vector<std::string>& files) {
  MergeGaps g;
  std::map<long, std::set<long>> shards_seen;  // K -> I present
  std::map<int, std::set<int>> reps;           // n -> replicate indices present
  std::set<int> planned_n;                     // the sizes the records' runs asked for
  for (const auto& f : files) {
    if (const auto s = shard_of(f)) shards_seen[s->second].insert(s->first);
    for (const auto& [r, line] : read_replicates(f)) {
      reps[r.at("n").get<int>()].insert(r.at("replicate").get<int>());
      if (auto plan = r.find("plan"); plan != r.end()) {
        const int k = plan->at("replicates").get<int>();
        g.plans_replicates.insert(k);
        for (const auto& n : plan->at("n")) planned_n.insert(n.get<int>());
      }
    }
  }
  // The largest plan is what the merged runs meant to simulate (a run resumed with more
  // replicates or sizes extends the smaller one): each planned size needs every index below it.
  for (const int n : planned_n) reps[n];
  if (shards_seen.size() > 1) {
    std::string ks;
    for (const auto& [k, present] : shards_seen)
      ks += (ks.empty() ? "" : ", ") + std::string("K = ") + std::to_string(k) + " (" +
            std::to_string(present.size()) + " file" + (present.size() == 1 ? "" : "s") + ")";
    throw InputError("shard files of different --shard I/K runs among the merged files (" + ks +
                     "): which replicates are missing cannot be told. Merge the files of one run "
                     "(give them by name, or move the others out of the directory)");
  }
  for (const auto& [k, present] : shards_seen) {
    g.shards = k;
    g.missing_shard_count = k - static_cast<long>(present.size());
    auto it = present.begin();  // sorted: at most |present| + kListed steps
    for (long i = 1; i <= k && g.missing_shards.size() < MergeGaps::kListed; ++i) {
      if (it != present.end() && *it == i)
        ++it;
      else
        g.missing_shards.push_back(i);
    }
  }
  for (const auto& [n, set] : reps) {
    // Every index up to the largest present, or to the largest plan's for a planned size.
    int top = set.empty() ? -1 : *set.rbegin();
    if (planned_n.count(n)) top = std::max(top, g.planned_replicates() - 1);
    g.present[n] = static_cast<long>(set.size());
    g.largest[n] = top;
    const long upto = static_cast<long>(std::distance(set.begin(), set.upper_bound(top)));
    if (upto == static_cast<long>(top) + 1) continue;
    g.missing_replicate_count[n] = static_cast<long>(top) + 1 - upto;
    std::vector<int>& list = g.missing_replicates[n];
    auto it = set.lower_bound(0);
    for (int r = 0; r <= top && list.size() < MergeGaps::kListed; ++r) {
      if (it != set.end() && *it == r)
        ++it;
      else
        list.push_back(r);
    }
  }
  return g;
}

std::string MergeGaps::message() const {
  if (complete()) return {};
  std::string s;
  if (missing_shard_count > 0) {
    const std::string k = std::to_string(shards);
    s = missing_shard_count == 1
            ? "shard " + std::to_string(missing_shards.front()) + " of " + k +
                  " missing (no replicates.shard-" + std::to_string(missing_shards.front()) +
                  "-of-" + k + ".jsonl among the merged files)"
            : std::to_string(missing_shard_count) + " of " + k +
                  " shards missing: " + index_list(missing_shards, missing_shard_count) +
                  " (no replicates.shard-I-of-" + k + ".jsonl among the merged files)";
  }
  for (const auto& [n, gaps] : missing_replicates) {
    const long count = missing_replicate_count.at(n);
    s += (s.empty() ? "" : "; ") + std::string("n = ") + std::to_string(n) + ": " +
         (present.at(n) == 0
              ? "all " + std::to_string(count) + " replicate" + (count == 1 ? "" : "s") + " missing"
              : std::string("replicate") + (count == 1 ? " " : "s ") + index_list(gaps, count) +
                    " of 0-" + std::to_string(largest.at(n)) + " missing");
  }
  if (!missing_replicates.empty() && !plans_replicates.empty()) {
    std::string asked;
    for (const int k : plans_replicates) asked += (asked.empty() ? "" : ", ") + std::to_string(k);
    s += plans_replicates.size() == 1
             ? " (the runs asked for --replicates " + asked + ")"
             : " (runs asked for --replicates " + asked + ": the largest is what a merge holds)";
  }
  long total = 0;
  std::string per_n;
  for (const auto& [n, k] : present) {
    total += k;
    per_n += (per_n.empty() ? "" : ", ") + std::string("n = ") + std::to_string(n) + ": " +
             std::to_string(k);
  }
  return s + ": the summary covers only " + std::to_string(total) + " replicate" +
         (total == 1 ? "" : "s") + " (" + per_n + ")";
}

nlohmann::json MergeGaps::to_json() const {
  nlohmann::json j = {{"missing_shards", nlohmann::json::array()},
                      {"missing_shard_count", missing_shard_count},
                      {"missing_replicates", nlohmann::json::object()},
                      {"missing_replicate_count", nlohmann::json::object()},
                      {"replicates", nlohmann::json::object()},
                      {"message", message()}};
  for (const long i : missing_shards)
    j["missing_shards"].push_back(std::to_string(i) + "/" + std::to_string(shards));
  for (const auto& [n, gaps] : missing_replicates)
    j["missing_replicates"][std::to_string(n)] = gaps;
  for (const auto& [n, c] : missing_replicate_count)
    j["missing_replicate_count"][std::to_string(n)] = c;
  for (const auto& [n, k] : present) j["replicates"][std::to_string(n)] = k;
  return j;
}

void check_out_dir_study(const std::string& out_dir, const std::string& sha) {
  std::error_code ec;
  if (!fs::is_directory(out_dir, ec)) return;
  auto refuse = [&](const fs::path& file, const std::string& what) {
    return InputError(what + "; use another --out (or remove it)", file.string());
  };
  const fs::path summary = fs::path(out_dir) / "power.json";
  if (fs::exists(summary, ec)) {
    std::ifstream in(summary, std::ios::binary);
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (!j.is_object() || !j.contains("study_sha256") || !j.at("study_sha256").is_string())
      throw refuse(summary,
                   "the output directory holds a power.json that is not a palplab power "
                   "summary");
    if (j.at("study_sha256") != sha)
      throw refuse(summary,
                   "the output directory holds the power summary of another study (its "
                   "SHA-256 " +
                       j.at("study_sha256").get<std::string>().substr(0, 12) + "…, this study's " +
                       sha.substr(0, 12) +
                       "…: the study file was edited, or another study's --out was given)");
  }
  // The first record of each replicate file tells its study.
  for (const auto& e : fs::directory_iterator(out_dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("replicates", 0) != 0 || e.path().extension() != ".jsonl") continue;
    if (std::error_code e2; !fs::is_regular_file(e.path(), e2))
      throw refuse(e.path(),
                   "the output directory holds a replicate file that is not a regular "
                   "file (a directory, a FIFO or a device)");
    std::ifstream in(e.path(), std::ios::binary);
    std::string line;
    while (std::getline(in, line) && line.find_first_not_of(" \t\r") == std::string::npos) {
    }
    const nlohmann::json r = nlohmann::json::parse(line, nullptr, false);
    if (r.is_object() && r.contains("study_sha256") && r.at("study_sha256") != sha)
      throw refuse(e.path(),
                   "the output directory holds replicates of another study (their SHA-256 " +
                       r.at("study_sha256").dump().substr(1, 12) + "…, this study's " +
                       sha.substr(0, 12) +
                       "…: the study file was edited, or another study's --out was given)");
  }
}

std::string write_power_report(const nlohmann::json& s, const std::string& out_dir) {
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  auto fmt = [](const nlohmann::json& v, int digits) {
    if (!v.is_number()) return std::string("—");
    const double x = v.get<double>();
    char buf[64];
    // Far beyond any measure's range (an edited record): exponent form rather than 300 digits.
    std::snprintf(buf, sizeof buf, std::fabs(x) < 1e12 ? "%.*f" : "%.*e", digits, x);
    std::string t(buf);
    // A value that rounds to zero is 0, not "-0.00" (a median Hedges' g of -0.001).
    if (t[0] == '-' && t.find_first_not_of("-0.") == std::string::npos) t.erase(0, 1);
    return t;
  };
  std::ostringstream md;
  md << "# Power analysis: " << markdown_text(s.at("study").get<std::string>()) << "\n\n";
  const bool partial = s.contains("partial");
  if (partial)
    md << "**Partial result** (`palplab merge --allow-partial`): "
       << markdown_text(s.at("partial").at("message").get<std::string>())
       << ". The table covers only the replicates merged; power and the smallest n may change "
          "once every shard is merged.\n\n";
  md << "alpha = " << s.at("alpha").get<double>() << ", target power "
     << s.at("target_power").get<double>()
     << "; power = share of replicates with p < alpha, 95 % Monte Carlo interval (Wilson); "
        "undefined = replicates in which the test had no p-value (counted as not significant; "
        "— when it was undefined in all); effect: η² (ANOVA) or Hedges' g (pairs), median "
        "[2.5 %, 97.5 %].\n\n"
     << "| test | n per group | replicates | undefined | power | 95 % CI | effect median [2.5 %, "
        "97.5 %] |\n"
     << "|---|---:|---:|---:|---:|---|---|\n";
  std::vector<analysis::Series> series;
  int colour = 0;
  for (const auto& t : s.at("tests")) {
    analysis::Series line;
    line.name = t.at("id").get<std::string>();
    line.colour = colour++;
    for (const auto& c : t.at("by_n")) {
      md << "| " << markdown_text(line.name) << " | " << c.at("n").get<int>() << " | "
         << c.at("replicates").get<long>() << " | " << c.value("undefined", 0L) << " | "
         << fmt(c.at("power"), 3) << " | "
         << (c.at("ci_low").is_number()
                 ? "[" + fmt(c.at("ci_low"), 3) + ", " + fmt(c.at("ci_high"), 3) + "]"
                 : std::string("—"))
         << " | " << fmt(c.at("effect_median"), 2) << " [" << fmt(c.at("effect_q025"), 2) << ", "
         << fmt(c.at("effect_q975"), 2) << "] |\n";
      line.x.push_back(c.at("n").get<double>());
      if (!c.at("power").is_number()) {  // undefined in every replicate: no point drawn
        line.y.push_back(kNaN);
        line.lo.push_back(kNaN);
        line.hi.push_back(kNaN);
        continue;
      }
      line.y.push_back(c.at("power").get<double>());
      line.lo.push_back(c.at("ci_low").get<double>());
      line.hi.push_back(c.at("ci_high").get<double>());
    }
    series.push_back(line);
  }
  md << "\nSmallest n per group reaching the target power:\n\n";
  for (const auto& t : s.at("tests")) {
    md << "- " << markdown_text(t.at("id").get<std::string>()) << ": ";
    if (!t.at("smallest_n").is_null()) {
      md << t.at("smallest_n").get<int>() << "\n";
      continue;
    }
    std::string undefined_at;  // the sizes at which the test was never defined
    for (const auto& c : t.at("by_n"))
      if (!c.at("power").is_number())
        undefined_at += (undefined_at.empty() ? "" : ", ") + std::to_string(c.at("n").get<int>());
    md << "not reached in the simulated sizes"
       << (undefined_at.empty()
               ? ""
               : " (the test was undefined in every replicate at n = " + undefined_at + ")")
       << "\n";
  }
  const bool with_people = s.contains("people");
  // "k/R" and, when known, what a right model reaches at that n: "k/R (right model 0.83)".
  auto count_of = [&](const nlohmann::json& k, const nlohmann::json& r,
                      const nlohmann::json& right) {
    if (!k.is_number()) return std::string("—");
    return std::to_string(k.get<long>()) + "/" + std::to_string(r.get<long>()) +
           (right.is_number() ? " (right model " + fmt(right, 3) + ")" : "");
  };
  if (s.contains("groups")) {
    long with = 0, all = 0;  // replicates with group descriptives, and all of them
    for (const auto& [n, k] : s.at("replicates").items()) all += k.get<long>();
    for (const auto& c : s.at("groups").front().at("by_n")) with += c.at("records").get<long>();
    md << "\n## Group means\n\nPer tested cell and group, the replicates' group mean (median "
          "[2.5 %, 97.5 %] over the replicates) and SD (median)"
       << (with_people ? "; the people's mean with its 95 % interval (t) and SD, and how many "
                         "replicates' group means lie inside that interval, beside the share a "
                         "right model reaches (a people's study and a study of n drawn "
                         "independently from the people: a 95 % t interval holds a same-size "
                         "replication's mean only about 86 % of the time at n = 10)"
                       : "")
       << "."
       << (with < all
               ? " Group means are in " + std::to_string(with) + " of the " + std::to_string(all) +
                     " replicates (records written before 2026-12-05 have none)."
               : "")
       << "\n\n| cell | group | n per group | replicates | mean median [2.5 %, 97.5 %] | SD median "
          "|"
       << (with_people ? " people's mean [95 % CI] | people's SD | inside people's CI |" : "")
       << "\n|---|---|---:|---:|---|---:|" << (with_people ? "---|---:|---|" : "") << "\n";
    for (const auto& g : s.at("groups"))
      for (const auto& c : g.at("by_n")) {
        md << "| " << markdown_text(g.at("cell").get<std::string>()) << " | "
           << markdown_text(g.at("group").get<std::string>()) << " | " << c.at("n").get<int>()
           << " | " << c.at("replicates").get<long>() << " | " << fmt(c.at("mean_median"), 3)
           << " [" << fmt(c.at("mean_q025"), 3) << ", " << fmt(c.at("mean_q975"), 3) << "] | "
           << fmt(c.at("sd_median"), 3) << " |";
        if (with_people) {
          if (g.contains("people")) {
            const auto& pg = g.at("people");
            md << " " << fmt(pg.at("mean"), 3) << " [" << fmt(pg.at("ci_low"), 3) << ", "
               << fmt(pg.at("ci_high"), 3) << "] | " << fmt(pg.at("sd"), 3) << " | "
               << count_of(c.at("inside"), c.at("records"), c.at("right_model")) << " |";
          } else {
            md << " — | — | — |";
          }
        }
        md << "\n";
      }
    md << "\nOrder of the group means (largest first; equal means \"=\"), replicates per order"
       << (with_people ? ", and how many have the people's order beside the share a right "
                         "model reaches"
                       : "")
       << ":\n\n";
    for (const auto& o : s.at("orders")) {
      md << "- " << markdown_text(o.at("cell").get<std::string>());
      if (o.contains("people")) {
        const auto& po = o.at("people");
        md << " (people: "
           << (po.at("order").is_string() ? markdown_text(po.at("order").get<std::string>())
                                          : "undefined")
           << (po.at("compared").get<bool>() ? "" : "; a tie or undefined: not compared") << ")";
      }
      md << "\n";
      for (const auto& c : o.at("by_n")) {
        const long r = c.at("replicates").get<long>();
        md << "  - n = " << c.at("n").get<int>() << ":";
        long listed = 0;
        std::string list;
        for (const auto& x : c.at("orders")) {
          list += (list.empty() ? " " : ", ") + markdown_text(x.at("order").get<std::string>()) +
                  " " + std::to_string(x.at("count").get<long>()) + "/" + std::to_string(r);
          listed += x.at("count").get<long>();
        }
        if (listed < r)
          list += (list.empty() ? " " : ", ") + std::string("undefined (a group without values) ") +
                  std::to_string(r - listed) + "/" + std::to_string(r);
        md << list << ".";
        if (c.contains("same") && c.at("same").is_number())
          md << " The people's order: "
             << count_of(c.at("same"), c.at("replicates"), c.at("right_model")) << ".";
        md << "\n";
      }
    }
  }
  if (with_people) {
    const auto& p = s.at("people");
    std::string sizes;
    for (const auto& [g, n] : p.at("n").items())
      sizes += (sizes.empty() ? "" : ", ") + markdown_text(g) + " " + std::to_string(n.get<int>());
    const std::string of = " of " + std::to_string(p.at("tests").get<long>());
    md << "\n## Agreement with people's verdicts ("
       << markdown_text(p.at("file").get<std::string>()) << ")\n\nPeople per group: " << sizes
       << ". A verdict is significant (p < alpha) or not (an undefined test counts as not). "
          "\"Replicates agreeing\" counts the simulated replicates above whose verdict is the "
          "people's; \"right model\" is how often a model that is right agrees at that n: a "
          "people's study and a study of n per group drawn independently from the people's "
          "participants (within groups, with replacement: the truth taken as their "
          "distribution), the second compared with the first, "
       << p.at("resamples").get<long>() << " times (seed " << p.at("seed").get<std::string>()
       << "), so that both studies' sampling errors are in it.\n\n"
       << "| test | people's p | people's effect | people's verdict | replicates agreeing (n: "
          "k/R) | right model (n: share) |\n|---|---:|---:|---|---|---|\n";
    for (const auto& t : s.at("tests")) {
      if (!t.contains("people")) continue;
      const auto& pt = t.at("people");
      if (pt.at("significant").is_null()) {  // undefined on the people's data: not compared
        md << "| " << markdown_text(t.at("id").get<std::string>())
           << " | — | — | undefined (no verdict; not compared) | — | — |\n";
        continue;
      }
      std::string model, right;
      for (const auto& c : t.at("by_n")) {
        const std::string n = std::to_string(c.at("n").get<int>()) + ": ";
        model += (model.empty() ? "" : "; ") + n + std::to_string(c.at("agree").get<long>()) + "/" +
                 std::to_string(c.at("replicates").get<long>());
        right += (right.empty() ? "" : "; ") + n + fmt(c.at("right_model"), 3);
      }
      const std::string id = markdown_text(t.at("id").get<std::string>());
      std::string p_text = fmt(pt.at("p"), 4);
      if (pt.at("p").is_number() && pt.at("p").get<double>() < 1e-3) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.1e", pt.at("p").get<double>());
        p_text = buf;
      }
      md << "| " << id << " | " << p_text << " | " << fmt(pt.at("effect"), 2) << " | "
         << (pt.at("significant").get<bool>() ? "significant" : "not significant") << " | " << model
         << " | " << right << " |\n";
    }
    std::string model, right;
    for (const auto& c : p.at("by_n")) {
      const std::string n = std::to_string(c.at("n").get<int>()) + ": ";
      model += (model.empty() ? "" : "; ") + n + std::to_string(c.at("all_agree").get<long>()) +
               "/" + std::to_string(c.at("replicates").get<long>()) + " [" +
               fmt(c.at("ci_low"), 2) + ", " + fmt(c.at("ci_high"), 2) + "], median " +
               fmt(c.at("median_agreeing"), 1) + of;
      const auto& rm = c.at("right_model");
      right += (right.empty() ? "" : "; ") + n +
               (rm.is_object() ? fmt(rm.at("all_agree"), 3) + ", median " +
                                     fmt(rm.at("median_agreeing"), 1) + of
                               : std::string("—"));
    }
    md << "| **all verdicts** | | | | " << model << " | " << right << " |\n";
    bool pattern = false;
    for (const auto& c : p.at("by_n")) pattern = pattern || c.contains("pattern");
    if (pattern) {
      md << "\nThe people's whole pattern: replicates (with group means) reaching every verdict "
            "above, the people's order of the group means in every compared cell, every group "
            "mean inside the people's 95 % interval, and all of these (Wilson 95 %), each beside "
            "the share a right model reaches:\n\n"
         << "| n | replicates | every verdict | every order | every mean inside | whole pattern "
            "|\n|---:|---:|---|---|---|---|\n";
      auto share = [&](long k, long r, const nlohmann::json& rm, const char* key) {
        const auto ci = analysis::wilson_interval(static_cast<int>(k), static_cast<int>(r));
        return std::to_string(k) + "/" + std::to_string(r) + " [" + fmt(ci.low, 2) + ", " +
               fmt(ci.high, 2) + "]" +
               (rm.is_object() ? " (right model " + fmt(rm.at(key), 3) + ")" : std::string());
      };
      for (const auto& c : p.at("by_n")) {
        if (!c.contains("pattern")) continue;
        const long r = c.at("group_replicates").get<long>();
        if (r == 0) continue;
        const auto& rm = c.at("right_model");
        md << "| " << c.at("n").get<int>() << " | " << r << " | ";
        // Every verdict among the replicates with group means is not stored: show the count of
        // all replicates when every one has groups (the same set), else leave it to the table.
        if (r == c.at("replicates").get<long>())
          md << share(c.at("all_agree").get<long>(), r, rm, "all_agree");
        else
          md << "(above)";
        md << " | " << share(c.at("all_orders").get<long>(), r, rm, "all_orders") << " | "
           << share(c.at("all_inside").get<long>(), r, rm, "all_inside") << " | "
           << share(c.at("pattern").get<long>(), r, rm, "pattern") << " |\n";
      }
    }
  }
  const std::string table = md.str();
  auto write = [&](const std::string& name, const std::string& text) {
    write_file((fs::path(out_dir) / name).string(), text, "the power summary");
  };
  write("power.json", s.dump(2) + "\n");
  write("power.md", table);
  write("power.svg",
        analysis::svg_line_plot(series,
                                std::string(partial ? "PARTIAL (shards missing): " : "") +
                                    "Power by group size (bars: the 95 % Monte Carlo "
                                    "interval)",
                                "participants per group", "power", true,
                                {{"target power " + fmt(s.at("target_power"), 2),
                                  s.at("target_power").get<double>()}}));
  return table;
}

}  // namespace palplab::protocols
