// `palplab merge DIR_OR_FILE... --out DIR [--alpha A] [--target-power P]`: combines the
// replicate files of `palplab power --shard I/K` runs (every replicates*.jsonl in the given
// directories, or the files given) and writes the power summary, identical to a single run.
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "common/input_error.hpp"
#include "protocols/power.hpp"

namespace fs = std::filesystem;

namespace {
struct MergeArgs {
  std::vector<std::string> inputs;
  std::string out;
  double alpha = 0.05, target = 0.80;
};

palplab::app::CommandRegistration reg{
    "merge", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "merge", "Merge the replicate files of sharded `palplab power` runs into one summary");
      auto a = std::make_shared<MergeArgs>();
      cmd->add_option("INPUTS", a->inputs, "Shard output directories or replicate files")
          ->required()
          ->expected(1, -1);
      cmd->add_option("--out", a->out, "Output directory for power.json/md/svg")->required();
      cmd->add_option("--alpha", a->alpha, "Significance level")
          ->check(palplab::app::finite_range(1e-9, 0.5));
      cmd->add_option("--target-power", a->target, "Power the smallest n must reach")
          ->check(palplab::app::finite_range(0.01, 0.999999));
      cmd->callback([a, code] {
        palplab::app::require_writable_dir("--out", a->out);
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
        auto summary = palplab::protocols::power_summary(files, a->alpha, a->target);
        // As `palplab power` does: never overwrite (or mix in) another study's results.
        palplab::protocols::check_out_dir_study(a->out,
                                                summary.at("study_sha256").get<std::string>());
        std::cout << palplab::protocols::write_power_report(summary, a->out) << "\nmerged "
                  << files.size() << " replicate files into " << a->out << "\n";
        *code = 0;
      });
    }};
}  // namespace
