// `palplab power STUDY.json --replicates R [--n 6,8,10,...] [--jobs N] [--out DIR]
//                [--shard I/K] [--alpha A] [--human FILE.csv]`: simulates the whole study R times
//                per group size
// and reports the power of every declared test (protocols/power.hpp). Replicates are appended
// to DIR/replicates.jsonl as they finish; running the same command again resumes, and the
// summary covers exactly the sizes and replicates asked for (a directory holding more, from an
// earlier larger run, keeps them; the output says so). Under MPI
// (a PALPLAB_MPI build launched by mpirun) the ranks share the replicates and rank 0 writes.
// With --shard I/K only every K-th replicate is run (job arrays); `palplab merge` combines.
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <new>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>

#include "app/command.hpp"
#include "app/output_dir.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "common/json_locate.hpp"
#include "protocols/calibrate.hpp"
#include "protocols/people_verdicts.hpp"
#include "protocols/power.hpp"
#include "protocols/study.hpp"
#include "results/sha256.hpp"

namespace {

// --n: comma-separated group sizes (the option may also be repeated). An empty entry ("6,,8"),
// a non-integer, a leading zero ("03", refused as every count of palplab refuses it:
// app/command.hpp count_range, --replicates, --jobs, --shard), a size outside [2, 100000] or a
// size given twice is an input error.
std::vector<int> parse_sizes(const std::vector<std::string>& args) {
  std::vector<int> out;
  std::string all;  // every --n argument, for the message of a size given twice across them
  for (const std::string& arg : args) all += (all.empty() ? "" : " ") + arg;
  for (const std::string& arg : args) {
    const auto fail = [&](const std::string& what, const std::string& digits = "") {
      return palplab::InputError(palplab::SourceLocation{"--n"},
                                 what + " in \"" + arg + "\" (expected group sizes 2 to 100000" +
                                     digits + ", separated by commas, each once)");
    };
    for (std::size_t i = 0;;) {
      const std::size_t j = std::min(arg.find(',', i), arg.size());
      const std::string item = arg.substr(i, j - i);
      if (item.empty()) throw fail("an empty entry");
      int v = 0;
      const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
      if (ec != std::errc() || end != item.data() + item.size() || v < 2 || v > 100000)
        throw fail("\"" + item + "\" is not a group size");
      if (palplab::protocols::has_leading_zero(item))
        throw fail("\"" + item + "\" has a leading zero",
                   " in decimal digits without leading zeros");
      if (std::find(out.begin(), out.end(), v) != out.end())
        throw palplab::InputError(palplab::SourceLocation{"--n"},
                                  "the size " + item + " is given twice in \"" + all +
                                      "\" (expected group sizes 2 to 100000, separated by "
                                      "commas, each once)");
      out.push_back(v);
      if (j == arg.size()) break;
      i = j + 1;
    }
  }
  return out;
}

// What a summary of exactly the requested replicates leaves out of `file`: "note: FILE holds 2
// replicates this command did not ask for (n = 3: 2 beyond --replicates 3). They are kept in
// the file but not used in this summary; to use them, rerun with --replicates 5, or ...".
std::string left_out_note(const palplab::protocols::LeftOut& l, const std::string& file,
                          int replicates) {
  const long total = l.total();
  std::string parts, sizes;
  int largest = -1;
  for (const auto& [n, k] : l.beyond) {
    parts += (parts.empty() ? "" : "; ") + std::string("n = ") + std::to_string(n) + ": " +
             std::to_string(k) + " beyond --replicates " + std::to_string(replicates);
    largest = std::max(largest, l.largest.at(n));
  }
  for (const auto& [n, k] : l.other_n) {
    parts += (parts.empty() ? "" : "; ") + std::string("n = ") + std::to_string(n) + ": " +
             std::to_string(k) + ", a size this command did not simulate";
    sizes += (sizes.empty() ? "" : ",") + std::to_string(n);
  }
  std::string rerun;
  if (largest >= 0) rerun = "--replicates " + std::to_string(largest + 1);
  if (!sizes.empty())
    rerun += (rerun.empty() ? "" : " and ") + std::string("--n including ") + sizes;
  return "note: " + file + " holds " + std::to_string(total) + " replicate" +
         (total == 1 ? "" : "s") + " this command did not ask for (" + parts +
         "). They are kept in the file but not used in this summary; to use them, rerun with " +
         rerun + ", or summarise every replicate of the file with `palplab merge " + file +
         " --out DIR`";
}

struct PowerArgs {
  std::string study, out = "power", shard, human;
  std::vector<std::string> n;  // "6,8,10" (or several arguments), parsed by parse_sizes
  palplab::protocols::PowerOptions opt;
  bool quiet = false;
};

// Whether `path` is (or may be) a replicate file `palplab power` appended to: its first record a
// JSON object with a "study_sha256", or, when its only line was cut by an interruption, the
// start of one (records are written with sorted keys: `{"n":...`). The run cuts an incomplete
// last line and appends (protocols/power.cpp repair_tail): a file of anything else under that
// name would lose its last line.
bool is_replicate_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const nlohmann::json r = nlohmann::json::parse(line, nullptr, false);
    if (r.is_object() && r.contains("study_sha256") && r.at("study_sha256").is_string())
      return true;
    if (!in.eof()) return false;
    // The first record cut by an interruption (no newline): the start of a record as palplab
    // writes it (keys in sorted order: "groups" first since 2026-12-05, "n" before). It is cut
    // off by the resume (review 2026-12-06, third: refused as "a JSON file", because only the
    // older start was recognised).
    for (const std::string head : {"{\"groups\":", "{\"n\":"})
      if (line.compare(0, head.size(), head) == 0 || head.compare(0, line.size(), line) == 0)
        return true;
    return false;
  }
  return true;  // blank
}

