#include "protocols/participants/needle.hpp"

#include <algorithm>
#include <cmath>

#include "common/seed.hpp"

namespace palplab::protocols::participants {

namespace {

// A unit vector orthogonal to n and its complement: the skin's tangent plane.
void tangents(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2) {
  const Eigen::Vector3d a =
      std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  t1 = n.cross(a).normalized();
  t2 = n.cross(t1).normalized();
}

constexpr double kHover = 0.01;          // m above the skin between palpations
constexpr double kStandOff = 0.005;      // m outside the skin where an insertion starts
constexpr double kWithdrawFactor = 4.0;  // withdrawing is faster than inserting

}  // namespace

NeedleTrainee::NeedleTrainee(const TraineeParams& params, TraineeState state)
    : p_(params), s_(state) {}

void NeedleTrainee::begin_session(const SurfaceView& view, const NeedleBriefing& briefing,
                                  std::uint64_t participant_seed, std::uint64_t seed) {
  view_ = view;
  brief_ = briefing;
  rng_ = Rng(derive_seed(seed, "needle-trainee"));
  const auto& V = *view_.V;
  const auto& N = *view_.N;
  auto nearest = [&](const Eigen::Vector3d& q) {
    int best = 0;
    double bd = (V.row(0).transpose() - q).squaredNorm();
    for (long i = 1; i < V.rows(); ++i) {
      const double d = (V.row(i).transpose() - q).squaredNorm();
      if (d < bd) {
        bd = d;
        best = static_cast<int>(i);
      }
    }
    return best;
  };
  if (s_.depth_var <= 0.0) {
    // The briefing, remembered with an individual error that stays with the person.
    Rng b(derive_seed(participant_seed, "needle-briefing"));
    const double sd = p_.depth_prior_cv * briefing.target_depth;
    s_.depth_mean = std::max(0.002, briefing.target_depth + sd * b.normal());
    s_.depth_var = std::max(sd * sd, 1e-10);
    const int c = nearest(briefing.entry);
    Eigen::Vector3d t1, t2;
    tangents(N.row(c).transpose().normalized(), t1, t2);
    s_.place = V.row(c).transpose() + p_.spatial_prior_sd * (b.normal() * t1 + b.normal() * t2);
    s_.place_sd = p_.spatial_prior_sd;
  }
  // The palpation grid around the believed entry point, in its tangent plane.
  const int c = nearest(s_.place);
  Eigen::Vector3d t1, t2;
  tangents(N.row(c).transpose().normalized(), t1, t2);
  const int g = std::max(1, static_cast<int>(std::lround(p_.palpation_grid)));
  grid_.clear();
  judged_.clear();
  for (int i = 0; i < g; ++i)
    for (int j = 0; j < g; ++j) {
      const Eigen::Vector3d q =
          V.row(c).transpose() +
          p_.palpation_spacing * ((i - 0.5 * (g - 1)) * t1 + (j - 0.5 * (g - 1)) * t2);
      grid_.push_back(nearest(q));
    }
  gi_ = 0;
  pos_ = view_.start_position;
  tool_ = "finger";
  insertions_ = 0;
  seen_target_ = false;
  closest_ = -1.0;
  misses_.clear();
  chosen_ = -1;
  last_t_ = 0.0;
  next_palpation();
}

void NeedleTrainee::next_palpation() {
  if (gi_ >= grid_.size()) {
    // The softest point: bone lies deepest there (the gap between the bony prominences).
    const auto it = std::min_element(judged_.begin(), judged_.end());
    chosen_ = grid_[it - judged_.begin()];
    start_insertion();
    return;
  }
  const int v = grid_[gi_];
  n_ = view_.N->row(v).transpose().normalized();
  goal_ = view_.V->row(v).transpose() + kHover * n_;
  peak_felt_ = 0.0;
  mode_ = Mode::travel;
}

void NeedleTrainee::end_insertion() {
  if (closest_ >= 0.0 && !seen_target_) misses_.push_back({closest_depth_, closest_});
  closest_ = -1.0;
}

void NeedleTrainee::start_insertion() {
  end_insertion();
  if (insertions_ >= static_cast<int>(std::lround(p_.max_insertions))) {
    stop();
    return;
  }
  ++insertions_;
  const Eigen::Vector3d n = view_.N->row(chosen_).transpose().normalized();
  Eigen::Vector3d t1, t2;
  tangents(n, t1, t2);
  entry_ = view_.V->row(chosen_).transpose() +
           p_.aim_position_sd * (rng_.normal() * t1 + rng_.normal() * t2);
  axis_ = (-n + p_.aim_angle_sd * (rng_.normal() * t1 + rng_.normal() * t2)).normalized();
  tool_ = "needle";
  goal_ = entry_ - kStandOff * axis_;
  depth_ = -kStandOff;
  stop_depth_ = s_.depth_mean;
  run_peak_ = 0.0;
  mode_ = Mode::approach;
}

void NeedleTrainee::stop() {
  end_insertion();
  mode_ = Mode::done;
}

ToolCommand NeedleTrainee::command(double t) {
  const double dt = std::max(0.0, t - last_t_);
  last_t_ = t;
  auto move_to = [&](const Eigen::Vector3d& to, double speed) {
    const Eigen::Vector3d d = to - pos_;
    const double step = speed * dt;
    if (d.norm() <= step) {
      pos_ = to;
      return true;
    }
    pos_ += d.normalized() * step;
    return false;
  };
  switch (mode_) {
    case Mode::travel:
      if (move_to(goal_, p_.explore_speed)) mode_ = Mode::press;
      break;
    case Mode::press: {
      const int v = grid_[gi_];
      const Eigen::Vector3d bottom = view_.V->row(v).transpose() - p_.palpation_depth * n_;
      if (move_to(bottom, p_.palpation_speed)) {
        judged_.push_back(peak_felt_ * (1.0 + p_.weber_fraction * rng_.normal()));
        mode_ = Mode::lift;
      }
      break;
    }
    case Mode::lift:
      if (move_to(goal_, p_.palpation_speed)) {
        ++gi_;
        next_palpation();
      }
      break;
    case Mode::approach:
      if (move_to(goal_, p_.explore_speed)) mode_ = Mode::insert;
      break;
    case Mode::insert:
      depth_ += p_.needle_speed * dt;
      pos_ = entry_ + depth_ * axis_;
      break;
    case Mode::withdraw:
      depth_ -= kWithdrawFactor * p_.needle_speed * dt;
      pos_ = entry_ + depth_ * axis_;
      if (depth_ <= -kStandOff) start_insertion();
      break;
    case Mode::done:
      break;
  }
  return {pos_, tool_, axis_};
}

void NeedleTrainee::perceive(const Percept& p) {
  if (mode_ == Mode::press) {
    peak_felt_ = std::max(peak_felt_, p.force.norm());
    return;
  }
  if (mode_ != Mode::insert) return;
  const double felt = -p.force.dot(axis_);  // N, resisting the insertion
  const bool visible = p.visible_tip_to_target >= 0.0;
  if (visible && depth_ > 0.0 && (closest_ < 0.0 || p.visible_tip_to_target < closest_)) {
    closest_ = p.visible_tip_to_target;
    closest_depth_ = depth_;
  }
  if (visible) {
    if (p.visible_tip_to_target == 0.0) {  // the tip is seen inside the target
      seen_target_ = true;
      seen_depth_ = depth_;
      stop();
      return;
    }
  }
  if (felt >= p_.bone_stop_force) {  // a hard stop without a pop: bone
    mode_ = Mode::withdraw;
    return;
  }
  if (run_peak_ - felt >= p_.pop_drop) {  // a pop: something gave way
    if (!visible && std::abs(depth_ - stop_depth_) <= p_.pop_window * stop_depth_) {
      stop();  // loss of resistance near the expected depth: the capsule
      return;
    }
    run_peak_ = felt;
  }
  run_peak_ = std::max(run_peak_, felt);
  // Opaque: stop at the believed depth. Seen: go on while the tip approaches the target; a tip
  // seen well past the believed depth has missed it: pull out and aim again.
  if (!visible && depth_ >= stop_depth_) stop();
  if (visible && depth_ >= stop_depth_ * (1.0 + 2.0 * p_.pop_window) + 0.005)
    mode_ = Mode::withdraw;
}

void NeedleTrainee::end_session(double study_time) {
  if (mode_ != Mode::done) end_insertion();  // the session ended during an insertion
  auto merge = [&](double depth, double extra_var) {
    const double obs_var = p_.visual_spatial_sd * p_.visual_spatial_sd + extra_var;
    const double obs = depth + p_.visual_spatial_sd * rng_.normal();
    const double k = s_.depth_var / (s_.depth_var + obs_var);
    s_.depth_mean += k * (obs - s_.depth_mean);
    s_.depth_var *= (1.0 - k);
  };
  // Visible misses: the closest approach's depth, less certain the wider the miss.
  for (const auto& [depth, r] : misses_) merge(depth, r * r);
  misses_.clear();
  // The depth at which the tip was seen to reach the target.
  if (seen_target_) merge(seen_depth_, 0.0);
  s_.last_session_end = study_time;
}

}  // namespace palplab::protocols::participants
