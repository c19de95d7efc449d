#pragma once
// The plan: a study expanded (seeded, deterministic) into participants x sessions. The same
// study and seed always give the same plan, bit for bit, on every platform: assignment uses
// palplab::protocols::Rng (not std:: distributions, whose output is implementation-defined) and
// every participant/session gets its own derived seed (common/seed.hpp).
#include <cstdint>
#include <string>
#include <vector>

#include "protocols/study.hpp"

namespace palplab::protocols {

// One slot of the per-participant timeline (the same for every participant).
struct Slot {
  int phase = 0;          // index into Study::phases
  int index = 0;          // session number within the phase, 0-based
  double offset = 0.0;    // s from the start of the participant's first session
  double duration = 0.0;  // s
  int day = 0;            // calendar day (0 = first day), from offset
};

// A session that would start before the previous one ends: its phase (index), the phase's key
// that sets the start ("start" for its first session, "gap" for the others) and the message.
struct ScheduleProblem {
  int phase = 0;
  std::string key, message;
};

// Offsets of every session; throws nothing, but `problems` receives sessions that would start
// before the previous one ends.
std::vector<Slot> schedule(const std::vector<Phase>& phases,
                           std::vector<ScheduleProblem>* problems = nullptr);

struct SessionSpec {
  int ordinal = 0;  // 0-based position in the participant's timeline
  int phase = 0;    // index into Study::phases
  std::string phase_id;
  int index = 0;               // within the phase
  std::string prototype;       // id
  std::string prototype_file;  // resolved path
  CueSwitches cues;
  double offset = 0.0;    // s, study time of the session start for this participant
  double duration = 0.0;  // s
  int day = 0;
  std::string instructor;  // "" when not instructed
  std::uint64_t seed = 0;  // derive_seed(participant seed, "session", ordinal)
};

struct ParticipantPlan {
  std::string id;  // "P01" ... or the explicit id
  std::string group;
  int number = 0;          // 0-based position in the study's participant list
  std::uint64_t seed = 0;  // derive_seed(study seed, "participant", number)
  std::vector<SessionSpec> sessions;
};

struct Plan {
  std::vector<ParticipantPlan> participants;
  std::size_t session_count() const;
  double simulated_seconds() const;  // sum of all session durations
  // The participant with this id; InputError naming --participant and the plan's ids if none.
  const ParticipantPlan& participant(const std::string& id) const;
};

Plan make_plan(const Study& study);

// One screen: study, groups, timeline (day, offset, duration, prototype, cues), seeds.
std::string plan_summary(const Study& study, const Plan& plan);

}  // namespace palplab::protocols
