#include "engine/haptics/press.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace palplab::engine {

const char* to_string(PressPhase p) {
  switch (p) {
    case PressPhase::approach:
      return "approach";
    case PressPhase::hold:
      return "hold";
    case PressPhase::withdraw:
      return "withdraw";
    case PressPhase::release:
      return "release";
    case PressPhase::done:
      return "done";
  }
  return "?";
}

PressDevice::PressDevice(const PressSpec& spec) : spec_(spec), depth_(-spec.start_offset) {
  if (!(spec.depth >= 0.0) || !std::isfinite(spec.depth))
    throw std::invalid_argument("press: the target depth must be >= 0 m (0 = force control)");
  if (spec.depth == 0.0 && (!(spec.force > 0.0) || !std::isfinite(spec.force)))
    throw std::invalid_argument("press: the target force must be a positive number of N");
  if (!(spec.force_error > -1.0) || !std::isfinite(spec.force_error))
    throw std::invalid_argument("press: the force judgement error must be > -1");
  if (!(spec.hold >= 0.0) || !(spec.release >= 0.0) || !std::isfinite(spec.hold + spec.release))
    throw std::invalid_argument("press: hold and release times must be >= 0 s");
  if (!(spec.approach_speed > 0.0) || !(spec.withdraw_speed > 0.0))
    throw std::invalid_argument("press: speeds must be > 0 m/s");
  if (!spec.point.allFinite() || !(std::abs(spec.normal.norm() - 1.0) < 1e-6))
    throw std::invalid_argument("press: point must be finite and the normal a unit vector");
  if (!(spec.hold_speed_in > 0.0) || !(spec.hold_speed_out > 0.0) ||
      !std::isfinite(spec.hold_speed_in + spec.hold_speed_out))
    throw std::invalid_argument("press: the hold's depth rate limits must be > 0 m/s");
  if (!spec.slide.allFinite()) throw std::invalid_argument("press: slide must be finite (m/s)");
  for (size_t i = 0; i < spec.segments.size(); ++i) {
    const PressSegment& g = spec.segments[i];
    const std::string at = "press: segment " + std::to_string(i) + ": ";
    if (!g.by.allFinite()) throw std::invalid_argument(at + "the slide must be finite (m)");
    if (g.is_slide() && !(g.speed > 0.0 && std::isfinite(g.speed)))
      throw std::invalid_argument(at + "a slide needs a speed > 0 m/s");
    if (!g.is_slide() && !(g.hold >= 0.0 && std::isfinite(g.hold)))
      throw std::invalid_argument(at + "a hold must last >= 0 s");
    slides_ = slides_ || g.is_slide();
  }
  slides_ = slides_ || !spec.slide.isZero(0.0);
}

bool PressDevice::target_reached(double f) const {
  if (spec_.depth > 0.0) return depth_ >= spec_.depth;
  return f * (1.0 + spec_.force_error) >= spec_.force;
}

void PressDevice::reach_target(double t, double f, double dt) {
  time_to_force_ = t;
  // The hold controller's first stiffness estimate: the secant measured on the way in.
  const double k = f / std::max(depth_ - std::max(contact_depth_, 0.0), 1e-5);
  stiffness_ = stiffness_in_ = std::max(k, 1.0);
  hist_n_ = 0;
  phase_ = spec_.stop_at_target ? PressPhase::done : PressPhase::hold;
  phase_start_ = t;
  if (phase_ == PressPhase::hold && !spec_.segments.empty()) {
    segment_base_ = offset_;
    segment_step_ = 0;
    if (!next_segment_step(dt)) {  // segments of no duration: the next step withdraws
      phase_ = PressPhase::withdraw;
      depth_ -= spec_.withdraw_speed * dt;
    }
  }
}

namespace {
// The hold's force controller (see PressDevice::hold_force). Measured on the benches' presses
// (docs/ARCHITECTURE.md, "Press force control").
constexpr double kLoopGain = 0.3;        // fraction of the force error corrected per step
constexpr double kMinExcitation = 1e-6;  // m, smallest second difference of depth used
constexpr double kMaxRatio = 2.0;        // one measurement moves the estimate at most 2x...
constexpr double kFilter = 0.3;          // ...and counts with this weight (geometric mean)
constexpr double kRange = 10.0;          // estimate within [1/10, 10] x the approach's
}  // namespace

