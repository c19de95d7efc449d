// `palplab merge DIR_OR_FILE... --out DIR [--alpha A] [--target-power P] [--allow-partial]
//                [--human FILE.csv --study STUDY.json]`:
// combines the replicate files of `palplab power --shard I/K` runs (every replicates*.jsonl in
// the given directories, or the files given) and writes the power summary, identical to a single
// run. A merge known to lack replicates (a shard's file not among the inputs, or indices missing
// below the largest of an n or of the records' largest plan: protocols::merge_gaps) is refused
// (exit 2) unless --allow-partial, which writes it with a warning and marks power.json/md partial.
// Shard files of different K (replicates.shard-I-of-K.jsonl) among the inputs are refused (exit 2)
// even then. With --human FILE.csv --study STUDY.json the summary also compares the replicates with
// the people's results as `palplab power --human` does (the records name their study only by its
// SHA-256, so the study file is needed for its tests; it must be the records' study).
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "app/output_dir.hpp"
#include "common/input_error.hpp"
#include "protocols/calibrate.hpp"
#include "protocols/people_verdicts.hpp"
#include "protocols/power.hpp"
#include "protocols/study.hpp"
#include "results/sha256.hpp"

namespace fs = std::filesystem;

namespace {
struct MergeArgs {
  std::vector<std::string> inputs;
  std::string out, human, study;
  double alpha = 0.05, target = 0.80;
  bool allow_partial = false;
};

palplab::app::CommandRegistration reg_merge{
    "merge", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "merge", "Merge the replicate files of sharded `palplab power` runs into one summary");
      auto a = std::make_shared<MergeArgs>();
      cmd->add_option("INPUTS", a->inputs, "Shard output directories or replicate files")
          ->required()
          ->expected(1, -1);
      cmd->add_option("--out", a->out, "Output directory for power.json/md/svg")->required();
      cmd->add_option("--alpha", a->alpha, "Significance level")
          ->capture_default_str()
          ->check(palplab::app::finite_range(1e-9, 0.5));
      cmd->add_option("--target-power", a->target, "Power the smallest n must reach")
          ->capture_default_str()
          ->check(palplab::app::finite_range(0.01, 0.999999));
      cmd->add_flag("--allow-partial", a->allow_partial,
                    "Merge even when shards or replicates are missing (a preliminary summary, "
                    "marked partial in power.json/md; a warning names what is missing)");
      auto* human_opt = cmd->add_option(
          "--human", a->human,
          "People's data of this study (tidy CSV, as `power --human`): also compare the "
          "replicates with the people's verdicts, group means and orders (needs --study)");
      auto* study_opt = cmd->add_option(
          "--study", a->study,
          "The study file the replicates simulated (its SHA-256 must be the records'); with "
          "--human its declared tests are run on the people's data");
      cmd->callback([a, human_opt, study_opt, code] {
        // The flags' own errors first: they need no replicate read.
        if (human_opt->count() > 0 && study_opt->count() == 0)
          throw palplab::InputError(
              "--human: give --study STUDY.json too (the replicate records name their study only "
              "by its SHA-256; its declared tests are what is run on the people's data)");
        if (human_opt->count() > 0 && a->human.empty())
          throw palplab::InputError(palplab::SourceLocation{"--human"},
                                    "expected the people's CSV file, got an empty path");
        if (study_opt->count() > 0 && a->study.empty())
          throw palplab::InputError(palplab::SourceLocation{"--study"},
                                    "expected the study file, got an empty path");
        // The inputs before the outputs: a missing input creates no --out directory.
        std::vector<std::string> files;
        for (const auto& in : a->inputs) {
          if (fs::is_directory(in)) {
            std::vector<std::string> found;
            for (const auto& e : fs::directory_iterator(in)) {
              const std::string name = e.path().filename().string();
              if (name.rfind("replicates", 0) == 0 && e.path().extension() == ".jsonl")
                found.push_back(e.path().string());
            }
            if (found.empty()) throw palplab::InputError("no replicates*.jsonl in directory", in);
            std::sort(found.begin(), found.end());
            files.insert(files.end(), found.begin(), found.end());
          } else if (fs::exists(in)) {
            files.push_back(in);
          } else {
            throw palplab::InputError("no such file or directory", in);
          }
        }
        // A file given twice (also as a directory's file, or through a link) is read once: it is
        // counted once in the output, and its replicates were never counted twice anyway.
        {
          std::vector<std::string> unique;
          std::vector<fs::path> seen;
          for (const auto& f : files) {
            std::error_code ec;
            const fs::path canon = fs::weakly_canonical(f, ec);
            const fs::path key = ec ? fs::path(f) : canon;
            if (std::find(seen.begin(), seen.end(), key) != seen.end()) continue;
            seen.push_back(key);
            unique.push_back(f);
          }
          files = std::move(unique);
        }
        auto summary = palplab::protocols::power_summary(files, a->alpha, a->target);
        if (study_opt->count() > 0) {
          const palplab::protocols::Study s = palplab::protocols::load_study(
              a->study, palplab::protocols::engine_prototype_inspector());
          const std::string sha = palplab::results::sha256_hex(s.json_text),
                            theirs = summary.at("study_sha256").get<std::string>();
          if (sha != theirs)
            throw palplab::InputError(palplab::SourceLocation{a->study},
                                      "--study: not the study the replicates simulated (SHA-256 " +
                                          sha.substr(0, 12) + ", the records' " +
                                          theirs.substr(0, 12) + ")");
          // With the study, each record's seed is checked exactly (as a power resume does).
          palplab::protocols::check_replicate_seeds(s, files);
          if (human_opt->count() > 0) {
            // Every group size merged, compared as `palplab power --human` compares its own.
            std::vector<int> sizes;
            for (const auto& [n, count] : summary.at("replicates").items())
              sizes.push_back(std::stoi(n));
            std::sort(sizes.begin(), sizes.end());
            const auto people = palplab::protocols::people_verdicts(
                s, palplab::protocols::read_human_cells(a->human), a->alpha, sizes);
            for (const auto& w : palplab::protocols::people_warnings(people))
              std::cerr << "warning: --human: " << w << "\n";
            summary =
                palplab::protocols::power_summary(files, a->alpha, a->target, {}, nullptr, &people);
          }
        }
        // Shards of a sharded run merged without the others gave a summary of part of the
        // replicates that read as the whole result.
        const palplab::protocols::MergeGaps gaps = palplab::protocols::merge_gaps(files);
        if (!gaps.complete() && !a->allow_partial)
          throw palplab::InputError(
              "incomplete merge: " + gaps.message() +
              ". Merge the directories or files of every shard (a shard that stopped early: "
              "rerun its `palplab power` command, it resumes), or give --allow-partial for a "
              "preliminary summary marked partial");
        // No replicate file given is overwritten by a summary (`merge D/power.md --out D`), and
        // a power.md or power.svg in --out that is not palplab's is left alone
        // (app/output_dir.hpp). The replicate files in --out are only read: `merge A B --out A`
        // writes A's summary beside them, and a later merge of A reads A's replicates once.
        std::vector<palplab::app::CommandInput> inputs;
        for (const auto& f : files) inputs.push_back({"a replicate file", f});
        if (!a->human.empty()) inputs.push_back({"the human data", a->human});
        if (!a->study.empty()) inputs.push_back({"the study file", a->study});
        palplab::app::require_replaceable_dir_outputs("--out", a->out, "power.json/md/svg",
                                                      palplab::app::power_summary_outputs(), inputs,
                                                      "", false);
        palplab::app::require_writable_dir("--out", a->out);
        palplab::app::require_writable_power_summary("--out", a->out);
        // As `palplab power` does: never overwrite (or mix in) another study's results.
        palplab::protocols::check_out_dir_study(a->out,
                                                summary.at("study_sha256").get<std::string>());
        if (!gaps.complete()) {
          std::cerr << "warning: partial merge (--allow-partial): " << gaps.message() << "\n";
          summary["partial"] = gaps.to_json();
        }
        std::cout << palplab::protocols::write_power_report(summary, a->out) << "\nmerged "
                  << files.size() << " replicate file" << (files.size() == 1 ? "" : "s") << " into "
                  << a->out << (gaps.complete() ? "" : " (PARTIAL: see the warning above)") << "\n";
        *code = 0;
      });
    }};
}  // namespace
