#include "protocols/needle_session.hpp"

#include <chrono>
#include <cmath>

#include "common/input_error.hpp"
#include "protocols/measures.hpp"
#include "protocols/participants/needle.hpp"

namespace palplab::protocols {

namespace pm = participants;

NeedleSessionRun run_needle_session(const Study& study, const pm::TraineeParams& params,
                                    std::uint64_t participant_seed, const SessionSpec& spec,
                                    const pm::TraineeState& before, engine::Scene& scene,
                                    bool keep_samples) {
  using Clock = std::chrono::steady_clock;
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
  constexpr long kTimedEvery = 8;  // as the palpation sessions (runner.cpp)
  out.loop.reserve(steps / kTimedEvery + 1);
  const auto wall0 = Clock::now();
  std::string tool = scene.tool();
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  for (long i = 0; i < steps; ++i) {
    const double t = (i + 1) * dt;
    const pm::ToolCommand cmd = trainee.command(t);
    const bool timed = i % kTimedEvery == 0;
    const auto a = timed ? Clock::now() : Clock::time_point{};
    if (cmd.tool != tool || cmd.axis != axis) {
      scene.set_tool(cmd.tool, cmd.axis);
      tool = cmd.tool;
      axis = cmd.axis;
    }
    const engine::Rendered r = scene.step(cmd.x);
    if (timed) out.loop.push_back(std::chrono::duration<float>(Clock::now() - a).count());
    samples.x.insert(samples.x.end(), {cmd.x.x(), cmd.x.y(), cmd.x.z()});
    samples.F.insert(samples.F.end(), {r.force.x(), r.force.y(), r.force.z()});
    samples.node.push_back(r.contact_node);
    for (const auto& e : r.events)
      out.data.events.push_back({e.t, engine::to_string(e.kind), e.value,
                                 e.region >= 0 && e.region < static_cast<int>(g.region_names.size())
                                     ? g.region_names[e.region]
                                     : std::string()});
    pm::Percept p;
    p.t = r.t;
    p.force = r.force;
    p.contact = r.contact;
    p.contact_region = r.contact_region;
    p.visible_deformation = r.visible_deformation;
    p.audio = r.audio;
    p.visible_tip_to_target = r.visible_tip_to_target;
    p.visible_tip_tissue = r.visible_tip_tissue;
    trainee.perceive(p);
  }
  out.wall = std::chrono::duration<double>(Clock::now() - wall0).count();
  trainee.end_session(spec.offset + spec.duration);
  out.steps = steps;
  out.data.measures = compute_needle_measures(out.data.events);
  if (keep_samples) out.data.samples = std::move(samples);
  out.state_after = trainee.state();
  return out;
}

}  // namespace palplab::protocols