void PressDevice::hold_force(const Eigen::Vector3d& force, double dt) {
  const double f = force.norm();
  const double depth_before = depth_;
  // The depth that produced f is depth_ (read() gave it for this step).
  hist_d_[2] = hist_d_[1], hist_f_[2] = hist_f_[1];
  hist_d_[1] = hist_d_[0], hist_f_[1] = hist_f_[0];
  hist_d_[0] = depth_, hist_f_[0] = f;
  if (++hist_n_ >= 3) {
    // Second differences: a force drift of constant rate (a slide over a slope, the tissue
    // creeping) cancels, so what is left is the response to the change of the depth steps.
    const double dd = (hist_d_[0] - hist_d_[1]) - (hist_d_[1] - hist_d_[2]);
    const double df = (hist_f_[0] - hist_f_[1]) - (hist_f_[1] - hist_f_[2]);
    // No update without excitation (a settled hold), nor from a force that moved against the
    // depth (a disturbance: a contact change, the tissue's own motion; it tells nothing of
    // the stiffness).
    if (std::abs(dd) > kMinExcitation && df / dd > 0.0) {
      const double k = std::clamp(df / dd, stiffness_ / kMaxRatio, stiffness_ * kMaxRatio);
      stiffness_ = std::clamp(stiffness_ * std::pow(k / stiffness_, kFilter),
                              stiffness_in_ / kRange, stiffness_in_ * kRange);
    }
  }
  const double step = kLoopGain / stiffness_ * (spec_.force - f);
  depth_ += std::clamp(step, -spec_.hold_speed_out * dt, spec_.hold_speed_in * dt);
  // Never back out past the start point nor in past max_depth.
  depth_ = std::min(std::max(depth_, -spec_.start_offset), spec_.max_depth);
  // A sliding press moves its depth along the force it feels (the contact normal where the probe
  // is), not along the start normal: see PressSpec::slide.
  if (slides_ && f > 0.0 && std::isfinite(f))
    lift_ += (depth_ - depth_before) * (spec_.normal - force / f);
}

void PressDevice::begin_withdraw(double t, const Eigen::Vector3d& f) {
  phase_ = PressPhase::withdraw;
  phase_start_ = t;
  // A press that slid lifts off along the force it feels (the outward contact normal where the
  // probe is now). Backing out along the start normal instead pushed C's body slide deeper
  // into the body's curved flank: the depth along the contact normal grew from 3.5 to 12 mm
  // and the force to the device's 8.5 N limit while the script "withdrew".
  const double fn = f.norm();
  if (!offset_.isZero(0.0) && fn > 0.0 && std::isfinite(fn)) out_dir_ = f / fn;
  clear_ = 0.0;
}

bool PressDevice::next_segment_step(double dt) {
  const double tau = static_cast<double>(++segment_step_) * dt;
  // A step whose end is within a millionth of a step of a segment's end belongs to it (tau is
  // a multiple of dt that rounding may put just past the end).
  const double eps = 1e-6 * dt;
  double begin = 0.0;
  Eigen::Vector3d done = segment_base_;  // offset after the segments before i
  for (size_t i = 0; i < spec_.segments.size(); ++i) {
    const PressSegment& g = spec_.segments[i];
    const double d = g.duration();
    if (tau <= begin + d + eps) {
      segment_ = static_cast<int>(i);
      offset_ =
          g.is_slide() ? Eigen::Vector3d(done + std::min(1.0, (tau - begin) / d) * g.by) : done;
      return true;
    }
    begin += d;
    done += g.by;
  }
  segment_ = -1;
  offset_ = done;
  return false;
}

DeviceInput PressDevice::read(double t) {
  t_ = t;
  DeviceInput in;
  in.position = position();
  return in;
}

