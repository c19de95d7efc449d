// `palplab recheck REPORTED.json --csv FILE [--json]`: recomputes statistics as a paper printed
// them (APA text with the columns they refer to) from the raw data and flags each as
// consistent, a rounding difference or inconsistent (analysis/recheck.hpp; the REPORTED.json
// format is in docs/FORMATS.md). Exit 0 when every statistic is consistent or a rounding
// difference, 1 when any is inconsistent, 2 on bad input.
#include <iostream>
#include <memory>

#include "analysis/csv.hpp"
#include "analysis/recheck.hpp"
#include "app/command.hpp"
#include "common/input_error.hpp"
#include "common/json_check.hpp"

namespace {
struct RecheckArgs {
  std::string reported, csv;
  bool json = false;
};

palplab::app::CommandRegistration reg{
    "recheck", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "recheck",
          "Recompute printed statistics (e.g. \"F(2, 27) = 18.65, p < .001\") from "
          "the raw data: consistent, rounding difference or inconsistent");
      auto a = std::make_shared<RecheckArgs>();
      cmd->add_option("reported", a->reported, "REPORTED.json (docs/FORMATS.md)")->required();
      cmd->add_option("--csv", a->csv, "Raw data CSV the statistics were computed from")
          ->required();
      cmd->add_flag("--json", a->json, "Print JSON");
      cmd->callback([a, code] {
        using namespace palplab::analysis;
        // The JSON reader of study files: located syntax errors, duplicate keys (nlohmann
        // would keep the last one silently), too deep nesting, numbers beyond a double.
        std::string text;
        const nlohmann::json rep = palplab::json::parse_json_file(a->reported, &text);
        CsvTable t = read_csv(a->csv);
        auto items = recheck(rep, t, a->reported, text);
        int inconsistent = 0;
        nlohmann::json out = nlohmann::json::array();
        for (const auto& it : items) {
          inconsistent += it.verdict == "inconsistent";
          nlohmann::json parts = nlohmann::json::array();
          for (const auto& p : it.parts)
            parts.push_back({{"part", p.name},
                             {"reported", p.reported},
                             {"recomputed", p.recomputed},
                             {"verdict", p.verdict}});
          out.push_back({{"id", it.id},
                         {"text", it.text},
                         {"test", it.test},
                         {"verdict", it.verdict},
                         {"recomputed", it.recomputed_apa},
                         {"parts", parts}});
        }
        if (a->json) {
          std::cout << nlohmann::json{{"statistics", out}, {"inconsistent", inconsistent}}.dump(2)
                    << "\n";
        } else {
          for (const auto& it : items) {
            std::cout << it.id << ": \"" << it.text << "\" -> " << it.verdict
                      << " (recomputed: " << it.recomputed_apa << ")\n";
            for (const auto& p : it.parts)
              if (p.verdict != "consistent")
                std::cout << "    " << p.name << ": printed " << p.reported << ", recomputed "
                          << p.recomputed << " (" << p.verdict << ")\n";
          }
          std::cout << items.size() << " statistics, " << inconsistent << " inconsistent\n";
        }
        *code = inconsistent > 0 ? 1 : 0;
      });
    }};
}  // namespace
