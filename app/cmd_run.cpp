// `palplab run STUDY.json --db FILE [--jobs N] [--resume] [--force] [--quiet]`: runs every
// planned session with virtual participants (lock-step) and stores the results.
// `palplab run STUDY.json --db FILE --human --participant ID [--device mouse|udp:PORT|trace:FILE]`:
// runs that participant's due sessions with a person (or a device stream) at the device, in real
// time (protocols::run_human; docs/DEVICES.md). With the mouse the sessions run in the palpation
// window (app/palpation_ui.hpp): run_human on a worker thread, the window on the main thread
// (GLFW), instructions between sessions, closing the window mid-session aborts it.
#include <unistd.h>
#include <csignal>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "app/command.hpp"
#include "app/palpation_ui.hpp"
#include "app/scene_option.hpp"
#include "common/escape.hpp"
#include "common/format.hpp"
#include "common/input_error.hpp"
#include "common/remove_on_signal.hpp"
#include "engine/haptics/devices/device_spec.hpp"
#include "engine/haptics/devices/monitored_device.hpp"
#include "engine/haptics/devices/mouse_device.hpp"
#include "engine/haptics/devices/self_test.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "engine/haptics/devices/udp_device.hpp"
#include "engine/render/mouse_control.hpp"
#include "engine/render/mouse_script.hpp"
#include "protocols/plan.hpp"
#include "protocols/runner.hpp"
#include "protocols/study.hpp"
#include "prototypes/factory.hpp"