void PressDevice::write(const Rendered& r) {
  const double dt = std::max(r.t - t_, 1e-6);  // the step just taken
  const double f = r.force.norm();
  switch (phase_) {
    case PressPhase::approach:
      if (f > 0.0 && contact_depth_ < 0.0) contact_depth_ = std::max(depth_, 0.0);
      if (target_reached(f)) {
        reach_target(r.t, f, dt);
        break;
      }
      depth_ += spec_.approach_speed * dt;
      if (spec_.depth > 0.0) depth_ = std::min(depth_, spec_.depth);
      if (depth_ > spec_.max_depth || r.t > spec_.max_approach_time) {
        // target not reachable: give up, withdraw (or end a script that stops at the target)
        if (spec_.stop_at_target) {
          phase_ = PressPhase::done;
          phase_start_ = r.t;
        } else {
          begin_withdraw(r.t, r.force);
        }
      }
      break;
    case PressPhase::hold:
      if (spec_.segments.empty()) {
        if (r.t - phase_start_ >= spec_.hold - 1e-12) {
          begin_withdraw(r.t, r.force);
          break;
        }
        if (spec_.depth == 0.0 && !spec_.hold_depth) hold_force(r.force, dt);
        offset_ += spec_.slide * dt;
        break;
      }
      if (spec_.depth == 0.0 && !spec_.hold_depth) hold_force(r.force, dt);
      if (next_segment_step(dt)) break;
      // The step after the last segment is the first of the withdrawal.
      begin_withdraw(r.t, r.force);
      [[fallthrough]];
    case PressPhase::withdraw: {
      // Along out_dir_ instead of `normal` (a slid press): the same distance per step.
      const bool slid = !out_dir_.isZero(0.0);
      if (slid) {
        lift_ += std::clamp(depth_ + spec_.start_offset, 0.0, spec_.withdraw_speed * dt) *
                 (out_dir_ - spec_.normal);
        clear_ = f > 0.0 ? 0.0 : clear_ + spec_.withdraw_speed * dt;
      }
      depth_ -= spec_.withdraw_speed * dt;
      if (depth_ <= -spec_.start_offset) {
        depth_ = -spec_.start_offset;
        phase_ = PressPhase::release;
        phase_start_ = r.t;
      } else if (slid && f == 0.0 && clear_ >= spec_.start_offset * (1 - 1e-9)) {
        // A slid press ends its withdrawal start_offset beyond where it left the surface, as a
        // still press does: its depth includes the slide's path, and backing all of it out
        // carried the probe past the surface it left into the next one (C's left ovary: off
        // the ovary, then 4 cm on into the horn, 5.8 N during the "withdrawal").
        phase_ = PressPhase::release;
        phase_start_ = r.t;
      }
      break;
    }
    case PressPhase::release:
      if (r.t - phase_start_ >= spec_.release - 1e-12) phase_ = PressPhase::done;
      break;
    case PressPhase::done:
      break;
  }
}

int press_node(const SceneGeometry& g, const std::string& what) {
  if (g.region_index(what) >= 0) return g.region_node(what);
  const bool digits =
      !what.empty() && what.size() < 10 &&
      std::all_of(what.begin(), what.end(), [](char c) { return c >= '0' && c <= '9'; });
  const int node = digits ? std::stoi(what) : -1;
  if (node < 0 || node >= g.V.rows()) {
    std::string names;
    for (const auto& r : g.region_names) names += (names.empty() ? "" : ", ") + r;
    throw std::invalid_argument(
        "\"" + what + "\" is neither a region (" + (names.empty() ? "this mesh has none" : names) +
        ") nor a node index in [0, " + std::to_string(g.V.rows() - 1) + "]");
  }
  return node;
}

PressSpec press_at(const SceneGeometry& g, int node, double force, double hold, double release) {
  PressSpec s;
  s.point = g.V.row(node).transpose();
  s.normal = g.N.row(node).transpose().normalized();
  s.force = force;
  s.hold = hold;
  s.release = release;
  return s;
}

PressSpec sliding_press(const SceneGeometry& g, const std::string& region, double force,
                        double speed, double* length) {
  const int id = g.region_index(region);
  if (id < 0) throw std::invalid_argument("sliding press: unknown region \"" + region + "\"");
  std::vector<long> nodes;
  for (long i = 0; i < g.V.rows(); ++i)
    if (g.vertex_region[i] == id) nodes.push_back(i);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (long i : nodes) mean += g.V.row(i).transpose();
  mean /= static_cast<double>(std::max<size_t>(nodes.size(), 1));
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (long i : nodes) {
    const Eigen::Vector3d d = g.V.row(i).transpose() - mean;
    C += d * d.transpose();
  }
  const Eigen::Vector3d axis =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(C).eigenvectors().col(2);  // largest
  double lo = 1e300, hi = -1e300;
  for (long i : nodes) {
    const double a = axis.dot(g.V.row(i).transpose() - mean);
    lo = std::min(lo, a), hi = std::max(hi, a);
  }
  if (length) *length = hi - lo;
  const int node = g.nearest_node(mean + (lo + 0.1 * (hi - lo)) * axis);
  PressSpec p = press_at(g, node, force, 0.8 * (hi - lo) / speed, 0.0);
  p.slide = speed * (axis - axis.dot(p.normal) * p.normal).normalized();
  return p;
}

}  // namespace palplab::engine
