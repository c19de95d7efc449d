// `palplab recheck REPORTED.json --csv FILE [--json]`: recomputes statistics as a paper printed
// them (APA text with the columns they refer to) from the raw data and flags each as
// consistent, a rounding difference, not recomputable (the data do not define it, with the
// reason) or inconsistent (analysis/recheck.hpp; the REPORTED.json format is in
// docs/FORMATS.md). Exit 0 when every statistic is consistent or a rounding difference, 1 when
// any is inconsistent or not recomputable, 2 on bad input.
#include <cmath>
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
  bool json = false, skip_empty = false;
};

palplab::app::CommandRegistration reg_recheck{
    "recheck", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "recheck",
          "Recompute printed statistics (e.g. \"F(2, 27) = 18.65, p < .001\") from "
          "the raw data: consistent, rounding difference, not recomputable or inconsistent");
      auto a = std::make_shared<RecheckArgs>();
      cmd->add_option("reported", a->reported, "REPORTED.json (docs/FORMATS.md)")->required();
      cmd->add_option("--csv", a->csv, "Raw data CSV the statistics were computed from")
          ->required();
      cmd->add_flag("--json", a->json, "Print JSON");
      cmd->add_flag("--skip-empty", a->skip_empty,
                    "Leave out rows whose value is empty or NA (undefined measures, as in "
                    "palplab's own measures.csv) instead of failing; their number is reported");
      cmd->callback([a, code] {
        using namespace palplab::analysis;
        // The JSON reader of study files: located syntax errors, duplicate keys (nlohmann
        // would keep the last one silently), too deep nesting, numbers beyond a double.
        std::string text;
        const nlohmann::json rep = palplab::json::parse_json_file(a->reported, &text);
        CsvTable t = read_csv(a->csv);
        auto items = recheck(rep, t, a->reported, text, a->skip_empty);
        int inconsistent = 0, undefined = 0;
        nlohmann::json out = nlohmann::json::array();
        for (const auto& it : items) {
          inconsistent += it.verdict == "inconsistent";
          undefined += it.verdict == "not recomputable";
          nlohmann::json parts = nlohmann::json::array();
          for (const auto& p : it.parts)
            parts.push_back(
                {{"part", p.name},
                 {"reported", p.reported},
                 {"recomputed", std::isfinite(p.recomputed) ? nlohmann::json(p.recomputed)
                                                            : nlohmann::json(nullptr)},
                 {"verdict", p.verdict}});
          nlohmann::json item = {
              {"id", it.id},
              {"text", it.text},
              {"test", it.test},
              {"verdict", it.verdict},
              {"recomputed", it.recomputed_apa.empty() ? nlohmann::json(nullptr)
                                                       : nlohmann::json(it.recomputed_apa)},
              {"parts", parts}};
          if (!it.reason.empty()) item["not_recomputable"] = it.reason;
          if (a->skip_empty) item["rows_skipped_empty"] = it.rows_skipped_empty;
          out.push_back(item);
        }
        if (a->json) {
          std::cout << nlohmann::json{{"statistics", out},
                                      {"inconsistent", inconsistent},
                                      {"not_recomputable", undefined}}
                           .dump(2)
                    << "\n";
        } else {
          for (const auto& it : items) {
            std::cout << it.id << ": \"" << it.text << "\" -> ";
            if (it.verdict == "not recomputable")
              std::cout << "not recomputable: " << it.reason << "\n";
            else if (!it.reason.empty())  // a part disagrees, another cannot be recomputed
              std::cout << it.verdict << " (in part not recomputable: " << it.reason << ")\n";
            else
              std::cout << it.verdict << " (recomputed: " << it.recomputed_apa << ")\n";
            if (it.rows_skipped_empty > 0)
              std::cout << "    " << it.rows_skipped_empty
                        << (it.rows_skipped_empty == 1 ? " row" : " rows")
                        << " with an empty value or group left out (--skip-empty)\n";
            for (const auto& p : it.parts)
              if (p.verdict == "not recomputable")
                std::cout << "    " << p.name << ": printed " << p.reported
                          << ", not recomputable\n";
              else if (p.verdict != "consistent")
                std::cout << "    " << p.name << ": printed " << p.reported << ", recomputed "
                          << p.recomputed << " (" << p.verdict << ")\n";
          }
          std::cout << items.size() << (items.size() == 1 ? " statistic, " : " statistics, ")
                    << inconsistent << " inconsistent, " << undefined << " not recomputable\n";
        }
        // Exit 0 only when every statistic is confirmed by the data (consistent or a rounding).
        *code = inconsistent + undefined > 0 ? 1 : 0;
      });
    }};
}  // namespace
