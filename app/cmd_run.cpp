// `palplab run STUDY.json --db FILE [--jobs N] [--resume] [--force] [--quiet]`: runs every
// planned session with virtual participants (lock-step) and stores the results.
// `palplab run STUDY.json --db FILE --human --participant ID [--device udp:PORT|trace:FILE]`:
// runs that participant's due sessions with a person (or a device stream) at the device, in real
// time (protocols::run_human; docs/DEVICES.md).
#include <unistd.h>
#include <csignal>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <memory>

#include "app/command.hpp"
#include "app/scene_option.hpp"
#include "common/escape.hpp"
#include "common/input_error.hpp"
#include "engine/haptics/devices/device_spec.hpp"
#include "engine/haptics/devices/self_test.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "engine/haptics/devices/udp_device.hpp"
#include "protocols/plan.hpp"
#include "protocols/runner.hpp"
#include "protocols/study.hpp"

namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_sigint(int) {
  g_interrupted = true;
}

struct HumanArgs {
  bool human = false;
  std::string participant, device = "mouse", record_trace;
  double min_rate = 900.0, device_lost = 2.0;
};

int run_human_cmd(const palplab::protocols::Study& s, const palplab::protocols::Plan& plan,
                  const palplab::protocols::RunOptions& ro, const HumanArgs& h, bool quiet) {
  using namespace palplab;
  if (h.participant.empty()) throw InputError("--human needs --participant ID");
  if (ro.resume || ro.force)
    throw InputError("--human continues or creates the database by itself; drop --resume/--force");
  const engine::DeviceSpec spec = engine::parse_device_spec(h.device);
  if (spec.kind == "mouse")
    throw InputError(
        "--device mouse: sessions in the window are not built yet for `run --human`; use "
        "--device udp:PORT (a bridge or `palplab device-sim`) or trace:FILE");
  if (!(h.min_rate >= 0.0 && h.min_rate <= 100000.0))
    throw InputError("--min-device-rate: expected 0..100000 Hz");
  if (!(h.device_lost > 0.0 && h.device_lost <= 3600.0))
    throw InputError("--device-lost: expected (0, 3600] s");
  protocols::HumanOptions o;
  o.db = ro.db;
  o.participant = h.participant;
  o.device_text = spec.text;
  o.samples = ro.samples;
  o.record_trace_dir = h.record_trace;
  o.device_lost = h.device_lost;
  o.stop = &g_interrupted;
  if (const char* now = std::getenv("PALPLAB_NOW")) {
    // Tests and dry runs of a long-term schedule: "today" as a Unix time or ISO 8601 UTC.
    std::tm tm{};
    if (strptime(now, "%Y-%m-%dT%H:%M:%SZ", &tm))
      o.now = timegm(&tm);
    else
      throw InputError(std::string("PALPLAB_NOW: expected YYYY-MM-DDTHH:MM:SSZ, got \"") + now +
                       "\"");
  }
  o.make_device = [spec, h]() -> std::unique_ptr<engine::Device> {
    if (spec.kind == "udp") {
      auto d = std::make_unique<engine::UdpDevice>(engine::UdpDeviceOptions{spec.port, 0.002});
      engine::require_device_rate(*d, spec.text, h.min_rate);
      return d;
    }
    return std::make_unique<engine::TraceDevice>(engine::read_trace(spec.file));
  };
  o.say = [quiet](const std::string& m) {
    if (!quiet) std::printf("%s\n", palplab::escape_controls(m, false).c_str());
    std::fflush(stdout);
  };
  o.before_session = [&](const protocols::SessionSpec& sp) {
    o.say("next: " + sp.phase_id + " #" + std::to_string(sp.index + 1) + " of participant " +
          h.participant + " (day " + std::to_string(sp.day) + ", " +
          std::to_string(std::lround(sp.duration)) + " s)");
    return !g_interrupted.load();
  };
  std::signal(SIGINT, on_sigint);
  std::signal(SIGTERM, on_sigint);
  const protocols::HumanSummary r = protocols::run_human(s, plan, o);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  std::printf("%s: participant %s: %d session(s) completed, %d aborted, %d remaining%s\n",
              palplab::escape_controls(ro.db, false).c_str(), h.participant.c_str(), r.sessions_run,
              r.aborted, r.remaining,
              r.remaining > 0 && !r.next_due.empty() ? ("; next due " + r.next_due).c_str() : "");
  // An aborted session is kept in the database, flagged; the exit code says it happened.
  return r.aborted > 0 ? 3 : 0;
}

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
      auto scenes = std::make_shared<std::vector<std::string>>();
      palplab::app::add_scene_option(cmd, *scenes, true);
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
      auto human = std::make_shared<HumanArgs>();
      cmd->add_flag("--human", human->human,
                    "Run one participant's due sessions with a person at the device (real time)");
      cmd->add_option("--participant", human->participant, "Participant id (with --human)");
      cmd->add_option("--device", human->device, "udp:PORT or trace:FILE (with --human)");
      cmd->add_option("--min-device-rate", human->min_rate,
                      "Refuse a device below this rate (Hz; default 900)");
      cmd->add_option("--device-lost", human->device_lost,
                      "Abort the session after this long without device samples (s; default 2)");
      cmd->add_option("--record-trace", human->record_trace,
                      "Write each session's device track to DIR (trace files)");
      cmd->callback([study, opt, quiet, samples, code, human, scenes] {
        using namespace palplab::protocols;
        palplab::app::preload_scenes(*scenes);
        if (opt->resume && opt->force)
          throw palplab::InputError("--resume and --force exclude each other");
        Study s = load_study(*study, engine_prototype_inspector());
        Plan plan = make_plan(s);
        opt->samples = *samples == "full";
        if (human->human) {
          *code = run_human_cmd(s, plan, *opt, *human, *quiet);
          return;
        }
        if (!human->participant.empty()) throw palplab::InputError("--participant needs --human");
        opt->record_trace_dir = human->record_trace;
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
