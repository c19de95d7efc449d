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
#include <functional>
#include <string>

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
};

struct RunOptions {
  std::string db;
  int jobs = 1;
  bool resume = false;  // continue an existing database of the same study
  bool force = false;   // delete an existing database and start again
  bool samples = true;  // store every 1 kHz sample
  // Stop (cleanly, as an interruption would) after this many sessions of this run; 0 = no limit.
  long max_sessions = 0;
  std::function<void(const Progress&)> progress;  // called after every session (serialised)
};

struct RunSummary {
  long sessions_run = 0, sessions_skipped = 0;
  double wall = 0.0;       // s
  double simulated = 0.0;  // s
  bool complete = false;   // every planned session is in the database
};

RunSummary run_study(const Study& study, const Plan& plan, const RunOptions& opt);

// Every session of one planned participant, in memory (no database; the measures are computed
// exactly as `run` computes them): what calibration and power analysis simulate. Samples are
// dropped unless `keep_samples`. Same results as run_study for the same study and plan.
std::vector<results::SessionData> simulate_participant(const Study& study,
                                                       const ParticipantPlan& pp,
                                                       bool keep_samples = false);

}  // namespace palplab::protocols