// Before any replicate is run or any file of --out touched: the study file is not one of the
// files written there, a file of the replicate file's name or of a summary's name is palplab's
// (app/output_dir.hpp; there is no --overwrite: remove it), and the directory holds no other
// study's summary or replicates (the run checked that only after cutting the replicate file's
// incomplete last line: another study's file lost it).
void check_power_out(const PowerArgs& a, const palplab::protocols::Study& s) {
  using namespace palplab::app;
  std::vector<DirOutput> outputs;
  const std::string file = a.opt.shards <= 1
                               ? "replicates.jsonl"
                               : "replicates.shard-" + std::to_string(a.opt.shard + 1) + "-of-" +
                                     std::to_string(a.opt.shards) + ".jsonl";
  outputs.push_back(
      {file, "palplab replicate file (" + file + ")", is_replicate_file, "append to"});
  if (a.opt.shards <= 1)  // a shard writes no summary
    for (auto& o : power_summary_outputs()) outputs.push_back(std::move(o));
  std::vector<CommandInput> inputs = {{"the study file", a.study}};
  if (!a.human.empty()) inputs.push_back({"the human data", a.human});
  // A directory holding the other kind of run: resuming there would simulate again what its
  // files hold (a whole set of shards was re-run, stored twice; review 2026-12-07).
  std::error_code ec;
  std::vector<std::string> shards;
  bool whole = false;
  for (const auto& e : std::filesystem::directory_iterator(a.out, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("replicates.shard-", 0) == 0 && name.size() > 6 &&
        name.compare(name.size() - 6, 6, ".jsonl") == 0)
      shards.push_back(name);
    whole = whole || name == "replicates.jsonl";
  }
  std::sort(shards.begin(), shards.end());
  if (a.opt.shards <= 1 && !shards.empty())
    throw palplab::InputError(
        palplab::SourceLocation{"--out"},
        a.out + " holds the replicates of a sharded run (" + shards.front() +
            (shards.size() > 1 ? ", … " + std::to_string(shards.size()) + " files" : "") +
            "): combine them with `palplab merge " + palplab::shell_word(a.out) +
            " --out DIR`, or give another --out for a run without --shard");
  if (a.opt.shards > 1)  // shards of another --shard I/K split: merge refuses the mix
    for (const std::string& f : shards) {
      const auto of = f.rfind("-of-");
      if (of != std::string::npos &&
          f.substr(of + 4, f.size() - 6 - of - 4) != std::to_string(a.opt.shards))
        throw palplab::InputError(palplab::SourceLocation{"--out"},
                                  a.out + " holds " + f +
                                      ", a shard of another --shard I/K split "
                                      "than " +
                                      std::to_string(a.opt.shard + 1) + "/" +
                                      std::to_string(a.opt.shards) +
                                      " (merge takes one split): give this shard another --out, or "
                                      "run it with the split of the files there");
    }
  if (a.opt.shards > 1 && whole)
    throw palplab::InputError(palplab::SourceLocation{"--out"},
                              a.out +
                                  " holds the replicates of a run without --shard "
                                  "(replicates.jsonl): give each shard another --out");
  require_replaceable_dir_outputs("--out", a.out, "replicates.jsonl and power.json/md/svg", outputs,
                                  inputs, "", false);
  palplab::protocols::check_out_dir_study(a.out, palplab::results::sha256_hex(s.json_text));
}

