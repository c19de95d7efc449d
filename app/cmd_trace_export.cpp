// `palplab trace-export DB --session N --out FILE.trace`: the device track of a stored session
// (its 1 kHz samples) as a trace file for `--device trace:FILE` (docs/DEVICES.md). Positions in
// the database are quantised to 1 um, so a replay reproduces the session within that, not bit
// for bit (a `--record-trace` file is exact).
#include <algorithm>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "app/command.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "protocols/runner.hpp"
#include "results/store.hpp"

namespace {
struct Args {
  std::string db, out;
  long long session = 0;
  bool overwrite = false;
};

palplab::app::CommandRegistration reg_trace_export{
    "trace-export", [](CLI::App& root, int* code) {
      auto* cmd = root.add_subcommand(
          "trace-export", "Write a stored session's device track (samples) as a trace file");
      auto a = std::make_shared<Args>();
      cmd->add_option("DB", a->db, "Results database")->required();
      // count_range refuses a number beyond the 64-bit range, which the integer parse silently
      // clamped (99999999999999999999 was read as session 9223372036854775807).
      cmd->add_option(
             "--session", a->session,
             "Session id (the database's sessions.session: session_id in export's sessions.csv)")
          ->required()
          ->check(palplab::app::count_range(1, std::numeric_limits<long long>::max()));
      cmd->add_option("--out", a->out, "Trace file to write")->required();
      cmd->add_flag("--overwrite", a->overwrite,
                    "Replace an existing --out that is not a trace file");
      cmd->callback([a, code] {
        using namespace palplab;
        // --out is never the database read, nor a file of another kind without --overwrite.
        app::require_replaceable_output(
            "--out", a->out, {{"the results database", a->db}},
            [](const std::string& p) { return app::file_starts_with(p, "# palplab-trace/"); },
            "palplab trace file", a->overwrite);
        results::Store store = results::Store::open(a->db);
        bool found = false;
        std::string who;
        long long lo = 0, hi = 0, n = 0;  // the session ids of the database, for the message
        for (const auto& s : store.read_attempts()) {
          lo = n == 0 ? s.session : std::min(lo, s.session);
          hi = n == 0 ? s.session : std::max(hi, s.session);
          ++n;
          if (s.session == a->session) {
            found = true;
            who = s.participant + " " + s.phase + " #" + std::to_string(s.phase_index + 1);
          }
        }
        if (!found)
          throw InputError(
              SourceLocation{a->db},
              "--session: no session " + std::to_string(a->session) + " in the database (" +
                  (n == 0 ? std::string("it holds no sessions")
                          : "its sessions are " + std::to_string(lo) + ".." + std::to_string(hi) +
                                ", " + std::to_string(n) + " in all") +
                  ")");
        const results::SampleSeries ss = store.read_samples(a->session);
        if (ss.size() == 0)
          throw InputError("session " + std::to_string(a->session) +
                               " has no stored samples (run with --samples full)",
                           a->db);
        engine::Trace tr = protocols::trace_from_samples(ss);
        tr.meta["session"] = std::to_string(a->session);
        engine::write_trace(a->out, tr);
        // The samples hold the positions only: a needle session's tool switch and stylus axis
        // are not in the database, so the track replays as the finger's (review 2026-12-06,
        // eighth: the replay had no insertion, silently). `run --record-trace` keeps them.
        const nlohmann::json study = nlohmann::json::parse(store.read_study().json, nullptr, false);
        if (study.is_object() && study.contains("task") && study["task"].is_object() &&
            study["task"].value("kind", "") == "needle_insertion")
          std::fprintf(stderr,
                       "warning: session %lld is a needle insertion: the database holds no tool "
                       "switch or stylus axis, so %s replays as the finger's positions only (no "
                       "insertion); `palplab run --record-trace DIR` records the whole track\n",
                       a->session, escape_controls(a->out, false).c_str());
        std::printf("%s: %zu samples of session %lld (%s)\n",
                    escape_controls(a->out, false).c_str(), tr.samples.size(), a->session,
                    escape_controls(who, false).c_str());
        *code = 0;
      });
    }};
}  // namespace
