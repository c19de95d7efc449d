// `palplab export DB --csv DIR [--samples]`: tidy CSV files from a results database.
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "common/escape.hpp"
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
        palplab::app::require_writable_dir("--csv", *dir);
        if (auto w = store.incomplete_warning(); !w.empty())
          std::cerr << palplab::escape_controls(w, false) << "\n";
        palplab::results::export_csv(store, *dir, *samples);
        std::cout << "wrote " << *dir << "/measures.csv, sessions.csv, events.csv"
                  << (*samples ? ", samples.csv" : "") << "\n";
        *code = 0;
      });
    }};
}  // namespace