palplab::app::CommandRegistration reg_power{
    "power", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "power", "Power analysis: simulate the study many times per group size");
      auto a = std::make_shared<PowerArgs>();
      cmd->add_option("STUDY", a->study, "Study file (JSON)")->required();
      cmd->add_option("--replicates", a->opt.replicates, "Simulated studies per group size")
          ->required()
          ->check(palplab::app::count_range(1, 10000000));
      // Split here, not by CLI11: its delimiter drops empty entries ("6,,8" would be 6,8).
      cmd->add_option("--n", a->n,
                      "Participants per group, comma separated (default: the study's); each "
                      "size once, 2 to 100000");
      cmd->add_option("--jobs", a->opt.jobs, "Replicates simulated in parallel (threads)")
          ->check(palplab::app::count_range(1, 1024));
      cmd->add_option("--out", a->out,
                      "Output directory (replicates.jsonl, power.json/md/svg; default: ./power)");
      cmd->add_option("--alpha", a->opt.alpha, "Significance level")
          ->capture_default_str()
          ->check(palplab::app::finite_range(1e-9, 0.5));
      cmd->add_option("--target-power", a->opt.target_power, "Power the smallest n must reach")
          ->capture_default_str()
          ->check(palplab::app::finite_range(0.01, 0.999999));
      auto* shard_opt =
          cmd->add_option("--shard", a->shard,
                          "Run only shard I of K (I/K, 1 <= I <= K <= 100000), for job arrays");
      auto* human_opt = cmd->add_option(
          "--human", a->human,
          "People's data of this study (tidy CSV: participant,group,phase,session,measure,value"
          "[,unit], as `calibrate --human`): also report the people's verdicts and how often the "
          "replicates reach them, beside what a right model would (drawn from the people's "
          "participants); not with --shard");
      cmd->add_flag("--quiet", a->quiet, "No progress output");
      cmd->callback([a, shard_opt, human_opt, code] {
        using namespace palplab::protocols;
        // Under MPI every rank runs this command and checks the same inputs: rank 0 alone says
        // what is wrong (every rank printed it; review 2026-12-07), the others exit with its
        // exit code (settle_ranks; run_power settles its own checks and rounds alike).
        const bool root = power_rank() == 0;
        try {
          std::optional<Study> study;
          std::optional<PeopleVerdicts> people;
          std::exception_ptr error;
          try {
            // Given at all, even empty (a job array's unset variable): never the whole run instead.
            if (shard_opt->count() > 0) {
              // Strictly: digits only, no wrap-around (sscanf's %d took 1/4294967297 for 1/1).
              const auto ik = parse_shard(a->shard, "/");
              if (!ik) {
                // "01/2" is refused as count_range refuses "--replicates 01" (review 2026-12-07:
                // --shard and --n took a leading zero, --replicates did not), and said so.
                const auto slash = a->shard.find('/');
                const bool zero =
                    slash != std::string::npos && (has_leading_zero(a->shard.substr(0, slash)) ||
                                                   has_leading_zero(a->shard.substr(slash + 1)));
                throw palplab::InputError(
                    "--shard: expected I/K, whole numbers with 1 <= I <= K <= " +
                    std::to_string(kMaxShards) + ", got \"" + a->shard + "\"" +
                    (zero ? " (decimal digits without leading zeros)" : ""));
              }
              const auto [i, k] = *ik;
              a->opt.shard = i - 1;
              a->opt.shards = k;
            }
            a->opt.n = parse_sizes(a->n);
            a->opt.out_dir = a->out;
            study = load_study(a->study, engine_prototype_inspector());
            const Study& s = *study;
            // The tests whose power is simulated (protocols/power.cpp run_declared_analyses).
            if (std::none_of(s.analyses.begin(), s.analyses.end(), [](const Analysis& x) {
                  return x.kind == "anova_oneway" || x.kind == "pairwise_t";
                }))
              throw palplab::InputError(
                  palplab::SourceLocation{a->study, 0, 0, -1, "$.analyses"},
                  "the study declares no test to compute the power of: expected at least one "
                  "analysis of kind \"anova_oneway\" or \"pairwise_t\"");
            // A one-group study with such a test is refused by the study validator (load_study).
            // Every size resizes before --out is touched: an explicit assignment, or a plan beyond
            // the validator's limit, is refused here, not after the directory was made.
            for (const int n : power_sizes(s, a->opt)) (void)resized_study(s, n, s.seed);
            // People's verdicts before any simulation: bad data are found at once.
            if (human_opt->count() > 0) {
              if (a->opt.shards > 1)
                throw palplab::InputError(
                    "--human: a shard writes no summary to compare with people's verdicts; run "
                    "`palplab power` without --shard (its --out holding every replicate) for that");
              if (a->human.empty())
                throw palplab::InputError(palplab::SourceLocation{"--human"},
                                          "expected the people's CSV file, got an empty path");
              people = people_verdicts(s, read_human_cells(a->human), a->opt.alpha,
                                       power_sizes(s, a->opt));
              if (root)
                for (const auto& w : people_warnings(*people))
                  std::cerr << "warning: --human: " << w << "\n";
            }
            check_power_out(*a, s);
            palplab::app::require_writable_dir("--out", a->out);
            if (a->opt.shards <= 1) palplab::app::require_writable_power_summary("--out", a->out);
          } catch (...) {
            error = std::current_exception();
          }
          settle_ranks(error);
          const Study& s = *study;
          const bool tty = isatty(2);
          if (!a->quiet)
            a->opt.progress = [tty](long done, long total, double elapsed) {
              const double eta = done > 0 ? elapsed / done * (total - done) : NAN;
              std::fprintf(
                  stderr, "%sreplicates %ld/%ld, %.0f s elapsed, ETA %s%s", tty ? "\r" : "", done,
                  total, elapsed,
                  std::isfinite(eta) ? (std::to_string(std::lround(eta)) + " s").c_str() : "?",
                  tty && done < total ? "   " : "\n");
              std::fflush(stderr);
            };
          const long ran = run_power(s, a->opt);
          if (ran < 0) {  // an MPI rank other than 0
            *code = 0;
            return;
          }
          if (a->opt.shards > 1) {
            std::cout << "shard " << a->opt.shard + 1 << "/" << a->opt.shards << ": " << ran
                      << (ran == 1 ? " replicate" : " replicates") << " run into " << a->out
                      << "; combine the shards with `palplab merge`\n";
            *code = 0;
            return;
          }
          // Exactly the sizes and replicates asked for: a resume with a smaller --replicates (or
          // other --n) than the directory holds leaves the others in the file, unused.
          const std::string file = (std::filesystem::path(a->out) / "replicates.jsonl").string();
          LeftOut left_out;
          auto summary = power_summary({file}, a->opt.alpha, a->opt.target_power,
                                       SummaryScope{power_sizes(s, a->opt), a->opt.replicates},
                                       &left_out, people ? &*people : nullptr);
          std::cout << write_power_report(summary, a->out);
          if (left_out.total() > 0)
            std::cout << "\n" << left_out_note(left_out, file, a->opt.replicates) << "\n";
          std::cout << "\nwrote " << a->out << "/power.json, power.md, power.svg (" << ran
                    << (ran == 1 ? " replicate" : " replicates") << " run now)\n";
          *code = 0;
        } catch (const FailedOnAnotherRank& e) {  // said by rank 0
          end_ranks();
          *code = e.code;
        } catch (const palplab::InputError& e) {
          if (!power_under_mpi()) throw;
          // Said here, as app/main.cpp says it, before the other ranks may end (end_ranks waits
          // for this one): mpirun kills the ranks still running once one has exited non-zero.
          std::cerr << "error: " << e.what() << "\n" << std::flush;
          end_ranks();
          *code = 2;
        } catch (const std::bad_alloc&) {
          end_ranks();
          throw;
        } catch (const std::exception& e) {
          if (!power_under_mpi()) throw;
          std::cerr << "internal error: " << e.what() << "\n" << std::flush;
          end_ranks();
          *code = 3;
        } catch (...) {
          end_ranks();
          throw;
        }
      });
    }};
}  // namespace
