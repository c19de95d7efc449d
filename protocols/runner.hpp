#pragma once
// `palplab run`: drives every planned session in lock-step (simulated time, 1 kHz haptic steps,
// as fast as the CPU allows) with the virtual participants, participants in parallel on `jobs`
// threads, each with its own scenes. Per session: build the scene of the session's prototype
// with the phase's cue overrides and the study's thresholds, let the trainee (and instructor)
// act on what it renders, log every sample and event, compute the measures from the log and
// store it all in one transaction.
//
// Reproducible: a session depends only on the participant's model state before it (stored with
// the previous session as JSON, exact), its derived seed and the deterministic scene; so a run
// resumed after an interruption (kill -9 included) ends with exactly the measures of an
// uninterrupted one, and the number of threads does not change any result.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "engine/haptics/clock.hpp"
#include "engine/haptics/device.hpp"
#include "engine/haptics/devices/trace_device.hpp"
#include "protocols/plan.hpp"
#include "protocols/study.hpp"
#include "results/store.hpp"

namespace palplab::protocols {

struct Progress {
  int participants_total = 0, participants_done = 0;
  long sessions_total = 0, sessions_done = 0;  // done includes sessions found on resume
  long sessions_resumed = 0;                   // complete before this run started
  double elapsed = 0.0;                        // s wall time of this run
  double simulated = 0.0;                      // s simulated by this run
  std::string last;                            // "P07 training #2" just completed
  // s wall time of the session just stored, whole: its scene set-up, the briefing's
  // demonstration, the stepping, its measures and its database write.
  double last_session_wall = 0.0;
  // Estimated wall time left (s): the simulated time left per prototype at that prototype's
  // measured cost (wall time of its virtual sessions per simulated second), over the worker
  // threads. A session run by this process counts whole (last_session_wall); one stored by an
  // earlier run of a resumed database counts its stored wall_duration, the stepping loop only
  // (the set-up is not stored): an underestimate, less so with each session this run times.
  // Prototypes cost very differently (exp2: C is ≈ 100× A), so while a prototype with sessions
  // left has none timed the ETA is unknown (-1) and `eta_untimed` names it. With
  // RunOptions::max_sessions: to that stop.
  double eta = -1.0;
  std::string eta_untimed;  // "C, D" (prototypes with sessions left and none timed yet)
};

struct RunOptions {
  std::string db;
  int jobs = 1;
  bool resume = false;  // continue an existing database of the same study
  bool force = false;   // delete an existing database and start again
  bool samples = true;  // store every 1 kHz sample
  // false: `samples` is only the default of a new run; a resumed run keeps the setting the run
  // started with (meta "samples"). true: a resume with another setting is refused (a database
  // must not hold samples for some sessions only).
  bool samples_explicit = true;
  // Stop (cleanly, as an interruption would) after this many sessions of this run; 0 = no limit.
  long max_sessions = 0;
  // "" = none; else every session's device track (exact positions) as
  // DIR/<participant>_<ordinal>_0.trace (replay: `run --human --device trace:FILE`).
  std::string record_trace_dir;
  std::function<void(const Progress&)> progress;  // called after every session (serialised)
  // Told what --force replaces before it is removed ("replacing r.db: a run of study \"x\", 30
  // sessions, complete"), and when a resume finds a database whose start was interrupted.
  std::function<void(const std::string&)> notice;
};

struct RunSummary {
  long sessions_run = 0, sessions_skipped = 0;
  double wall = 0.0;       // s
  double simulated = 0.0;  // s
  bool complete = false;   // every planned session is complete in the database (people's too)
  // The planned participants with a session not complete, in plan order; of them, those run by
  // people (`run --human`): the database stays unfinished until they come (--resume does not
  // run them).
  std::vector<std::string> left, people_left;
};

RunSummary run_study(const Study& study, const Plan& plan, const RunOptions& opt);

// Every session of one planned participant, in memory (no database; the measures are computed
// exactly as `run` computes them): what calibration and power analysis simulate. Samples are
// dropped unless `keep_samples`. Same results as run_study for the same study and plan.
std::vector<results::SessionData> simulate_participant(const Study& study,
                                                       const ParticipantPlan& pp,
                                                       bool keep_samples = false);

// `run --human`: one participant's due sessions with a person (or a device stream) at the
// device, the haptic loop at 1 kHz on its own thread (engine::run_realtime). Sessions are due by
// calendar day (UTC) counted from the participant's first human session (day 0 = the first
// run); sessions of earlier days still pending run first; when nothing is due, InputError with
// the date of the next one. Every session is written as it goes (results::Store::begin_session
// ...): samples and events every second; stop / device lost / device finished early mark it
// aborted (kept, flagged) and the next run repeats it as a new attempt. A session planned on the
// same day as the one before it starts no earlier than that one's end plus the study's break
// between them (exp2: 10 min between training sessions); the command waits, saying until when
// (`no_wait`: at once). Each session's study_offset is when it started, s after the
// participant's first session started (the plan's offset for virtual participants).
struct HumanOptions {
  std::string db;  // created when missing (the same study file otherwise, SHA-256 checked)
  std::string participant;
  std::string device_text;  // stored with each session ("udp:5005")
  // A fresh device per session (a trace replays from its start; a UDP socket is re-bound).
  std::function<std::unique_ptr<engine::Device>()> make_device;
  const std::atomic<bool>* stop = nullptr;  // Ctrl-C / window closed: abort the session
  bool no_wait = false;  // start each due session at once, without the study's planned break
  // Why `stop` was set, asked when it ends a session (stored as the abort reason).
  std::function<std::string()> stop_reason = [] { return std::string("interrupted"); };
  double device_lost = 2.0;  // s without a fresh hardware sample: the session is aborted
  bool samples = true;
  bool samples_explicit = true;  // as RunOptions::samples_explicit
  std::string record_trace_dir;  // "" = none; else DIR/<participant>_<ordinal>_<attempt>.trace
  std::int64_t now = -1;  // Unix time at the start (s), the clock runs on; -1 = the system clock
  std::function<void(const std::string&)> say;  // instructions, progress (stdout)
  // Before each session (after its instructions are said); false = stop here.
  std::function<bool(const SessionSpec&)> before_session;
  // For a window (`run --human --device mouse`): the session's scene, built and about to start
  // (valid until on_session_end returns); every graphics frame (on the clock's graphics thread);
  // the session's record once stored (status complete or aborted).
  std::function<void(const SessionSpec&, const engine::Scene&)> on_session_start;
  std::function<void(const engine::Frame&)> on_frame;
  std::function<void(const results::SessionRecord&)> on_session_end;
};

// What a person is told before the session: the phase's `instructions` (docs/FORMATS.md), or
// else a default naming the feature to find and the session's length.
std::string session_instructions(const Study& study, const SessionSpec& spec);

struct HumanSummary {
  int sessions_run = 0, aborted = 0, remaining = 0;
  // `stop` ended the run between sessions (during the study's break, or before a session's
  // start): nothing of the next session is stored.
  bool stopped = false;
  std::string next_due;      // "YYYY-MM-DD" of the next pending session; "" when all are done
  std::string abort_reason;  // why the aborted session stopped (as stored); "" when none was
};

HumanSummary run_human(const Study& study, const Plan& plan, const HumanOptions& opt);

// The device track of a stored session from its samples (quantised: 1 um positions, so a
// replay reproduces the measures within that quantisation, not bit for bit).
engine::Trace trace_from_samples(const results::SampleSeries& s);

// --record-trace DIR: every trace a run writes names its run in its metadata, "database" (the
// results database's absolute path, trace_database) and "study" (the study id). A DIR holding a
// trace of the names a run writes (<participant>_<ordinal>_<attempt>.trace) from another
// database, or from a palplab that did not name it, is refused (InputError at --record-trace)
// before the run: its files would be replaced (a person's recorded sessions by another study's).
std::string trace_database(const std::string& db);
void require_trace_dir_of(const std::string& dir, const std::string& db);

}  // namespace palplab::protocols
