#pragma once
// One session of a needle-insertion task (Study::task.kind == "needle_insertion") with the
// virtual trainee of protocols/participants/needle.hpp, driven in lock-step like a palpation
// session (protocols/runner.cpp builds the scene and stores the result). The trainee's tool
// commands go to Scene::set_tool each step (finger while palpating, then the needle along its
// aimed axis); measures come from the logged events (compute_needle_measures).
#include <string>
#include <vector>

#include "engine/haptics/devices/trace_device.hpp"
#include "engine/haptics/scene.hpp"
#include "protocols/participants/model.hpp"
#include "protocols/plan.hpp"
#include "protocols/study.hpp"
#include "results/store.hpp"

namespace palplab::protocols {

struct NeedleSessionRun {
  results::SessionData data;  // events, measures (and samples when kept)
  long steps = 0;
  double wall = 0.0;        // s
  std::vector<float> loop;  // s, timed step durations (every 8th step)
  participants::TraineeState state_after;
  // With record_track: the device track as a person's device would give it (exact positions,
  // buttons bit 1 = the needle, the stylus axis), so that `run --human --device trace:FILE`
  // replays the session (the stored samples hold neither the tool nor the axis).
  engine::Trace track;
};

NeedleSessionRun run_needle_session(const Study& study, const participants::TraineeParams& params,
                                    std::uint64_t participant_seed, const SessionSpec& spec,
                                    const participants::TraineeState& before, engine::Scene& scene,
                                    bool keep_samples, bool record_track = false);

}  // namespace palplab::protocols
