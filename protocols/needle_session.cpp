#include "protocols/needle_session.hpp"

#include <chrono>
#include <cmath>

#include "common/input_error.hpp"
#include "engine/haptics/clock.hpp"
#include "protocols/measures.hpp"
#include "protocols/participants/needle.hpp"

namespace palplab::protocols {

namespace pm = participants;

namespace {

using Clock = std::chrono::steady_clock;

// The virtual trainee as the session's device under engine::run_lockstep: read() is the
// trainee's command for the step about to run, its tool and axis set on the scene before the
// step when they change (as engine::ToolSwitchDevice does for a person's device); write() is
// what the trainee perceives of the step. The command time is the step's end, (k + 1) dt with k
// counted here (not scene.time() + dt, which can differ in the last bit), so a session is
// bit-identical to the hand-written loop this replaced.
class TraineeDevice : public engine::Device {
 public:
  static constexpr long kTimedEvery = 8;  // as the palpation sessions (runner.cpp)
  TraineeDevice(pm::NeedleTrainee& trainee, engine::Scene& scene, std::vector<float>& loop,
                engine::Trace* track)
      : trainee_(trainee),
        scene_(scene),
        loop_(loop),
        track_(track),
        tool_(scene.tool()),
        dt_(scene.dt()) {}

  engine::DeviceInput read(double) override {
    const pm::ToolCommand cmd = trainee_.command(static_cast<double>(k_ + 1) * dt_);
    timed_ = k_ % kTimedEvery == 0;
    ++k_;
    // Timed: the tool change and the step (this read's end to the write).
    if (timed_) t0_ = Clock::now();
    if (cmd.tool != tool_ || cmd.axis != axis_) {
      scene_.set_tool(cmd.tool, cmd.axis);
      tool_ = cmd.tool;
      axis_ = cmd.axis;
    }
    engine::DeviceInput in;
    in.position = x_ = cmd.x;
    // What a person's device gives for the same command (engine::ToolSwitchDevice reads it);
    // the scene ignores it here (the tool is set above), the recorded track keeps it.
    in.buttons = cmd.tool == "needle" ? engine::kNeedleToolButton : 0u;
    in.button = (in.buttons & 1u) != 0;
    in.stylus_axis = cmd.axis;
    if (track_) track_->samples.push_back({static_cast<double>(k_ - 1) * dt_, in});
    return in;
  }
  const Eigen::Vector3d& last_position() const { return x_; }  // the command of the last read
  void write(const engine::Rendered& r) override {
    if (timed_) loop_.push_back(std::chrono::duration<float>(Clock::now() - t0_).count());
    trainee_.perceive(pm::percept_of(r));
  }

 private:
  pm::NeedleTrainee& trainee_;
  engine::Scene& scene_;
  std::vector<float>& loop_;
  engine::Trace* track_;
  std::string tool_;
  Eigen::Vector3d axis_ = Eigen::Vector3d::Zero(), x_ = Eigen::Vector3d::Zero();
  double dt_;
  long k_ = 0;
  bool timed_ = false;
  Clock::time_point t0_;
};

}  // namespace

NeedleSessionRun run_needle_session(const Study& study, const pm::TraineeParams& params,
                                    std::uint64_t participant_seed, const SessionSpec& spec,
                                    const pm::TraineeState& before, engine::Scene& scene,
                                    bool keep_samples, bool record_track) {
  const engine::SceneGeometry& g = scene.geometry();
  if (scene.tool() == "probe")
    throw InputError("prototype \"" + spec.prototype + "\" (model \"" + scene.model_kind() +
                         "\") has no finger and needle tools; a needle_insertion task needs "
                         "model \"needle\"",
                     spec.prototype_file);
  pm::SurfaceView view;
  view.V = &g.V;
  view.N = &g.N;
  view.vertex_region = &g.vertex_region;
  view.feature_region = g.region_index(study.task.feature);
  view.start_position = g.start_position;
  pm::NeedleBriefing brief;
  brief.entry = study.task.entry_hint;
  brief.target_depth = study.task.target_depth_hint;

  pm::NeedleTrainee trainee(params, before);
  trainee.begin_session(view, brief, participant_seed, spec.seed);

  NeedleSessionRun out;
  const double dt = scene.dt();
  const long steps = std::lround(spec.duration / dt);
  results::SampleSeries samples;
  samples.t0 = 0.0;
  samples.dt = dt;
  samples.x.reserve(3 * steps);
  samples.F.reserve(3 * steps);
  samples.node.reserve(steps);
  out.loop.reserve(steps / TraineeDevice::kTimedEvery + 1);
  if (record_track) out.track.samples.reserve(steps);
  TraineeDevice device(trainee, scene, out.loop, record_track ? &out.track : nullptr);
  engine::LockstepOptions lo;
  lo.duration = spec.duration;
  lo.frame_period = 0.0;
  const auto wall0 = Clock::now();
  engine::run_lockstep(scene, device, lo, [&](const engine::Rendered& r, const engine::Sample&) {
    const Eigen::Vector3d& x = device.last_position();
    samples.x.insert(samples.x.end(), {x.x(), x.y(), x.z()});
    samples.F.insert(samples.F.end(), {r.force.x(), r.force.y(), r.force.z()});
    samples.node.push_back(r.contact_node);
    for (const auto& e : r.events)
      out.data.events.push_back({e.t, engine::to_string(e.kind), e.value,
                                 e.region >= 0 && e.region < static_cast<int>(g.region_names.size())
                                     ? g.region_names[e.region]
                                     : std::string()});
  });
  out.wall = std::chrono::duration<double>(Clock::now() - wall0).count();
  trainee.end_session(spec.offset + spec.duration);
  out.steps = steps;
  out.data.measures = compute_needle_measures(out.data.events);
  if (keep_samples) out.data.samples = std::move(samples);
  out.state_after = trainee.state();
  return out;
}

}  // namespace palplab::protocols
