#pragma once
// Whole-study simulation in memory, and power analysis by simulating a study many times
// (`palplab power`, `palplab merge`; docs/PARTICIPANTS.md "Power analysis").
//
// A replicate is the study run once with virtual participants: every group gets n participants
// and the study seed is replaced by derive_seed(study seed, "power", n, replicate), so
// replicates are independent and each is reproducible on its own — whichever thread, shard or
// MPI rank computes it. Each replicate runs the study's declared analyses (one-way ANOVA and
// pairwise t-tests on a measure in a phase) and keeps, per test, its p-value and effect size
// (η² for an ANOVA, Hedges' g for a pair). Replicates are appended to DIR/replicates.jsonl as
// they finish (resume skips those already there); the summary (power with a Wilson 95 % Monte
// Carlo interval, effect-size quantiles, smallest n reaching the target power) is computed from
// that file alone — of `palplab power`, only the sizes and replicates it was asked for, the rest
// of the file kept — so shards merged afterwards give the single-run result exactly.
#include <cstdint>
#include <exception>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "protocols/study.hpp"

namespace palplab::protocols {

// One measure value of one simulated session (tidy, as `palplab export` writes measures.csv).
struct SimValue {
  std::string participant, group, phase;
  int session = 1;  // 1-based index within the phase
  std::string measure;
  std::optional<double> value;  // nullopt = undefined (e.g. the feature was never found)
};

// Simulates every planned participant of `study` on `jobs` threads (results do not depend on
// `jobs`). Participants are in plan order, sessions in timeline order.
std::vector<SimValue> simulate_study(const Study& study, int jobs = 1);

// `study` with every group resized to `n` (balanced random assignment only: an explicit
// assignment fixes the participants, an InputError) and its seed replaced by `seed`.
Study resized_study(const Study& study, int n, std::uint64_t seed);

// The outcome of one declared test in one replicate.
struct TestOutcome {
  std::string id;           // "anova_oneway palpation_force post_training", "pairwise_t ... A-B"
  double p = 1.0;           // two-sided p; NaN when the test is undefined
  double effect = 0.0;      // η² (ANOVA) or Hedges' g (pair, mean a - mean b); NaN if undefined
  std::string effect_name;  // "eta_squared" | "hedges_g"
};

// Runs the study's declared analyses (anova_oneway, pairwise_t; descriptives have no test) on
// simulated values. The one place that couples power analysis to analysis/.
std::vector<TestOutcome> run_declared_analyses(const Study& study,
                                               const std::vector<SimValue>& values);

// One group's values in one tested cell: the measure in the phase as a declared test takes it
// (its last session, or all sessions pooled). `cell` is "MEASURE PHASE" (+ " pooled"), the
// test ids' middle part.
struct GroupDescriptive {
  std::string cell, group;
  int n = 0;                           // defined values
  double mean = 0.0;                   // NaN when n = 0
  double sd = 0.0;                     // sample SD; NaN when n < 2
  double ci_low = 0.0, ci_high = 0.0;  // 95 % interval of the mean (t, n - 1 df); NaN if n < 2
};
// The order of the group means of `cell` in `groups`, largest first: "A > B > C", equal means
// joined by " = " in alphabetical order ("A = B > C"); empty when a group of the cell has no
// mean.
std::string order_of_means(const std::vector<GroupDescriptive>& groups, const std::string& cell);
// Every group in every cell a declared test (anova_oneway, pairwise_t) takes, cells in the order
// the analyses name them, groups in study order: what the tests compared.
std::vector<GroupDescriptive> tested_group_descriptives(const Study& study,
                                                        const std::vector<SimValue>& values);

struct PowerOptions {
  std::vector<int> n;  // group sizes; empty = the study's own (all groups equal)
  int replicates = 100;
  int jobs = 1;
  double alpha = 0.05;
  double target_power = 0.80;
  std::string out_dir;
  int shard = 0, shards = 1;  // this process runs replicates with index % shards == shard
  std::function<void(long done, long total, double elapsed_s)> progress;
};
// --shard I/K: K is at most this (docs/PARTICIPANTS.md "Power analysis").
constexpr long kMaxShards = 100000;
// "I/K" (sep '/') or "I-of-K" (sep "-of-"): decimal digits without a leading zero (the rule of
// every count palplab takes: app/command.hpp count_range), 1 <= I <= K <= kMaxShards, else
// nullopt (no sign, space, leading zero, overflow or wrap-around). Returns (I, K), I 1-based.
std::optional<std::pair<int, int>> parse_shard(const std::string& text, const std::string& sep);
// Whether `digits` (one number of a count option: --n's sizes, --shard's I or K) starts with a
// zero that is not the whole number ("03"): refused, as count_range refuses it, so that the
// hint "decimal digits without leading zeros" can be given.
bool has_leading_zero(const std::string& digits);

// Which replicates a run still lacks, in index order (index = i * replicates + r over the
// sizes `ns`; shard I of K takes index % K == I - 1), and which of them this MPI rank takes
// (every `ranks`-th of that list, starting at the `rank`-th) — enumerated as the run goes,
// never listed: a list of 10^7 replicates x 10 sizes took 1.1 GB before the first replicate.
// `done` holds the (n, replicate) already in the replicate file (kept by reference).
struct ReplicateTask {
  int n = 0, replicate = 0;
};
class ReplicateTasks {
 public:
  ReplicateTasks(const std::vector<int>& ns, int replicates, int shard, int shards,
                 const std::set<std::pair<int, int>>& done, int rank = 0, int ranks = 1);
  // How many replicates this shard lacks (all ranks together), and how many are this rank's.
  long total() const { return total_; }
  long mine() const { return total_ / ranks_ + (rank_ < total_ % ranks_ ? 1 : 0); }
  // This rank's next replicate, false after the last.
  bool next(ReplicateTask& t);

