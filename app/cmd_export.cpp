// `palplab export DB --csv DIR [--samples] [--overwrite]`: tidy CSV files from a results database.
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "app/output_dir.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "common/remove_on_signal.hpp"
#include "results/store.hpp"

namespace {

// The export's files with their header lines (results/store.cpp export_csv; the same since the
// first export): a file at one of these names that starts with its header is an earlier export
// and is replaced (samples.csv: removed by an export without --samples) without --overwrite.
struct ExportFile {
  const char* name;
  const char* header;
};
constexpr const char* kSamplesHeader =
    "participant,group,phase,session,t,x,y,z,fx,fy,fz,contact_node\n";
constexpr ExportFile kExportFiles[] = {
    {"measures.csv", "participant,group,phase,session,measure,value,unit\n"},
    // (The start of the header: an export before 2026-12-07 ends it here, one since then goes
    // on with ",session_id".)
    {"sessions.csv",
     "participant,group,phase,session,ordinal,prototype,instructor,study_offset_s,day,"
     "duration_s,steps,wall_duration_s,loop_median_s,loop_p99_s,seed,completed_at"},
    {"events.csv", "participant,group,phase,session,t,kind,value,region\n"},
    {"samples.csv", kSamplesHeader},
};

// Before the export writes into --csv: the database is none of the files it writes, replaces or
// removes (DIR/measures.csv was replaced by the CSV, DIR/samples.csv removed, each NAME.partial
// truncated), and a file at one of those names that is not palplab's export (the user's own
// samples.csv, removed as "left by an earlier export") is replaced or removed only with
// --overwrite (app/output_dir.hpp).
void check_export_dir(const std::string& db, const std::string& dir, bool samples, bool overwrite) {
  using palplab::app::DirOutput;
  std::vector<DirOutput> outputs;
  for (const auto& f : kExportFiles) {
    const std::string header = f.header;
    const bool is_samples = std::string(f.name) == "samples.csv";
    outputs.push_back({f.name, "palplab export (" + std::string(f.name) + ")",
                       [header](const std::string& path) {
                         return palplab::app::file_head(path, header.size()) == header;
                       },
                       is_samples && !samples ? "remove" : "replace",
                       is_samples && !samples
                           ? "an export without --samples removes the samples.csv of an earlier "
                             "export"
                           : ""});
    // Each file is first written as NAME.partial (never anything but the export's own).
    if (!is_samples || samples)
      outputs.push_back({std::string(f.name) + ".partial", "palplab export",
                         [](const std::string&) { return true; }});
  }
  palplab::app::require_replaceable_dir_outputs(
      "--csv", dir, "measures.csv, sessions.csv, events.csv", outputs,
      {{"the results database", db}}, "--overwrite", overwrite);
}

palplab::app::CommandRegistration reg_export{
    "export", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand("export", "Export a results database as tidy CSV files");
      auto db = std::make_shared<std::string>();
      auto dir = std::make_shared<std::string>();
      auto samples = std::make_shared<bool>(false);
      auto overwrite = std::make_shared<bool>(false);
      cmd->add_option("DB", *db, "Results database (from palplab run)")->required();
      cmd->add_option("--csv", *dir, "Directory for measures.csv, sessions.csv, events.csv")
          ->required();
      cmd->add_flag("--samples", *samples, "Also write samples.csv (every 1 kHz sample; large)");
      cmd->add_flag("--overwrite", *overwrite,
                    "Replace (or, without --samples, remove) a file at one of the export's names "
                    "in --csv that is not a palplab export (the database itself never)");
      cmd->callback([db, dir, samples, overwrite, code] {
        palplab::results::Store store = palplab::results::Store::open(*db);
        // A file where the CSV directory goes is said as such (and left alone).
        std::error_code ec;
        if (const auto st = std::filesystem::status(*dir, ec);
            std::filesystem::exists(st) && !std::filesystem::is_directory(st))
          throw palplab::InputError(palplab::SourceLocation{"--csv"},
                                    "\"" + *dir +
                                        "\" exists and is not a directory (expected the "
                                        "directory for measures.csv, sessions.csv, events.csv)");
        check_export_dir(*db, *dir, *samples, *overwrite);
        // With --overwrite a samples.csv that is not an export's may be removed: said as such.
        const std::string samples_csv = (std::filesystem::path(*dir) / "samples.csv").string();
        const bool foreign_samples =
            std::filesystem::is_regular_file(samples_csv, ec) &&
            std::filesystem::file_size(samples_csv, ec) > 0 && !ec &&
            palplab::app::file_head(samples_csv, std::string(kSamplesHeader).size()) !=
                kSamplesHeader;
        // The directories made here (--csv and any missing parents) are removed again if the
        // export fails (a damaged database): they would be left empty (review 2026-12-06,
        // second; `--csv nest1/nest2` left nest1).
        struct RemoveIfMadeAndEmpty {
          std::filesystem::path dir, top;  // top: the outermost directory that did not exist
          bool done = false;
          ~RemoveIfMadeAndEmpty() {
            if (done || top.empty()) return;
            std::error_code e;
            for (auto p = dir; std::filesystem::is_empty(p, e) && !e; p = p.parent_path()) {
              std::filesystem::remove(p, e);
              if (e || p == top || !p.has_parent_path()) break;
            }
          }
        } made{std::filesystem::absolute(*dir, ec).lexically_normal(), {}};
        if (!made.dir.has_filename()) made.dir = made.dir.parent_path();  // "out/" -> "out"
        for (auto p = made.dir;
             !p.empty() && !std::filesystem::exists(std::filesystem::symlink_status(p, ec));
             p = p.parent_path()) {
          made.top = p;
          if (p == p.parent_path()) break;
        }
        // Removed on SIGINT/SIGTERM/SIGHUP too, when empty (an interrupted export left them).
        std::vector<std::unique_ptr<palplab::RemoveOnSignal>> made_on_signal;
        if (!made.top.empty())
          for (auto p = made.dir;; p = p.parent_path()) {
            made_on_signal.push_back(std::make_unique<palplab::RemoveOnSignal>(p.string()));
            if (p == made.top || !p.has_parent_path() || p == p.parent_path()) break;
          }
        palplab::app::require_writable_dir("--csv", *dir);
        if (auto w = store.incomplete_warning(); !w.empty())
          std::cerr << palplab::escape_controls(w, false) << "\n";
        // A run with --samples none has none to export: said, not a bare header. The data say
        // it, not meta "samples" (a database whose meta said none while it held samples was
        // warned about; review 2026-12-07).
        // (A run with --samples full whose samples are gone is a damaged database: the export
        // says so below, without this warning first.)
        const auto setting = store.read_meta("samples");
        if (*samples && !store.read_sessions().empty() && !store.has_samples() &&
            setting.value_or("") != "full") {
          std::cerr << "warning: " << palplab::escape_controls(*db, false)
                    << ": the run stored no device samples"
                    << (setting && *setting == "none" ? " (it ran with --samples none)" : "")
                    << ": samples.csv holds its header only\n";
        }
        const auto summary = palplab::results::export_csv(store, *dir, *samples);
        made.done = true;
        made_on_signal.clear();
        std::cout << "wrote " << *dir << "/measures.csv, sessions.csv, events.csv"
                  << (*samples ? ", samples.csv" : "") << "\n";
        // Without --samples, an earlier export's samples.csv is not left beside these files.
        for (const auto& f : summary.removed)
          std::cout << "removed " << palplab::escape_controls(f, false)
                    << (foreign_samples
                            ? " (not a palplab export; removed as --overwrite allows, so that the "
                              "directory holds one export only)\n"
                            : " (left by an earlier export; this one wrote no samples: add "
                              "--samples to export them)\n");
        *code = 0;
      });
    }};
}  // namespace
