// `palplab bench [SECTION...] [--quick] [--json FILE] [--md FILE] [--svg DIR] [--data DIR]`: runs
// the named benchmark sections (all when none is named) and prints one table; --json writes one
// key per section ({"stats": {"results": [...]}}; a result's further measured quantities under
// "metrics"), --md a Markdown table, --svg the sections' figures. Sections: app/bench.hpp.
// An unknown section name is an input error (exit 2).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/bench.hpp"
#include "app/command.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"

namespace palplab::app {

std::vector<BenchSection>& bench_sections() {
  static std::vector<BenchSection> s;
  return s;
}

BenchSectionRegistration::BenchSectionRegistration(std::string name, std::string description,
                                                   BenchSectionFn run) {
  bench_sections().push_back({std::move(name), std::move(description), std::move(run)});
}

BenchResult time_reps(const std::string& name, const std::string& what, int reps,
                      const std::function<void()>& work, double goal_s) {
  using clock = std::chrono::steady_clock;
  std::vector<double> cpu;
  auto once = [&] {
    auto a = clock::now();
    std::clock_t c = std::clock();
    work();
    cpu.push_back(static_cast<double>(std::clock() - c) / CLOCKS_PER_SEC);
    return std::chrono::duration<double>(clock::now() - a).count();
  };
  BenchResult r;
  r.name = name;
  r.what = what;
  r.goal_s = goal_s;
  r.reps = std::max(reps, 5);
  r.cold_s = once();
  r.cold_cpu_s = cpu.front();
  std::vector<double> t;
  for (int i = 0; i < r.reps; ++i) t.push_back(once());
  r.median_s = engine::median(t);
  r.min_s = *std::min_element(t.begin(), t.end());
  r.max_s = *std::max_element(t.begin(), t.end());
  cpu.erase(cpu.begin());  // the cold run
  r.median_cpu_s = engine::median(cpu);
  return r;
}

BenchResult result_from_samples(const std::string& name, const std::string& what,
                                std::vector<double> samples_s, double cold_s) {
  BenchResult r;
  r.name = name;
  r.what = what;
  r.reps = static_cast<int>(samples_s.size());
  r.cold_s = cold_s;
  if (samples_s.empty()) return r;
  r.median_s = engine::median(samples_s);
  r.min_s = *std::min_element(samples_s.begin(), samples_s.end());
  r.max_s = *std::max_element(samples_s.begin(), samples_s.end());
  r.median_cpu_s = r.median_s;  // single-threaded work timed by the section
  return r;
}

std::string BenchOptions::prototypes_dir() const {
  return (std::filesystem::path(data_dir) / ".." / ".." / "prototypes").lexically_normal().string();
}

}  // namespace palplab::app