namespace {

std::atomic<bool> g_interrupted{false};
volatile std::sig_atomic_t g_signal = 0;  // the signal that set g_interrupted
extern "C" void on_sigint(int sig) {
  g_signal = sig;
  g_interrupted = true;
}

// What stopped a person's run, as stored with an aborted session and said on stderr (every
// signal was "interrupted (Ctrl-C)": review 2026-12-07).
std::string signal_text() {
  switch (g_signal) {
    case SIGINT:
      return "interrupted (SIGINT, Ctrl-C)";
    case SIGTERM:
      return "stopped by SIGTERM";
    case SIGHUP:
      return "stopped by SIGHUP (the terminal closed)";
    default:
      return "interrupted";
  }
}

// A virtual run interrupted (SIGINT, SIGTERM, SIGHUP) stops at once, as the default action would:
// every session completed before it is already stored (each in its own transaction), the one
// running is not. The handler only says so and how to continue (write(2), unlink and _exit are
// async-signal-safe; the text is made before the run).
std::string g_interrupt_text, g_interrupt_text_none;
// Set once a session of the run is stored (or the run resumes a database): before that the
// interruption message must not speak of stored sessions (review 2026-12-07).
volatile std::sig_atomic_t g_stored_any = 0;
extern "C" void on_interrupt_virtual(int sig) {
  palplab::remove_registered_files();  // a --record-trace FILE.partial being written
  const std::string& text = g_stored_any ? g_interrupt_text : g_interrupt_text_none;
  const ssize_t ignored = ::write(2, text.data(), text.size());
  (void)ignored;
  ::_exit(128 + sig);
}

struct HumanArgs {
  bool human = false;
  std::string participant, device = "mouse", record_trace, mouse_script, size = "1280x800";
  double min_rate = 900.0, device_lost = 2.0;
  bool no_wait = false;
};

// The mouse device of one session in the window: owns the MouseDevice the window drives and the
// MonitoredDevice that hands what the haptic loop rendered back to the window.
struct WindowMouseDevice : palplab::engine::Device {
  explicit WindowMouseDevice(palplab::render::ToneCue& tone) : cued(monitor, tone) {}
  palplab::engine::MouseDevice mouse{Eigen::Vector3d::Zero()};
  palplab::engine::MonitoredDevice monitor{mouse};
  palplab::app::ToneSwitch cued;  // the ST tone switched at every haptic step
  palplab::engine::DeviceInput read(double t) override { return cued.read(t); }
  void write(const palplab::engine::Rendered& r) override { cued.write(r); }
};

// `run --human --device mouse`: protocols::run_human on a worker thread, the window here. The
// two meet in `Shared` (one mutex): the worker waits in before_session until the person starts
// the session; the window draws the session's scene from on_session_start to on_session_end.
palplab::protocols::HumanSummary run_in_window(const palplab::protocols::Study& s,
                                               const palplab::protocols::Plan& plan,
                                               palplab::protocols::HumanOptions o,
                                               const HumanArgs& h) {
  using namespace palplab;
  int W = 1280, H = 800;
  if (std::sscanf(h.size.c_str(), "%dx%d", &W, &H) != 2 || W < 64 || H < 64 || W > 8192 || H > 8192)
    throw InputError("--size: \"" + h.size + "\": expected WIDTHxHEIGHT, 64..8192 px per side");
  std::optional<render::MouseScript> script;
  if (!h.mouse_script.empty()) script = render::MouseScript::load(h.mouse_script);
  std::unique_ptr<app::PalpationUi> ui;
  try {
    ui = std::make_unique<app::PalpationUi>(W, H, "palplab - participant " + h.participant,
                                            std::move(script));
  } catch (const render::NoWindowError& e) {
    throw InputError(std::string("--device mouse needs a window: ") + e.what());
  }
  struct Shared {
    std::mutex mu;
    std::condition_variable cv;
    enum Stage { kIdle, kInstructions, kSession } stage = kIdle;
    std::string title, text, last_message;
    bool start = false, closed = false, done = false;
    std::optional<app::UiScene> new_scene;
    WindowMouseDevice* device = nullptr;
    double duration = 0.0;
    std::string session_line;
    engine::Frame frame;
    bool fresh = false;
  } sh;
  std::atomic<bool> stop{false};  // the window closed (or Ctrl-C): the session is aborted
  o.stop = &stop;
  o.stop_reason = [] { return g_signal ? signal_text() : std::string("window closed"); };
  auto outer_say = o.say;
  o.say = [&](const std::string& m) {
    if (outer_say) outer_say(m);
    std::lock_guard lock(sh.mu);
    sh.last_message = m;
  };
  WindowMouseDevice* made = nullptr;
  o.make_device = [&]() -> std::unique_ptr<engine::Device> {
    auto d = std::make_unique<WindowMouseDevice>(ui->tone());
    made = d.get();
    return d;
  };
  auto outer_before = o.before_session;
  o.before_session = [&](const protocols::SessionSpec& sp) {
    if (outer_before && !outer_before(sp)) return false;
    std::unique_lock lock(sh.mu);
    sh.stage = Shared::kInstructions;
    sh.title = sp.phase_id + " #" + std::to_string(sp.index + 1) + " (day " +
               std::to_string(sp.day) + ", " + std::to_string(std::lround(sp.duration)) + " s)";
    sh.text = protocols::session_instructions(s, sp);
    sh.start = false;
    sh.cv.wait(lock, [&] { return sh.start || sh.closed; });
    sh.stage = Shared::kIdle;
    return !sh.closed;
  };
  o.on_session_start = [&](const protocols::SessionSpec& sp, const engine::Scene& scene) {
    // Hold the contact point outside the surface until the window's first frame moves it.
    made->mouse.set_position(render::MouseControl::start_position(scene.geometry()), false);
    std::lock_guard lock(sh.mu);
    sh.new_scene = app::UiScene::of(scene);
    sh.device = made;
    sh.duration = sp.duration;
    sh.session_line = "participant " + h.participant + ": " + sp.phase_id + " #" +
                      std::to_string(sp.index + 1) + " (day " + std::to_string(sp.day) + ")";
    sh.fresh = false;
    sh.stage = Shared::kSession;
  };
  o.on_frame = [&](const engine::Frame& f) {
    std::lock_guard lock(sh.mu);
    sh.frame = f;
    sh.fresh = true;
  };
  o.on_session_end = [&](const results::SessionRecord&) {
    std::lock_guard lock(sh.mu);
    sh.stage = Shared::kIdle;
    sh.device = nullptr;
  };

  protocols::HumanSummary result;
  std::exception_ptr failure;
  std::thread worker([&] {
    try {
      result = protocols::run_human(s, plan, o);
    } catch (...) {
      failure = std::current_exception();
    }
    std::lock_guard lock(sh.mu);
    sh.done = true;
  });
  engine::Frame frame;
  app::UiStatus status;
  auto session_wall0 = std::chrono::steady_clock::now();
  while (true) {
    if (ui->closed() || g_interrupted.load()) {
      std::lock_guard lock(sh.mu);
      if (!sh.closed) {
        sh.closed = true;
        stop = true;
        sh.cv.notify_all();
      }
    }
    std::unique_lock lock(sh.mu);
    if (sh.done) break;
    if (sh.closed) {  // the window is gone: wait for the worker to store the aborted session
      lock.unlock();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    ui->begin_frame();
    if (sh.stage == Shared::kInstructions) {
      if (ui->draw_message(sh.title, sh.text, "Start the session")) {
        sh.start = true;
        sh.cv.notify_all();
      }
    } else if (sh.stage == Shared::kSession && (sh.new_scene || ui->has_scene())) {
      if (sh.new_scene) {
        ui->set_scene(std::move(*sh.new_scene));
        sh.new_scene.reset();
        frame = engine::Frame{};  // the previous session's last frame is not this one's
        session_wall0 = std::chrono::steady_clock::now();
      }
      const bool fresh = sh.fresh;
      if (fresh) std::swap(frame, sh.frame);
      sh.fresh = false;
      status.lines = {sh.session_line};
      // The haptic loop's rate so far (its period statistics come with the session's end).
      const double wall =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - session_wall0).count();
      char rate[96];
      std::snprintf(rate, sizeof rate, "haptic loop: %ld steps, %.0f steps/s", frame.step,
                    wall > 0.05 ? frame.step / wall : 0.0);
      status.lines.push_back(rate);
      status.timer = frame.t;
      status.timer_total = sh.duration;
      ui->draw_palpation(&sh.device->mouse, &sh.device->monitor, fresh ? &frame : nullptr, status);
    } else {
      ui->draw_message("palplab", sh.last_message.empty() ? "..." : sh.last_message, "OK");
    }
    lock.unlock();
    ui->end_frame();
  }
  worker.join();
  ui.reset();
  if (failure) std::rethrow_exception(failure);
  return result;
}

int run_human_cmd(const palplab::protocols::Study& s, const palplab::protocols::Plan& plan,
                  const palplab::protocols::RunOptions& ro, const HumanArgs& h, bool quiet) {
  using namespace palplab;
  if (h.participant.empty()) throw InputError("--human needs --participant ID");
  if (ro.resume || ro.force)
    throw InputError("--human continues or creates the database by itself; drop --resume/--force");
  (void)plan.participant(h.participant);  // an unknown id before the device is measured
  // Everything the arguments name is checked here, before run_human creates (or opens) the
  // database: a bad --device left a fresh database behind its exit 2. (--min-device-rate and
  // --device-lost are range-checked by their validators.)
  const engine::DeviceSpec spec = engine::parse_device_spec(h.device);
  if (!h.mouse_script.empty() && spec.kind != "mouse")
    throw InputError("--mouse-script needs --device mouse");
  // A trace is read once, here (a missing or malformed file is exit 2 before any output); each
  // session replays a copy from its start.
  auto trace = std::make_shared<engine::Trace>();
  if (spec.kind == "trace") {
    *trace = engine::read_trace(spec.file);
    if (trace->samples.empty())
      throw InputError(SourceLocation{"--device"},
                       "\"" + h.device + "\": the trace has no samples (expected a device track)");
    // Replayed one sample per haptic step of each session's scene: the trace's step must be
    // theirs (a 2 kHz trace played at half speed: review 2026-12-06, fourth).
    if (trace->samples.size() > 1)
      for (const auto& [id, file] : s.prototype_files)
        if (const double dt = prototypes::load_prototype(file).dt;
            std::abs(trace->step - dt) > 1e-3 * dt)
          throw InputError(SourceLocation{"--device"},
                           "\"" + h.device + "\": the trace has a sample every " +
                               format_g(trace->step * 1e3, 6) + " ms, prototype " + id +
                               "'s haptic step is " + format_g(dt * 1e3, 6) +
                               " ms (a trace is replayed one sample per step: record or "
                               "resample it at that step)");
  }
  // A UDP device is bound and measured once before the database is touched: a port in use or a
  // bridge that does not send is exit 2 with no output file. (Each session binds it again.)
  if (spec.kind == "udp") {
    engine::UdpDevice probe(engine::UdpDeviceOptions{spec.port, 0.002});
    engine::require_device_rate(probe, spec.text, h.min_rate);
  }
  if (!h.record_trace.empty()) {
    app::require_creatable_dir("--record-trace", h.record_trace);
    protocols::require_trace_dir_of(h.record_trace, ro.db);
  }
  protocols::HumanOptions o;
  o.db = ro.db;
  o.participant = h.participant;
  o.device_text = spec.text;
  o.samples = ro.samples;
  o.samples_explicit = ro.samples_explicit;
  o.record_trace_dir = h.record_trace;
  o.device_lost = h.device_lost;
  o.stop = &g_interrupted;
  o.stop_reason = signal_text;
  o.no_wait = h.no_wait;
  if (const char* now = std::getenv("PALPLAB_NOW")) {
    // Tests and dry runs of a long-term schedule: "today" as a Unix time or ISO 8601 UTC.
    std::tm tm{};
    if (strptime(now, "%Y-%m-%dT%H:%M:%SZ", &tm))
      o.now = timegm(&tm);
    else
      throw InputError(std::string("PALPLAB_NOW: expected YYYY-MM-DDTHH:MM:SSZ, got \"") + now +
                       "\"");
  }
  o.make_device = [spec, h, trace]() -> std::unique_ptr<engine::Device> {
    if (spec.kind == "udp") {
      auto d = std::make_unique<engine::UdpDevice>(engine::UdpDeviceOptions{spec.port, 0.002});
      engine::require_device_rate(*d, spec.text, h.min_rate);
      return d;
    }
    return std::make_unique<engine::TraceDevice>(*trace);
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
  // SIGHUP too: a closed terminal or a dropped ssh session ended the run silently (exit 129).
  std::vector<std::pair<int, void (*)(int)>> before;
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    before.emplace_back(sig, std::signal(sig, on_sigint));
    if (before.back().second == SIG_IGN) std::signal(sig, SIG_IGN);  // nohup stays nohup
  }
  const protocols::HumanSummary r =
      spec.kind == "mouse" ? run_in_window(s, plan, o, h) : protocols::run_human(s, plan, o);
  for (auto [sig, handler] : before) std::signal(sig, handler);
  std::printf("%s: participant %s: %d session(s) completed, %d aborted, %d remaining%s\n",
              palplab::escape_controls(ro.db, false).c_str(), h.participant.c_str(), r.sessions_run,
              r.aborted, r.remaining,
              r.remaining > 0 && !r.next_due.empty() ? ("; next due " + r.next_due).c_str() : "");
  // An aborted session is kept in the database, flagged: a result of the run, not a failure of
  // palplab (3 is "internal error", and it said nothing on stderr: review 2026-12-06, fourth).
  // Exit 1, the command's own "found something", and a line on stderr for scripts' logs.
  // The reason is said there too (with --quiet stdout says nothing).
  if (r.aborted > 0)
    std::fprintf(stderr,
                 "palplab run: %d session(s) of participant %s aborted: %s (kept in %s, flagged "
                 "status 'aborted' with the reason; the next run repeats them)\n",
                 r.aborted, h.participant.c_str(),
                 palplab::escape_controls(r.abort_reason, false).c_str(),
                 palplab::escape_controls(ro.db, false).c_str());
  // A signal ends the command as it ends a virtual run: 128 + its number, and said (stopped
  // during the study's break, the run exited 0 in silence: review 2026-12-07).
  if (g_signal) {
    std::fprintf(stderr,
                 "palplab run: %s%s: the completed sessions are stored in %s, %d remaining; "
                 "the same command continues\n",
                 signal_text().c_str(),
                 r.stopped ? " before the next session (nothing of it is stored)" : "",
                 palplab::escape_controls(ro.db, false).c_str(), r.remaining);
    return 128 + g_signal;
  }
  return r.aborted > 0 ? 1 : 0;
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

palplab::app::CommandRegistration reg_run{
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
      auto* jobs_opt =
          cmd->add_option("--jobs", opt->jobs, "Participants simulated in parallel (threads)")
              ->check(palplab::app::count_range(1, 1024));
      cmd->add_flag("--resume", opt->resume, "Continue an interrupted run in the same database");
      cmd->add_flag("--force", opt->force, "Replace an existing database");
      cmd->add_flag("--quiet", *quiet, "No progress output");
      cmd->add_option("--samples", *samples, "Store device samples: full (1 kHz) or none")
          ->check(CLI::IsMember({"full", "none"}));
      auto* max_sessions_opt =
          cmd->add_option("--max-sessions", opt->max_sessions,
                          "Stop after this many sessions, at least 1 (continue later with "
                          "--resume; without the flag: no limit)")
              ->check(palplab::app::count_range(1, 1000000000));
      auto human = std::make_shared<HumanArgs>();
      cmd->add_flag("--human", human->human,
                    "Run one participant's due sessions with a person at the device (real time)");
      cmd->add_option("--participant", human->participant, "Participant id (with --human)");
      std::vector<const CLI::Option*> human_only;
      human_only.push_back(cmd->add_option(
          "--device", human->device,
          "mouse (the palpation window; default), udp:PORT or trace:FILE (with --human)"));
      human_only.push_back(cmd->add_option(
          "--mouse-script", human->mouse_script,
          "Scripted mouse input for --device mouse (JSON, docs/DEVICES.md; tests)"));
      human_only.push_back(
          cmd->add_option("--size", human->size, "Window size WIDTHxHEIGHT for --device mouse"));
      human_only.push_back(cmd->add_option("--min-device-rate", human->min_rate,
                                           "Refuse a device below this rate (Hz; default 900)")
                               ->check(palplab::app::finite_range(0, 100000)));
      human_only.push_back(
          cmd->add_option("--device-lost", human->device_lost,
                          "Abort the session after this long without device samples (s; "
                          "default 2)")
              ->check(palplab::app::finite_range(0, 3600, true)));
      human_only.push_back(cmd->add_flag(
          "--no-wait", human->no_wait,
          "Start each due session at once, without the study's planned break after the one "
          "before it (with --human)"));
      cmd->add_option("--record-trace", human->record_trace,
                      "Write each session's device track to DIR (trace files)");
      // Virtual runs only: with --human they would be silently ignored.
      const std::vector<const CLI::Option*> virtual_only = {jobs_opt, max_sessions_opt};
      cmd->callback([cmd, study, opt, quiet, samples, code, human, scenes, human_only,
                     virtual_only] {
        using namespace palplab::protocols;
        for (const CLI::Option* o : human_only)
          palplab::app::flag_only_with(o, human->human, "--human (a person at the device)");
        for (const CLI::Option* o : virtual_only)
          palplab::app::flag_only_with(o, !human->human, "virtual participants (without --human)");
        const std::vector<std::string> scene_sources = palplab::app::preload_scenes(*scenes);
        if (opt->resume && opt->force)
          throw palplab::InputError("--resume and --force exclude each other");
        if (opt->db.empty())
          throw palplab::InputError(palplab::SourceLocation{"--db"},
                                    "no database file name given (an empty string): expected "
                                    "FILE.db");
        // Given but empty (an unset shell variable): the run went on and wrote no trace.
        if (cmd->count("--record-trace") > 0 && human->record_trace.empty())
          throw palplab::InputError(palplab::SourceLocation{"--record-trace"},
                                    "no directory given (an empty string): expected the "
                                    "directory the trace files go into");
        Study s = load_study(*study, engine_prototype_inspector());
        {
          std::vector<std::string> used;
          for (const auto& [id, file] : s.prototype_files) used.push_back(file);
          for (const auto& w : palplab::app::unused_scene_warnings(*scenes, scene_sources, used))
            std::cerr << palplab::escape_controls(w, false) << "\n";
        }
        Plan plan = make_plan(s);
        opt->samples = *samples == "full";
        // Without --samples a resume keeps what the run started with.
        opt->samples_explicit = cmd->count("--samples") > 0;
        if (human->human) {
          *code = run_human_cmd(s, plan, *opt, *human, *quiet);
          return;
        }
        if (!human->participant.empty()) throw palplab::InputError("--participant needs --human");
        if (!human->record_trace.empty()) {
          palplab::app::require_creatable_dir("--record-trace", human->record_trace);
          palplab::protocols::require_trace_dir_of(human->record_trace, opt->db);
        }
        opt->record_trace_dir = human->record_trace;
        const bool tty = isatty(2);
        auto bar_open = std::make_shared<bool>(false);  // a progress bar without its newline
        if (!*quiet) {
          opt->notice = [](const std::string& m) {
            std::fprintf(stderr, "%s\n", palplab::escape_controls(m, false).c_str());
          };
          opt->progress = [tty, bar_open](const Progress& p) {
            // The runner's estimate (per prototype's measured cost); "ETA ? (C not timed yet)"
            // while a prototype with sessions left has none run.
            const std::string eta =
                hms(p.eta) +
                (p.eta_untimed.empty()
                     ? ""
                     : " (" + palplab::escape_controls(p.eta_untimed, false) + " not timed yet)");
            if (tty) {
              const int width = 30;
              int fill = static_cast<int>(width * p.sessions_done / std::max(1L, p.sessions_total));
              std::fprintf(stderr,
                           "\r[%s%s] %ld/%ld sessions, %d/%d participants, %s elapsed, ETA %s  ",
                           std::string(fill, '#').c_str(), std::string(width - fill, '.').c_str(),
                           p.sessions_done, p.sessions_total, p.participants_done,
                           p.participants_total, hms(p.elapsed).c_str(), eta.c_str());
              *bar_open = p.sessions_done != p.sessions_total;
              if (!*bar_open) std::fprintf(stderr, "\n");
            } else {
              std::fprintf(
                  stderr, "session %ld/%ld done (%s), participants %d/%d, elapsed %.1f s, ETA %s\n",
                  p.sessions_done, p.sessions_total,
                  palplab::escape_controls(p.last, false).c_str(), p.participants_done,
                  p.participants_total, p.elapsed, eta.c_str());
            }
            std::fflush(stderr);
          };
        }
        // The flags that change what is written come along (--samples is the run's own).
        std::string again =
            "palplab run " + palplab::shell_word(*study) + " --db " + palplab::shell_word(opt->db);
        for (const auto& sc : *scenes) again += " --scene " + palplab::shell_word(sc);
        if (!human->record_trace.empty())
          again += " --record-trace " + palplab::shell_word(human->record_trace);
        g_interrupt_text = "\ninterrupted: the sessions completed before this are stored in " +
                           palplab::escape_controls(opt->db, false) +
                           " (those still running are not); continue with:\n  " + again +
                           " --resume\n";
        g_interrupt_text_none =
            "\ninterrupted before any session was complete: no session "
            "is stored in " +
            palplab::escape_controls(opt->db, false) + "; continue with:\n  " + again +
            " --resume\n";
        g_stored_any = opt->resume ? 1 : 0;
        {  // the flag follows the sessions stored, with or without the progress output
          std::function<void(const Progress&)> show = std::move(opt->progress);
          opt->progress = [show](const Progress& p) {
            if (p.sessions_done > 0) g_stored_any = 1;
            if (show) show(p);
          };
        }
        // SIGHUP too: a closed terminal or a dropped ssh session ended the run silently (exit
        // 129, review 2026-12-07). A signal the caller ignores (nohup, `&`) stays ignored.
        std::vector<std::pair<int, void (*)(int)>> before;
        for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
          before.emplace_back(sig, std::signal(sig, on_interrupt_virtual));
          if (before.back().second == SIG_IGN) std::signal(sig, SIG_IGN);
        }
        RunSummary r = run_study(s, plan, *opt);
        for (auto [sig, handler] : before) std::signal(sig, handler);
        if (*bar_open) std::fprintf(stderr, "\n");  // stopped by --max-sessions
        // What is left to run: virtual sessions (--resume), or only people's (run --human).
        std::string how = "continue with --resume";
        if (!r.complete && r.left.size() == r.people_left.size()) {
          std::string ids;
          for (std::size_t k = 0; k < r.people_left.size() && k < 10; ++k)
            ids += (k ? ", " : "") + r.people_left[k];
          if (r.people_left.size() > 10) ids += ", …";
          how = "the virtual participants are done; people's sessions remain (" + ids +
                "): `palplab run STUDY --db " + palplab::shell_word(opt->db) +
                " --human --participant ID`";
        }
        if (!*quiet) {
          std::printf(
              "%s: %ld sessions run (%ld already in the database), %.1f s simulated in %.1f s "
              "wall (%.1fx real time), %s\n",
              palplab::escape_controls(opt->db, false).c_str(), r.sessions_run, r.sessions_skipped,
              r.simulated, r.wall, r.wall > 0 ? r.simulated / r.wall : 0.0,
              r.complete ? "complete"
                         : palplab::escape_controls("INCOMPLETE (" + how + ")", false).c_str());
        } else if (!r.complete) {  // --quiet: no progress, but never a silent partial result
          std::fprintf(stderr, "%s: INCOMPLETE (%ld session%s run; %s)\n",
                       palplab::escape_controls(opt->db, false).c_str(), r.sessions_run,
                       r.sessions_run == 1 ? "" : "s",
                       palplab::escape_controls(how, false).c_str());
        }
        *code = 0;
      });
    }};
}  // namespace