 private:
  const std::vector<int>& ns_;
  const std::set<std::pair<int, int>>& done_;
  long replicates_, shard_, shards_;
  int rank_, ranks_;
  long total_ = 0;
  std::size_t size_ = 0;  // the size being walked (index into ns_)
  long r_ = 0;            // its next replicate index of this shard
  long position_ = 0;     // the next missing replicate's position in the shard's list
  void start_size();
};

// The group sizes a run simulates: opt.n, or the study's own size when empty (all groups equal,
// else an InputError asking for --n).
std::vector<int> power_sizes(const Study& study, const PowerOptions& opt);

// Runs the replicates this process is responsible for (skipping those already in
// DIR/replicates.jsonl) and appends each as it finishes. Under MPI (PALPLAB_MPI, launched by
// mpirun) ranks share the replicates and rank 0 writes them. Returns the number run here, or
// -1 on an MPI rank other than 0 (which must not write the summary). An error on any rank
// (rank 0's file checks, a replicate's simulation) is settled as settle_ranks says: rank 0
// throws it, every other rank throws FailedOnAnotherRank; no rank waits for ever. After an
// error the caller ends MPI with end_ranks (after rank 0 said the error); after a run that
// returns, MPI has ended.
long run_power(const Study& study, const PowerOptions& opt);

// MPI (a PALPLAB_MPI build launched by mpirun; docs/PARTICIPANTS.md "Power analysis"): every
// rank runs the whole command, so every rank found the same bad input and printed it. Starts
// MPI (once) and returns this process's rank; 0 without MPI.
int power_rank();
// Whether this process is one of the ranks of an mpirun (MPI started by power_rank).
bool power_under_mpi();
// Collective under MPI (every rank calls it at the same point, with what its own work there
// threw, or nullptr): when no rank failed it returns; otherwise rank 0 rethrows its own error —
// or, when only other ranks failed, the first one's as an InputError (or an internal error)
// with the same message — and every other rank throws FailedOnAnotherRank with the exit code
// rank 0 gives (2 for an InputError), so that the error is printed once and every rank exits
// with that code. Without MPI it rethrows `error`. MPI is not ended: rank 0 says the error,
// then every rank calls end_ranks (a rank that ended first made mpirun kill rank 0 before it
// had printed).
void settle_ranks(std::exception_ptr error);
// Collective under MPI: waits for every rank, then ends MPI (nothing when it has ended, or
// without MPI).
void end_ranks();
struct FailedOnAnotherRank : std::exception {
  int code = 2;
  explicit FailedOnAnotherRank(int c) : code(c) {}
  const char* what() const noexcept override { return "failed (said by MPI rank 0)"; }
};

// Which replicates a summary covers: the group sizes `sizes` (empty = every size found) and the
// replicate indices 0..replicates-1 (0 = every index found). `palplab power` summarises exactly
// what it was asked for, also when its --out holds more (an earlier, larger run); `palplab merge`
// summarises everything.
struct SummaryScope {
  std::vector<int> sizes;
  int replicates = 0;
  bool covers(int n, int replicate) const;
};
// The replicates found but left out of a summary by its SummaryScope (deduplicated).
struct LeftOut {
  std::map<int, long> beyond;   // n in scope -> replicates with an index >= scope.replicates
  std::map<int, int> largest;   // n in scope -> largest index found among those
  std::map<int, long> other_n;  // n not in scope -> replicates
  long total() const;
};

// How a model that is right would fare against the people's results, at one group size n: a
// people's study of their size and a replicate of n per group are drawn independently from the
// people's participants (with replacement within each group: the truth taken as their
// distribution), and the replicate is compared with the drawn people's study as a model's
// replicate is with theirs — so both studies' sampling errors are in it (the predictive view of
// replication, Killeen 2005: a 95 % interval holds a same-size replication's mean about 83 % of
// the time with a z interval, Cumming & Maillardet 2006; ≈ 86 % with t intervals at n = 10).
// Counts over PeopleVerdicts::resamples draws, seeded per n.
struct RightModel {
  std::map<std::string, long> agree;       // test id -> draws reaching the people's verdict
  long all_agree = 0;                      // draws reaching every verdict
  double median_agreeing = 0.0;            // median number of tests agreeing
  std::map<std::string, long> same_order;  // cell -> draws with the people's order
  std::map<std::string, long> inside;      // GroupDescriptive key "cell\tgroup" -> draws inside
  long all_orders = 0, all_inside = 0, pattern = 0;  // every order / mean inside / both + verdicts
};

// People's results on the study's declared tests (`palplab power --human FILE.csv`;
// protocols/people_verdicts.cpp): their verdicts, group means and orders, and per group size
// what a right model would reach (RightModel).
struct PeopleVerdicts {
  std::string file;                // the human CSV
  std::vector<TestOutcome> tests;  // the declared tests run on the people's values
  std::map<std::string, int> n;    // group -> participants with a value in the tested cells
  // The people's group descriptives in the tested cells (tested_group_descriptives).
  std::vector<GroupDescriptive> groups;
  long resamples = 0;
  std::uint64_t seed = 0;
  std::map<int, RightModel> right;  // n -> what a right model reaches at n per group
  // The people's cells no declared test uses ("measure in phase P session S (lines …)"):
  // read, checked, and not compared (people_warnings says so).
  std::vector<std::string> untested;
};
// The people's order of the group means in `cell` as compared: empty when undefined or with a
// tie (equal means have no order to reach; such a cell is not compared).
std::string compared_order(const std::vector<GroupDescriptive>& groups, const std::string& cell);
// One study's results (a replicate, or a right model's draw) against the people's: which tests
// reach the people's verdict (tests without one are not compared), which cells have the
// people's order (compared_order), which groups' means lie inside the people's 95 % interval
// ("cell\tgroup"; groups without an interval are not compared; a missing mean is outside).
struct Comparison {
  std::vector<std::string> agree, same_order, inside;
  bool all_agree = false, all_orders = false, all_inside = false;
  bool pattern() const { return all_agree && all_orders && all_inside; }
};
Comparison compare_with_people(const PeopleVerdicts& people, const std::vector<TestOutcome>& tests,
                               const std::vector<GroupDescriptive>& groups, double alpha);
// A verdict: significant (finite p < alpha) or not (an undefined test counts as not).
bool significant(double p, double alpha);
// The median of values 0, 1, 2, ... given by their counts (counts[k] = how many were k); the
// mean of the two middle values for an even total; NaN when there are none.
double median_of_counts(const std::vector<long>& counts);

// The summary of the replicates found in `files` (replicates.jsonl from one or more shards;
// duplicates must agree) that `scope` covers; those it does not are counted in `*left_out`
// (when given). Every record is checked, in scope or not. InputError when files hold different
// studies or settings, or no replicate in scope.
// With `people`, every test also gets people's p, effect and verdict and, per n, how many
// replicates reached that verdict; every group the people's mean and interval and per n the
// replicates inside it; every cell the people's order and per n the replicates with it;
// "people" holds per n the replicates reaching all verdicts (Wilson 95 % interval), every order,
// every mean inside, the whole pattern — each beside what a right model reaches at that n
// (RightModel, "right_model"). InputError when a test or a group of `people` is not among the
// replicates'.
nlohmann::json power_summary(const std::vector<std::string>& files, double alpha,
                             double target_power, const SummaryScope& scope = {},
                             LeftOut* left_out = nullptr, const PeopleVerdicts* people = nullptr);
// What a merge of `files` is known to lack (`palplab merge`; docs/PARTICIPANTS.md "Power
// analysis"): shards I of a `--shard I/K` run whose file replicates.shard-I-of-K.jsonl is not
// among `files` (K read from the names of those that are), and, per n, replicate indices below
// the largest one present (a shard missing or stopped early). Records that carry their run's
// plan ($.plan, since 2026-12-07) also show replicates missing above the largest present, and
// sizes with none: the largest plan (most replicates, every size any run asked for) is what
// the merge must hold — a resume with more replicates extends a run, it is no mismatch.
struct MergeGaps {
  // Missing shards and replicate indices listed (message, power.json); the rest are counted.
  static constexpr std::size_t kListed = 10;
  long shards = 0;                   // K of the shard files merged (one K only), 0 when none
  std::vector<long> missing_shards;  // the first kListed missing I (1-based) of K
  long missing_shard_count = 0;      // all of them
  std::map<int, std::vector<int>> missing_replicates;  // n -> first kListed indices missing
  std::map<int, long> missing_replicate_count;         // n -> all indices missing below the largest
  std::map<int, long> present;                         // n -> replicates present (deduplicated)
  std::map<int, int> largest;  // n -> largest replicate index expected (present, or planned)
  // Every `--replicates` the records' runs asked for ($.plan; a run resumed with more
  // replicates, shards of differently sized runs); the largest is what a merge must hold.
  std::set<int> plans_replicates;
  int planned_replicates() const {
    return plans_replicates.empty() ? 0 : *plans_replicates.rbegin();
  }
  bool complete() const { return missing_shard_count == 0 && missing_replicate_count.empty(); }
  // "shard 2 of 2 missing (no replicates.shard-2-of-2.jsonl among the merged files); n = 3:
  // replicates 0, 2 of 0-3 missing: the summary covers only 3 replicates (n = 2: 2, n = 3: 1)";
  // longer lists end "…, and N more"; empty when complete().
  std::string message() const;
  // The power.json "partial" object: {"missing_shards": ["2/2"], "missing_shard_count": 1,
  // "missing_replicates": {"3": [0, 2]}, "missing_replicate_count": {"3": 2}, "replicates":
  // {"2": 2, "3": 1}, "message": message()}; the lists hold at most kListed entries each.
  nlohmann::json to_json() const;
};
// Shard files of different K among `files` are an InputError (which replicates a run of
// another K should hold cannot be told from the records): merge the files of one run.
MergeGaps merge_gaps(const std::vector<std::string>& files);
// Every record's seed is the one derived from the study's seed for its n and replicate index
// (InputError at FILE:LINE: $.seed otherwise: a record edited, e.g. a line copied to fill a gap
// with its index changed, or simulated with another seed). The power resume checks its file;
// merge checks its inputs when given the study (--study).
void check_replicate_seeds(const Study& study, const std::vector<std::string>& files);

// InputError when `out_dir` holds results of a study other than the one with SHA-256 `sha`
// (a power.json or replicates*.jsonl of another study), so they are not overwritten or mixed.
void check_out_dir_study(const std::string& out_dir, const std::string& sha);
// Writes DIR/power.json, DIR/power.md (the table, also returned) and DIR/power.svg. A summary
// with a "partial" object (MergeGaps::to_json, `merge --allow-partial`) gets a partial-result
// line under power.md's title and in the figure's title.
std::string write_power_report(const nlohmann::json& summary, const std::string& out_dir);

}  // namespace palplab::protocols
