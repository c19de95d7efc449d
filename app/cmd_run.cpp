// `palplab run STUDY.json --db FILE [--jobs N] [--resume] [--force] [--quiet]`: runs every
// planned session with virtual participants (lock-step) and stores the results.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "protocols/plan.hpp"
#include "protocols/runner.hpp"
#include "protocols/study.hpp"

namespace {

std::string hms(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  char buf[32];
  long t = std::lround(s);
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, (t % 3600) / 60);
  else
    std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  return buf;
}

palplab::app::CommandRegistration reg{
    "run", [](CLI::App& root, int* code) {
      auto* cmd =
          root.add_subcommand("run", "Run a study with virtual participants into a database");
      auto study = std::make_shared<std::string>();
      auto opt = std::make_shared<palplab::protocols::RunOptions>();
      auto quiet = std::make_shared<bool>(false);
      auto samples = std::make_shared<std::string>("full");
      cmd->add_option("STUDY", *study, "Study file (JSON)")->required();
      cmd->add_option("--db", opt->db, "Results database to create (SQLite)")->required();
      cmd->add_option("--jobs", opt->jobs, "Participants simulated in parallel (threads)")
          ->check(CLI::Range(1, 1024));
      cmd->add_flag("--resume", opt->resume, "Continue an interrupted run in the same database");
      cmd->add_flag("--force", opt->force, "Replace an existing database");
      cmd->add_flag("--quiet", *quiet, "No progress output");
      cmd->add_option("--samples", *samples, "Store device samples: full (1 kHz) or none")
          ->check(CLI::IsMember({"full", "none"}));
      cmd->add_option("--max-sessions", opt->max_sessions,
                      "Stop after this many sessions (continue later with --resume)")
          ->check(CLI::Range(0L, 1000000000L));
      cmd->callback([study, opt, quiet, samples, code] {
        using namespace palplab::protocols;
        if (opt->resume && opt->force)
          throw palplab::InputError("--resume and --force exclude each other");
        Study s = load_study(*study, engine_prototype_inspector());
        Plan plan = make_plan(s);
        opt->samples = *samples == "full";
        const bool tty = isatty(2);
        if (!*quiet) {
          opt->progress = [tty](const Progress& p) {
            const long run = p.sessions_done - p.sessions_resumed;
            const long left = p.sessions_total - p.sessions_done;
            const double eta = run > 0 ? p.elapsed / run * left : -1;
            if (tty) {
              const int width = 30;
              int fill = static_cast<int>(width * p.sessions_done / std::max(1L, p.sessions_total));
              std::fprintf(stderr,
                           "\r[%s%s] %ld/%ld sessions, %d/%d participants, %s elapsed, ETA %s  ",
                           std::string(fill, '#').c_str(), std::string(width - fill, '.').c_str(),
                           p.sessions_done, p.sessions_total, p.participants_done,
                           p.participants_total, hms(p.elapsed).c_str(), hms(eta).c_str());
              if (p.sessions_done == p.sessions_total) std::fprintf(stderr, "\n");
            } else {
              std::fprintf(
                  stderr, "session %ld/%ld done (%s), participants %d/%d, elapsed %.1f s, ETA %s\n",
                  p.sessions_done, p.sessions_total,
                  palplab::escape_controls(p.last, false).c_str(), p.participants_done,
                  p.participants_total, p.elapsed, hms(eta).c_str());
            }
            std::fflush(stderr);
          };
        }
        RunSummary r = run_study(s, plan, *opt);
        if (!*quiet) {
          std::printf(
              "%s: %ld sessions run (%ld already in the database), %.1f s simulated in %.1f s "
              "wall (%.1fx real time), %s\n",
              palplab::escape_controls(opt->db, false).c_str(), r.sessions_run, r.sessions_skipped,
              r.simulated, r.wall, r.wall > 0 ? r.simulated / r.wall : 0.0,
              r.complete ? "complete" : "INCOMPLETE (continue with --resume)");
        }
        *code = 0;
      });
    }};
}  // namespace
