// `palplab export DB --csv DIR [--samples]`: tidy CSV files from a results database.
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "results/store.hpp"

namespace {
palplab::app::CommandRegistration reg{
    "export", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand("export", "Export a results database as tidy CSV files");
      auto db = std::make_shared<std::string>();
      auto dir = std::make_shared<std::string>();
      auto samples = std::make_shared<bool>(false);
      cmd->add_option("DB", *db, "Results database (from palplab run)")->required();
      cmd->add_option("--csv", *dir, "Directory for measures.csv, sessions.csv, events.csv")
          ->required();
      cmd->add_flag("--samples", *samples, "Also write samples.csv (every 1 kHz sample; large)");
      cmd->callback([db, dir, samples, code] {
        palplab::results::Store store = palplab::results::Store::open(*db);
        // A file where the CSV directory goes is said as such (and left alone).
        std::error_code ec;
        if (const auto st = std::filesystem::status(*dir, ec);
            std::filesystem::exists(st) && !std::filesystem::is_directory(st))
          throw palplab::InputError(palplab::SourceLocation{"--csv"},
                                    "\"" + *dir +
                                        "\" exists and is not a directory (expected the "
                                        "directory for measures.csv, sessions.csv, events.csv)");
        palplab::app::require_writable_dir("--csv", *dir);
        if (auto w = store.incomplete_warning(); !w.empty())
          std::cerr << palplab::escape_controls(w, false) << "\n";
        const auto summary = palplab::results::export_csv(store, *dir, *samples);
        std::cout << "wrote " << *dir << "/measures.csv, sessions.csv, events.csv"
                  << (*samples ? ", samples.csv" : "") << "\n";
        // Without --samples, an earlier export's samples.csv is not left beside these files.
        for (const auto& f : summary.removed)
          std::cout << "removed " << palplab::escape_controls(f, false)
                    << " (left by an earlier export; this one wrote no samples: add --samples "
                       "to export them)\n";
        *code = 0;
      });
    }};
}  // namespace