namespace {
struct BenchArgs {
  std::vector<std::string> sections;
  bool quick = false;
  std::string json, md, svg, data = "tests/data";
};

std::string fmt_s(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", s);
  return b;
}

// A time column of a result: 0 is "not measured" (a case without repetitions, a section that
// times no CPU or no cold run), shown empty, not as a time of 0 s beside one of 6 s (review
// 2026-12-06, eighth). bench.json keeps the 0 (its readers test for it).
std::string time_cell(double s, const char* none = "") {
  return s == 0 ? none : fmt_s(s);
}

palplab::app::CommandRegistration reg_bench{
    "bench", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand("bench", "Run benchmark sections (median of >= 5 runs)");
      auto a = std::make_shared<BenchArgs>();
      cmd->add_option("sections", a->sections, "Sections to run (default: all)");
      cmd->add_flag("--quick", a->quick, "Fewer repetitions and smaller cases");
      cmd->add_option("--json", a->json, "Write results as JSON (one key per section)");
      cmd->add_option("--md", a->md, "Write results as a Markdown table");
      cmd->add_option("--svg", a->svg, "Write each section's figures (SVG) into this directory");
      cmd->add_option("--data", a->data,
                      "The repository's tests/data directory (default: tests/data, i.e. run "
                      "from the repository root)");
      cmd->callback([a, code] {
        using namespace palplab::app;
        auto& all = bench_sections();
        std::vector<const BenchSection*> run;
        for (const auto& name : a->sections) {
          auto it = std::find_if(all.begin(), all.end(),
                                 [&](const BenchSection& s) { return s.name == name; });
          if (it == all.end()) {
            std::string known;
            for (const auto& s : all) known += (known.empty() ? "" : ", ") + s.name;
            throw palplab::InputError(palplab::SourceLocation{"bench"},
                                      "unknown section '" + name + "'; sections are: " + known);
          }
          run.push_back(&*it);
        }
        if (run.empty())
          for (const auto& s : all) run.push_back(&s);
        if (!std::filesystem::is_directory(a->data))
          throw palplab::InputError(
              palplab::SourceLocation{"--data"},
              "no directory '" + a->data + "' (run from the repository root or pass --data)");
        if (!a->svg.empty()) {
          std::error_code ec;
          std::filesystem::create_directories(a->svg, ec);
          if (!std::filesystem::is_directory(a->svg))
            throw palplab::InputError(palplab::SourceLocation{"--svg"},
                                      "cannot create the directory '" + a->svg + "'");
        }
        // The output files are checked before the first section (an unwritable path is an input
        // error, not a lost run) and rewritten after every section, so a run that is stopped
        // keeps the sections it finished.
        const auto write = [](const std::string& path, const std::string& text, const char* what) {
          std::ofstream out(path, std::ios::trunc);
          if (!out || !(out << text) || !out.flush())
            throw palplab::InputError(std::string("cannot write the ") + what + " file", path);
        };
        if (!a->json.empty()) write(a->json, "{}\n", "JSON");
        if (!a->md.empty()) write(a->md, "", "Markdown");
        BenchOptions opt{a->quick, a->data, a->svg};
        nlohmann::json j = nlohmann::json::object();
        std::string md =
            "| section | case | reps | median s | min s | max s | cold s | median CPU s | goal s "
            "| measured |\n"
            "|---|---|---|---|---|---|---|---|---|---|\n";
        for (const auto* s : run) {
          auto results = s->run(opt);
          nlohmann::json arr = nlohmann::json::array();
          std::cout << s->name << ": " << s->description << "\n";
          for (const auto& r : results) {
            std::printf(
                "  %-20s median %9s s  min %9s  max %9s  cold %9s  cpu %9s  cold cpu %9s  (%d "
                "reps)%s\n",
                r.name.c_str(), time_cell(r.median_s, "-").c_str(), time_cell(r.min_s, "-").c_str(),
                time_cell(r.max_s, "-").c_str(), time_cell(r.cold_s, "-").c_str(),
                time_cell(r.median_cpu_s, "-").c_str(), time_cell(r.cold_cpu_s, "-").c_str(),
                r.reps, r.goal_s > 0 ? ("  goal <= " + fmt_s(r.goal_s) + " s").c_str() : "");
            std::string mtext;
            nlohmann::json metrics = nlohmann::json::object();
            for (const auto& [k, v] : r.metrics) {
              metrics[k] = v;
              mtext += (mtext.empty() ? "" : ", ") + k + " " + fmt_s(v);
            }
            if (!mtext.empty()) std::printf("  %-20s %s\n", "", mtext.c_str());
            std::fflush(stdout);
            nlohmann::json e = {{"name", r.name},
                                {"what", r.what},
                                {"reps", r.reps},
                                {"median_s", r.median_s},
                                {"min_s", r.min_s},
                                {"max_s", r.max_s},
                                {"cold_s", r.cold_s},
                                {"median_cpu_s", r.median_cpu_s},
                                {"cold_cpu_s", r.cold_cpu_s}};
            if (r.goal_s > 0) {
              e["goal_s"] = r.goal_s;
              e["meets_goal"] = r.cold_s <= r.goal_s;
            }
            if (!r.metrics.empty()) e["metrics"] = metrics;
            arr.push_back(e);
            md += "| " + s->name + " | " + r.what + " | " + std::to_string(r.reps) + " | " +
                  time_cell(r.median_s) + " | " + time_cell(r.min_s) + " | " + time_cell(r.max_s) +
                  " | " + time_cell(r.cold_s) + " | " + time_cell(r.median_cpu_s) + " | " +
                  (r.goal_s > 0 ? fmt_s(r.goal_s) : "") + " | " + mtext + " |\n";
          }
          j[s->name] = {{"description", s->description}, {"quick", a->quick}, {"results", arr}};
          if (!a->json.empty()) write(a->json, j.dump(2) + "\n", "JSON");
          if (!a->md.empty()) write(a->md, md, "Markdown");
        }
        *code = 0;
      });
    }};
}  // namespace
