#include "protocols/participants/model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "common/json_check.hpp"
#include "common/seed.hpp"
#include "engine/haptics/scene.hpp"

namespace palplab::protocols::participants {

Percept percept_of(const engine::Rendered& r) {
  Percept p;
  p.t = r.t;
  p.force = r.force;
  p.contact = r.contact;
  p.contact_region = r.contact_region;
  p.visible_deformation = r.visible_deformation;
  p.visible_volume = r.visible_volume;
  p.audio = r.audio;
  p.visible_tip_to_target = r.visible_tip_to_target;
  p.visible_tip_tissue = r.visible_tip_tissue;
  return p;
}

double seen_deformation(double d, double v, double w) {
  if (!(w > 0.0)) return d;
  if (!(d > 0.0) || !(v > 0.0)) return 0.0;
  return std::pow(d, 1.0 - w) * std::pow(v / kSeenVolumeArea, w);
}

namespace {
// The combination over an array (the per-step percept uses a stack array: no allocation).
Estimate combine(const Estimate* in, std::size_t n, std::vector<double>* weights) {
  double inv_sum = 0.0, acc = 0.0;
  for (std::size_t i = 0; i < n; ++i) inv_sum += 1.0 / in[i].variance;
  for (std::size_t i = 0; i < n; ++i) acc += in[i].value / in[i].variance;
  if (weights) {
    weights->clear();
    for (std::size_t i = 0; i < n; ++i) weights->push_back((1.0 / in[i].variance) / inv_sum);
  }
  return {acc / inv_sum, 1.0 / inv_sum};
}
}  // namespace

Estimate mle_combine(const std::vector<Estimate>& in, std::vector<double>* weights) {
  return combine(in.data(), in.size(), weights);
}

double retention(double dt, const TraineeParams& p) {
  if (dt <= 0) return 1.0;
  const double tau = p.forgetting_tau, d = p.forgetting_exponent;
  const double tc = p.consolidation_time, f = p.consolidated_factor;
  if (dt <= tc) return std::pow(1.0 + dt / tau, -d);
  // Up to consolidation the full exponent, after it a reduced one (continuous at tc).
  return std::pow(1.0 + tc / tau, -d) * std::pow((1.0 + dt / tau) / (1.0 + tc / tau), -d * f);
}

nlohmann::json TraineeState::to_json() const {
  return {{"initialised", initialised},
          {"target_mean", target_mean},
          {"target_var", target_var},
          {"prior_mean", prior_mean},
          {"prior_var", prior_var},
          {"place", {place.x(), place.y(), place.z()}},
          {"place_sd", place_sd},
          {"k_hat", k_hat},
          {"k_count", k_count},
          {"k_felt_sum", k_felt_sum},
          {"k_seen_sum", k_seen_sum},
          {"feedback_count", feedback_count},
          {"last_session_end", last_session_end},
          {"demo_sound", demo_sound},
          {"demo_d", demo_d},
          {"reliance", reliance},
          {"finds", finds},
          {"speed_factor", speed_factor},
          {"overshoot_factor", overshoot_factor},
          {"k_log_sum", k_log_sum},
          {"k_log_sq", k_log_sq},
          {"landmark_practice", landmark_practice},
          {"depth_mean", depth_mean},
          {"depth_var", depth_var}};
}

TraineeState TraineeState::from_json(const nlohmann::json& j, palplab::json::Checker& c) {
  TraineeState s;
  const std::string R = "$";
  if (!c.expect_object(j, R)) return s;
  // Each number in the bounds the model can produce, generously: a state edited to a negative
  // variance or a speed factor of 1e300 would be simulated from silently. Keys added after the
  // first states were written are optional (their defaults: the state before the mechanism).
  constexpr double kForce = 1e6, kLength = 1e3, kTime = 1e12, kBig = 1e300;
  auto num = [&](const char* key, double lo, double hi, const char* what, double& into,
                 bool required = true) {
    if (auto v = c.number(j, R, key, required, lo, hi, what)) into = *v;
  };
  auto count = [&](const char* key, const char* what, int& into, bool required = true) {
    if (auto v = c.integer(j, R, key, required, 0, 1000000000, what)) into = static_cast<int>(*v);
  };
  if (auto v = c.boolean(j, R, "initialised", true)) s.initialised = *v;
  num("target_mean", -kForce, kForce, "the target force believed (N)", s.target_mean);
  num("target_var", 0, kForce * kForce, "its variance (N²)", s.target_var);
  num("prior_mean", -kForce, kForce, "the briefed target force (N)", s.prior_mean);
  num("prior_var", 0, kForce * kForce, "its variance (N²)", s.prior_var);
  if (auto v =
          c.vec3(j, R, "place", true, -kLength, kLength, "the remembered place of the feature (m)"))
    s.place = {(*v)[0], (*v)[1], (*v)[2]};
  num("place_sd", 0, kLength, "the spread of that memory (m)", s.place_sd);
  num("k_hat", 0, kBig, "the stiffness estimate (N/m)", s.k_hat);
  count("k_count", "the presses the stiffness estimate is made of", s.k_count);
  num("k_felt_sum", 0, kBig, "the sum of felt stiffness", s.k_felt_sum);
  num("k_seen_sum", 0, kBig, "the sum of seen stiffness", s.k_seen_sum);
  count("feedback_count", "the feedback events received", s.feedback_count);
  num("last_session_end", 0, kTime, "the study time of the last session's end (s)",
      s.last_session_end);
  // Added with the guidance / visual-learning mechanisms (older states lack them).
  if (auto v = c.boolean(j, R, "demo_sound")) s.demo_sound = *v;
  num("demo_d", 0, kLength, "the deformation the demonstration showed (m)", s.demo_d, false);
  num("reliance", 0, 1, "the reliance on a marker", s.reliance, false);
  count("finds", "the sessions that found the feature", s.finds, false);
  num("speed_factor", 1e-6, 1e6, "the individual speed factor", s.speed_factor, false);
  num("overshoot_factor", 0, 1e6, "the individual overshoot factor", s.overshoot_factor, false);
  num("k_log_sum", -kBig, kBig, "a sum of log stiffness ratios", s.k_log_sum, false);
  num("k_log_sq", 0, kBig, "a sum of squared log stiffness ratios", s.k_log_sq, false);
  num("landmark_practice", 0, kBig, "the landmark judgements practised", s.landmark_practice,
      false);
  num("depth_mean", -kLength, kLength, "the believed target depth (m)", s.depth_mean, false);
  num("depth_var", 0, kLength * kLength, "its variance (m²)", s.depth_var, false);
  return s;
}

TraineeState TraineeState::from_json(const nlohmann::json& j) {
  const std::string text = j.dump();
  palplab::json::Checker c("trainee state", text);
  TraineeState s = from_json(j, c);
  c.throw_if_any();
  return s;
}

Trainee::Trainee(const TraineeParams& params, TraineeState state) : p_(params), s_(state) {}

void Trainee::begin_session(const SurfaceView& view, double briefed_target, double study_time,
                            double duration, std::uint64_t participant_seed, std::uint64_t seed,
                            Channels channels) {
  (void)duration;
  view_ = view;
  ch_ = channels;
  briefed_ = briefed_target;
  rng_ = Rng(derive_seed(seed, "trainee"));
  aim_rng_ = Rng(derive_seed(seed, "press_aim"));
  press_node_ = -1;
  if (!s_.initialised) {
    // The briefing: the target is told in newtons, but how much force that is to this person
    // is uncertain; the anatomy lesson leaves a rough idea of where the feature lies.
    Rng brief(derive_seed(participant_seed, "briefing"));
    const double cv = p_.prior_target_cv;
    s_.prior_mean = briefed_target * std::max(0.05, 1.0 + cv * brief.normal());
    s_.prior_var = std::pow(cv * briefed_target, 2);
    s_.target_mean = s_.prior_mean;
    s_.target_var = s_.prior_var;
    const double sd = p_.spatial_prior_sd;
    s_.place = view.feature_centroid +
               Eigen::Vector3d(brief.normal(), brief.normal(), brief.normal()) * sd;
    s_.place_sd = sd;
    // Individual differences: one speed factor per person (lognormal, median 1).
    s_.speed_factor = std::exp(p_.individual_cv * brief.normal());
    // The demonstration: a sound on the way to the target says "a sound marks the target"
    // (the trainee will wait for it); a visible deformation at the target is remembered (seen
    // with visual Weber noise) as what the target looks like.
    if (demo_) {
      s_.demo_sound = demo_->sound;
      s_.reliance = demo_->sound ? 1.0 : 0.0;
      // Each press of the demonstration is seen with its own visual Weber noise and the mean of
      // what was seen is kept (ensemble averaging over a sequence, Albrecht & Scholl 2010): the
      // remembered picture's error shrinks with the number of presses shown.
      // What was seen of each press is judged as every press of the trainee's own will be
      // (seen_deformation: the indentation, or with visual_volume_weight the whole picture).
      const double w = p_.visual_volume_weight;
      const auto& sv = demo_->seen_volume;
      if (!demo_->seen.empty()) {
        double sum = 0.0;
        for (std::size_t i = 0; i < demo_->seen.size(); ++i) {
          const double d =
              seen_deformation(demo_->seen[i], i < sv.size() ? sv[i] : demo_->volume, w);
          sum += d * std::max(0.05, 1.0 + p_.visual_weber * brief.normal());
        }
        s_.demo_d = sum / static_cast<double>(demo_->seen.size());
      } else if (demo_->deformation > 0) {
        s_.demo_d = seen_deformation(demo_->deformation, demo_->volume, w) *
                    std::max(0.05, 1.0 + p_.visual_weber * brief.normal());
      }
    }
    // How far this person's press goes on awaiting a marker (lognormal, median 1). Drawn last,
    // so that every draw above is the same whatever overshoot_individual_cv is.
    s_.overshoot_factor = std::exp(p_.overshoot_individual_cv * brief.normal());
    s_.initialised = true;
  } else {
    // Forgetting over the retention interval: the learned part decays back towards what the
    // briefing left, by a power law of the interval (Wixted & Ebbesen 1991). The uncertainty
    // always does; the mean by the share forgetting_contraction (0: kept, Laabs 1973).
    const double r = retention(study_time - s_.last_session_end, p_);
    const double kept = r + (1.0 - p_.forgetting_contraction) * (1.0 - r);  // = r exactly at 1
    s_.target_mean = s_.prior_mean + kept * (s_.target_mean - s_.prior_mean);
    s_.target_var = r * r * s_.target_var + (1.0 - r * r) * s_.prior_var;
    s_.place_sd = std::sqrt(s_.place_sd * s_.place_sd +
                            (1.0 - r * r) * std::pow(p_.spatial_forgetting_sd, 2));
  }
  // An instructed session starts with the instruction "I will tell you when to release": the
  // trainee waits for the call as for a marker it trusts (reliance 1), whether or not the
  // demonstration had a sound. Before 2026-12-02 only a demonstration's sound set this, so in
  // experiment 1 the trainees of A (whose demonstration sounded) waited for the call and those
  // of B and C stopped at their own belief: a trainee briefed low (exp1 C's P13, 1.29 N) never
  // reached the instructor's target and learned nothing in four sessions.
  if (ch_.call) s_.reliance = 1.0;
  pos_ = view.start_position;
  identified_ = false;
  search_k_ = 0;
  probed_.clear();
  presses_ = 0;
  misses_ = 0;
  marker_in_session_ = false;
  dwell_start_ = -1.0;
  release_at_ = -1.0;
  t_prev_ = 0.0;
  prev_landmark_k_ = -1.0;
  last_ = Percept{};
  plan_route();
  next_probe();
}

int Trainee::nearest_node(const Eigen::Vector3d& q) const {
  const auto& V = *view_.V;
  int node = 0;
  double bd = std::numeric_limits<double>::infinity();
  for (int i = 0; i < V.rows(); ++i) {
    const double d = (V.row(i).transpose() - q).squaredNorm();
    if (d < bd) bd = d, node = i;
  }
  return node;
}

void Trainee::plan_route() {
  // Orienting before the search (landmark-based haptic navigation): without seeing where the
  // hand is on the organ, a palpator first finds a place it can identify by touch — where the
  // hand meets the organ — and works its way from there, landmark by landmark, towards where
  // memory puts the feature, judging at each landmark by touch where the hand is (Lederman &
  // Klatzky 1987: a shape is learnt by contour following, the slowest exploratory procedure).
  // The route is the straight line from the first landmark to the believed feature position,
  // one landmark every landmark_spacing, each projected to the nearest surface node. Exploration
  // time thus comes out of the route's length, the time each landmark takes to judge (faster
  // with practice and for faster people) and the search misses after it.
  route_.clear();
  route_i_ = 0;
  if (!(p_.landmark_spacing > 0)) return;
  const int first = nearest_node(view_.start_position);
  const Eigen::Vector3d a = view_.V->row(first).transpose();
  const double len = (s_.place - a).norm();
  const int n = static_cast<int>(std::floor(len / p_.landmark_spacing));
  route_.push_back(first);
  for (int i = 1; i < n; ++i) {
    const int node = nearest_node(a + (s_.place - a) * (static_cast<double>(i) / n));
    if (node != route_.back()) route_.push_back(node);
  }
}

void Trainee::next_probe() {
  if (route_i_ < route_.size()) {
    // The next landmark: reached at explore_speed from the start (a reach), then traced at
    // trace_speed from landmark to landmark.
    const int node = route_[route_i_];
    const Eigen::Vector3d n = view_.N->row(node).transpose().normalized();
    press_dir_ = -n;
    const double speed = route_i_ == 0 ? p_.explore_speed : p_.trace_speed;
    ++route_i_;
    orienting_ = true;
    target_node_ = node;
    start_travel(view_.V->row(node).transpose() + n * p_.lift_height, Mode::descend);
    travel_speed_ = speed;
    return;
  }
  orienting_ = false;
  choose_search_target();
}

void Trainee::choose_search_target() {
  // Probe where memory says the feature is, but not where this session already probed: of 8
  // draws from the spatial belief (SD widened slowly after misses, up to 2.5x), take the surface
  // node that best trades belief density against closeness to the probes already made (a
  // touched place is known to about spatial_memory_sd; inhibition of return, Klein 2000). A
  // node is never probed twice in a session.
  const double sd = s_.place_sd * std::min(1.0 + 0.25 * search_k_, 2.5) + 1e-4;
  const double r = std::max(p_.spatial_memory_sd, 1e-4);
  const auto& V = *view_.V;
  int best = -1, fallback = 0;
  double best_score = -std::numeric_limits<double>::infinity();
  for (int attempt = 0; attempt < 8; ++attempt) {
    Eigen::Vector3d q =
        s_.place + Eigen::Vector3d(rng_.normal(), rng_.normal(), rng_.normal()) * sd;
    const int node = nearest_node(q);
    fallback = node;
    if (std::find(probed_.begin(), probed_.end(), node) != probed_.end()) continue;
    const Eigen::Vector3d x = V.row(node).transpose();
    double dmin2 = std::numeric_limits<double>::infinity();
    for (int k : probed_) dmin2 = std::min(dmin2, (V.row(k).transpose() - x).squaredNorm());
    const double score = -(x - s_.place).squaredNorm() / (2 * sd * sd) +
                         std::log(1.0 - std::exp(-dmin2 / (2 * r * r)) + 1e-12);
    if (score > best_score) best_score = score, best = node;
  }
  if (best < 0) best = fallback;
  probed_.push_back(best);
  target_node_ = best;
  ++search_k_;
  Eigen::Vector3d n = view_.N->row(best).transpose();
  press_dir_ = -n.normalized();
  start_travel(V.row(best).transpose() + n.normalized() * p_.lift_height, Mode::descend);
  travel_speed_ = p_.explore_speed;
}

void Trainee::start_travel(const Eigen::Vector3d& to, Mode next) {
  goal_ = to;
  after_travel_ = next;
  mode_ = Mode::travel;
  mode_start_ = t_prev_;
  travel_len_ = (to - pos_).norm();
}

// Cue reliabilities scale with the stimulus (Weber), not with the noisy sample: a sample that
// happens to be low must not earn itself a small variance (that would bias towards low values).
double Trainee::perceived_force(const Percept& p) const {
  const double F = ch_.haptic ? p.force.norm() : 0.0;
  const double w = p_.weber_fraction;
  Estimate est[2];
  std::size_t n = 0;
  if (ch_.haptic) est[n++] = Estimate{F * (1.0 + eps_h_), std::pow(w * std::max(F, 0.05), 2)};
  if (ch_.visual && p.visible_deformation > 0 && s_.k_hat > 0) {
    const double fv_true = s_.k_hat * p.visible_deformation;
    const double cv2 = std::pow(p_.visual_weber, 2) + w * w / (s_.k_count + 1);
    est[n++] = Estimate{fv_true * (1.0 + eps_v_), cv2 * std::max(fv_true * fv_true, 0.0025)};
  }
  if (n == 0) return 0.0;
  return combine(est, n, nullptr).value;
}

double Trainee::perceived_variance(const Percept& p) const {
  const double F = ch_.haptic ? p.force.norm() : 0.0;
  const double w = p_.weber_fraction;
  Estimate est[2];
  std::size_t n = 0;
  if (ch_.haptic) est[n++] = Estimate{F, std::pow(w * std::max(F, 0.05), 2)};
  if (ch_.visual && p.visible_deformation > 0 && s_.k_hat > 0) {
    const double fv_true = s_.k_hat * p.visible_deformation;
    const double cv2 = std::pow(p_.visual_weber, 2) + w * w / (s_.k_count + 1);
    est[n++] = Estimate{fv_true, cv2 * std::max(fv_true * fv_true, 0.0025)};
  }
  if (n == 0) return 1e6;
  return combine(est, n, nullptr).variance;
}

double Trainee::draw_recognition_time() {
  // Median recognition_time for a novice of average speed, faster with practice (power law over
  // the sessions in which the feature was found) and for faster people; lognormal spread.
  return p_.recognition_time / s_.speed_factor * std::pow(1.0 + s_.finds, -p_.practice_exponent) *
         std::exp(p_.recognition_cv * rng_.normal());
}

double Trainee::draw_landmark_time() {
  // Median landmark_time for a novice of average speed, shortened by the power law of practice
  // (Newell & Rosenbloom 1981) over the landmark judgements made so far; lognormal spread. A
  // judgement during which the touched part visibly deformed counts 1 + visual_recognition_gain
  // times: seeing where one touches confirms the felt landmark and teaches the layout faster
  // (a second, visual cue: Ernst & Banks 2002; vision localises the hand better than
  // proprioception: van Beers et al. 1999). This is how training with visible deformation
  // shortens the later haptic-only search.
  return p_.landmark_time / s_.speed_factor *
         std::pow(1.0 + s_.landmark_practice, -p_.practice_exponent) *
         std::exp(p_.recognition_cv * rng_.normal());
}

bool Trainee::landmark_felt_distinct() {
  // The light touch at a landmark also tells how soft the part is: felt force over the hand's
  // travel since it first touched (pressing to judge hardness: Lederman & Klatzky 1987). A
  // landmark that feels softer or harder than the previous one by more than the stiffness JND
  // (Jones & Hunter 1990: 23 %) is identified by feel as well as by shape, a second haptic cue
  // (counted like a seen judgement: compliance_recognition_gain). A simulator whose surface feels
  // equally stiff everywhere (a penalty contact on a rigid surface) never gives it.
  if (!ch_.haptic || !last_.contact) return false;
  const double travel = (pos_ - touch_pos_).dot(press_dir_), f = last_.force.norm();
  if (!(travel > 0.0) || !(f > 0.0)) return false;
  const double k = f / travel, prev = prev_landmark_k_;
  prev_landmark_k_ = k;
  return prev > 0.0 && std::abs(std::log(k / prev)) > std::log1p(p_.stiffness_weber);
}

void Trainee::learn_target(double observed, double variance, double gain_scale) {
  // Kalman update of the target belief from a cue that marks "target reached"; gain_scale < 1
  // when part of the learning is withheld (guidance).
  const double obs_var = variance + std::pow(p_.memory_noise_cv * std::max(observed, 0.0), 2);
  const double k = gain_scale * s_.target_var / (s_.target_var + obs_var);
  s_.target_mean += k * (observed - s_.target_mean);
  s_.target_var *= (1.0 - k);
  ++s_.feedback_count;
}

void Trainee::learn_lower_bound(double felt, double trust) {
  // Moments of N(m, v) conditioned on  T + e > felt,  e ~ N(0, r) the perceptual error of the
  // felt force (Weber): with s = sqrt(v + r), a = (felt - m)/s and the inverse Mills ratio
  // lambda = phi(a)/(1 - Phi(a)): m' = m + v/s lambda, v' = v (1 - v/s^2 lambda (lambda - a))
  // (the probit update of expectation propagation; Minka 2001, Opper 1998).
  const double r = std::pow(p_.weber_fraction * std::max(felt, 0.05), 2);
  const double v = s_.target_var, s = std::sqrt(v + r);
  if (!(s > 0)) return;
  const double a = (felt - s_.target_mean) / s;
  const double tail = 0.5 * std::erfc(a / std::sqrt(2.0));  // 1 - Phi(a)
  const double phi = std::exp(-0.5 * a * a) / std::sqrt(2.0 * std::numbers::pi);
  // Far in the tail the ratio tends to a (lambda ~ a + 1/a): the asymptote avoids 0/0.
  const double lambda = tail > 1e-12 ? phi / tail : a + 1.0 / a;
  // The missing marker has a second explanation: the cue no longer works (it was withdrawn).
  // With the trust in the cue (for a sound or call the reliance) as prior, the posterior that the
  // cue still works is
  //   w = pi (1 - Phi(a)) / (pi (1 - Phi(a)) + 1 - pi)
  // (no marker is certain when the cue is gone, has probability 1 - Phi(a) when it works), and
  // the belief becomes the moment-matched mixture of "truncated" (w) and "unchanged" (1 - w):
  // a miss well above the believed target says "the cue is gone" and teaches little, a miss
  // below it says "not there yet".
  const double pi = std::clamp(trust, 0.0, 1.0);
  const double w = pi * tail / (pi * tail + (1.0 - pi) + 1e-300);
  const double shift = v / s * lambda;
  const double v_trunc = std::max(v * (1.0 - v / (s * s) * lambda * (lambda - a)), 1e-6 * v);
  s_.target_mean += w * shift;
  s_.target_var = w * v_trunc + (1.0 - w) * v + w * (1.0 - w) * shift * shift;
}

Eigen::Vector3d Trainee::command(double t) {
  const double dt = std::max(0.0, t - t_prev_);
  t_prev_ = t;
  auto move_towards = [&](const Eigen::Vector3d& g, double speed) {
    Eigen::Vector3d d = g - pos_;
    double len = d.norm(), step = speed * dt;
    if (len <= step) {
      pos_ = g;
      return true;
    }
    pos_ += d * (step / len);
    return false;
  };
  // Physiological bound: nobody pushes on against a force far beyond what the task asks for.
  // Above max_force the hand yields along the felt force, whatever it was doing, and a press
  // ends (this also bounds what any other motion can do if it runs into the organ).
  const double felt = ch_.haptic && last_.contact ? last_.force.norm() : 0.0;
  if (felt > p_.max_force) {
    pos_ += last_.force / felt * p_.release_speed * dt;
    if (mode_ == Mode::press || mode_ == Mode::hold) begin_release(t);
    return pos_;
  }
  switch (mode_) {
    case Mode::travel:
      // A person lifts the hand when the organ is in the way: move with the felt force.
      if (last_.contact && last_.force.norm() > 1e-9)
        pos_ += last_.force.normalized() * travel_speed_ * s_.speed_factor * dt;
      // A goal the organ keeps the hand from (behind another part of it) is given up after
      // three times the straight-line travel time plus 2 s: the next landmark or probe.
      if (t - mode_start_ > 3.0 * travel_len_ / (travel_speed_ * s_.speed_factor) + 2.0) {
        if (identified_) {
          // On the way to the demonstrated place: press from where the hand got to.
          press_node_ = -1;
          mode_ = Mode::rest;
          mode_start_ = t;
        } else {
          next_probe();
        }
        break;
      }
      if (move_towards(goal_, travel_speed_ * s_.speed_factor)) {
        if (after_travel_ == Mode::press) {
          start_press();  // arrived above the demonstrated place: press at once
        } else {
          mode_ = after_travel_;
          mode_start_ = t;
        }
      }
      break;
    case Mode::descend:
      pos_ += press_dir_ * 0.5 * p_.explore_speed * s_.speed_factor * dt;
      if (t - mode_start_ > 3.0 * p_.lift_height / (0.5 * p_.explore_speed * s_.speed_factor))
        next_probe();  // nothing to touch here
      break;
    case Mode::dwell:
      // Keep a light touch while recognising what is under the finger.
      if (last_.force.norm() < 0.3) pos_ += press_dir_ * p_.press_speed * dt;
      // Seeing the touched part deform makes the judgement faster (a second, visual cue).
      if (t - mode_start_ >= rec_time_ / (1.0 + (dwell_saw_d_ ? p_.visual_recognition_gain : 0))) {
        if (last_.contact && last_.contact_region == view_.feature_region &&
            rng_.uniform() >= p_.miss_probability) {
          identified_ = true;
          // Where it was found, from the hand's position and, if the part visibly deformed,
          // from seeing it: both combined by inverse variances, then merged into the belief
          // (Kalman), so memory sharpens over sessions and sharpens more with vision.
          const double sh = p_.spatial_memory_sd, sv = p_.visual_spatial_sd;
          const double obs_sd =
              dwell_saw_d_ ? 1.0 / std::sqrt(1.0 / (sh * sh) + 1.0 / (sv * sv)) : sh;
          const Eigen::Vector3d obs =
              pos_ + Eigen::Vector3d(rng_.normal(), rng_.normal(), rng_.normal()) * obs_sd;
          const double k =
              s_.place_sd * s_.place_sd / (s_.place_sd * s_.place_sd + obs_sd * obs_sd + 1e-18);
          s_.place += k * (obs - s_.place);
          s_.place_sd = std::sqrt((1.0 - k) * s_.place_sd * s_.place_sd);
          if (p_.press_at_demonstrated_place > 0) {
            // Press where the target press was shown, not where the search happened to touch
            // the feature: reach the hover point above the aimed node, then press from there.
            aim_press(kReleaseClearance);
            start_travel(hover_, Mode::press);
            travel_speed_ = p_.explore_speed;
          } else {
            mode_ = Mode::press;
            mode_start_ = t;
            start_press();
          }
        } else {
          if (orienting_)
            s_.landmark_practice += (dwell_saw_d_ ? 1.0 + p_.visual_recognition_gain : 1.0) +
                                    (landmark_felt_distinct() ? p_.compliance_recognition_gain : 0);
          // Not the feature (or a landmark passed): the next landmark, or probe elsewhere
          // (travel lifts off the surface on the way).
          next_probe();
        }
      }
      break;
    case Mode::press:
      pos_ += press_dir_ * p_.press_speed * dt;
      // Give up a press that never reaches the intended force (e.g. nothing felt).
      if ((release_at_ >= 0 && t >= release_at_) || t - mode_start_ > 10.0) begin_release(t);
      break;
    case Mode::hold:
      if (t - mode_start_ >= p_.hold_time || (release_at_ >= 0 && t >= release_at_))
        begin_release(t);
      break;
    case Mode::release: {
      // Lift off along the pressed part's outward direction. If something resists the lift (the
      // hand runs into another part of the organ), move with the felt force as in travel, and
      // stop as soon as the hand is free.
      const Eigen::Vector3d up = -press_dir_;
      if (last_.contact && ch_.haptic && last_.force.dot(up) < 0.0) {
        pos_ += last_.force.normalized() * p_.release_speed * dt;
        release_blocked_ = true;
      } else {
        pos_ += up * p_.release_speed * dt;
      }
      if (!last_.contact) {
        // The clearance is measured from where the contact ended, not from where the press
        // started: the next press starts just above the organ, every time (measuring it from
        // the press start made the hand creep 2 mm further away with every palpation).
        if (!lifted_off_) {
          lifted_off_ = true;
          lift_off_ = pos_;
        }
        if (release_blocked_ || (pos_ - lift_off_).dot(up) >= kReleaseClearance) {
          mode_ = Mode::rest;
          mode_start_ = t;
          // The next press aims at the demonstrated place anew (each press is a new reach).
          if (identified_ && p_.press_at_demonstrated_place > 0) aim_press(kReleaseClearance);
        }
      }
      break;
    }
    case Mode::rest: {
      // Between presses the hand moves to above the next aimed node (moving with the felt force
      // if it touches the organ on the way, as in travel); the press starts after the rest.
      bool there = true;
      if (press_node_ >= 0) {
        if (last_.contact && ch_.haptic && last_.force.norm() > 1e-9)
          pos_ += last_.force.normalized() * p_.explore_speed * s_.speed_factor * dt;
        there = move_towards(hover_, p_.explore_speed * s_.speed_factor);
        // A hover point the organ keeps the hand from: press from where the hand is.
        if (!there && t - mode_start_ > p_.rest_time + 2.0) there = true;
      }
      if (there && t - mode_start_ >= p_.rest_time) start_press();
      break;
    }
  }
  return pos_;
}

void Trainee::aim_press(double clearance) {
  // Observational learning: what a learner takes from a demonstration is first of all its goal,
  // the end point of the demonstrated action (Hodges, Williams, Hayes & Breslin 2007). The
  // briefing showed the target press at the feature's centre (the surface nodes of the feature
  // nearest its centroid, docs/PARTICIPANTS.md "The demonstration"), so every press aims there,
  // with the scatter of a reach to a seen place (visual_spatial_sd per axis; van Beers, Sittig &
  // Denier van der Gon 1999), projected to the nearest surface node of the feature. On a tissue
  // whose stiffness varies from place to place the picture at the target is then the one the
  // demonstration showed; pressing wherever the search happened to touch the feature (the
  // model before) compared the demonstration's picture with softer places' (prototype C's
  // ovary: 600 N/m at its centre, 167-450 N/m where the searches ended).
  const auto& V = *view_.V;
  const auto& region = *view_.vertex_region;
  const Eigen::Vector3d q =
      view_.feature_centroid +
      Eigen::Vector3d(aim_rng_.normal(), aim_rng_.normal(), aim_rng_.normal()) *
          p_.visual_spatial_sd;
  int node = -1;
  double bd = std::numeric_limits<double>::infinity();
  for (int i = 0; i < V.rows(); ++i) {
    if (region[i] != view_.feature_region) continue;
    const double d = (V.row(i).transpose() - q).squaredNorm();
    if (d < bd) bd = d, node = i;
  }
  if (node < 0) return;  // no surface node of the feature: press where the hand is
  press_node_ = node;
  const Eigen::Vector3d n = view_.N->row(node).transpose().normalized();
  press_dir_ = -n;
  hover_ = V.row(node).transpose() + n * clearance;
}

void Trainee::start_press() {
  mode_ = Mode::press;
  mode_start_ = t_prev_;
  // Signal-dependent motor noise (Harris & Wolpert 1998): the produced force scatters with an SD
  // proportional to the intended force; per-press perceptual errors (Weber).
  // Successive presses of a session are not independent draws: their errors follow a stationary
  // AR(1) (lag-1 correlation press_error_correlation; each error keeps its SD). Repeated
  // productions without feedback drift rather than scatter afresh (Gilden, Thornton & Mallon
  // 1995; van Beers 2009). The first press of a session draws afresh.
  const double rho = p_.press_error_correlation;
  const double innovation = std::sqrt(1.0 - rho * rho);
  z_motor_ = presses_ > 0 ? rho * z_motor_ + innovation * rng_.normal() : rng_.normal();
  intended_ = std::max(0.0, s_.target_mean * (1.0 + p_.motor_noise_cv * z_motor_));
  z_haptic_ = presses_ > 0 ? rho * z_haptic_ + innovation * rng_.normal() : rng_.normal();
  eps_h_ = p_.weber_fraction * z_haptic_;
  eps_v_ = p_.visual_weber * rng_.normal();
  rt_scale_ = std::max(0.3, 1.0 + p_.reaction_time_cv * rng_.normal());
  release_at_ = -1.0;
  // A trainee who has come to rely on a marker (sound, call) waits for it.
  expect_marker_ = (ch_.audio || ch_.call) && s_.reliance > 0.05;
  marker_this_press_ = false;
  visual_marker_ = false;
  visual_bound_stop_ = false;
  audio_seen_ = false;
  call_heard_ = false;
  peak_felt_ = 0.0;
  peak_seen_d_ = 0.0;
  press_d0_ = -1.0;
  ++presses_;
}

void Trainee::begin_release(double t) {
  // Learn the felt-force / seen-deformation ratio from the press peak (visual calibration).
  if (ch_.visual && ch_.haptic && peak_seen_d_ > 0 && peak_felt_ > 0) {
    // Ratio of sums (not mean of ratios, which is biased upwards by the deformation noise).
    s_.k_felt_sum += peak_felt_;
    s_.k_seen_sum += peak_seen_d_;
    ++s_.k_count;
    s_.k_hat = s_.k_felt_sum / s_.k_seen_sum;
    const double lr = std::log(peak_felt_ / peak_seen_d_);
    s_.k_log_sum += lr;
    s_.k_log_sq += lr * lr;
  }
  // Guidance: reliance grows with every marker received, and fades when an expected one fails.
  double lower_bound_trust = -1.0;  // < 0: this press is no censored observation
  if (marker_this_press_) {
    s_.reliance += p_.guidance_rate * (1.0 - s_.reliance);
    misses_ = 0;
  } else if (expect_marker_) {
    // The marker that means "target reached" did not come: the target lies above the force this
    // press reached. A censored observation (target > F): the belief is updated by assumed
    // density filtering, i.e. replaced by the Gaussian with the moments of the belief truncated
    // below F, with the perceptual noise of F added to the truncation's scale. Without it a
    // trainee who heard the marker once but whose belief stayed below the threshold kept
    // pressing short of it, the expectation extinguished and the belief stayed at the low
    // briefing (group A's bimodal low tail, docs/PARTICIPANTS.md "Not reaching the marker").
    lower_bound_trust = s_.reliance;
    // An expectation built on markers received fades when they stop; one that rests only on
    // the demonstration (no marker received yet) keeps the trainee searching, pressing harder
    // after each miss.
    if (s_.feedback_count > 0) s_.reliance *= 1.0 - p_.extinction_rate;
    ++misses_;
  }
  // A press aimed at the remembered picture that reached its bound while the indentation stayed
  // short of it says the same about the target: it lies above the force reached. The picture is
  // in view the whole time, so its absence is not ambiguous (trust 1). Without this a trainee
  // whose briefed belief was low (exp4's P15 in the predictions of 2026-12-02: 0.92 N) stopped
  // every press at 1.66 x that belief, short of the picture, and never learned: 1.04 N in the
  // haptic-only test after training presses of 1.8-2.2 N. One observation per press: this
  // one replaces that of a missed sound or call (the same evidence, more trusted).
  if (visual_bound_stop_ && !visual_marker_ && !marker_this_press_) lower_bound_trust = 1.0;
  if (lower_bound_trust >= 0.0 && ch_.haptic && peak_felt_ > 0)
    learn_lower_bound(peak_felt_, lower_bound_trust);
  mode_ = Mode::release;
  mode_start_ = t;
  release_at_ = -1.0;
  lifted_off_ = false;
  release_blocked_ = false;
}

void Trainee::perceive(const Percept& seen, bool call) {
  // The deformation as this trainee judges it (the indentation unless visual_volume_weight > 0).
  Percept mixed;
  if (p_.visual_volume_weight > 0.0) {
    mixed = seen;
    mixed.visible_deformation =
        seen_deformation(seen.visible_deformation, seen.visible_volume, p_.visual_volume_weight);
  }
  const Percept& p = p_.visual_volume_weight > 0.0 ? mixed : seen;
  if (mode_ == Mode::descend && p.contact) {
    mode_ = Mode::dwell;
    mode_start_ = p.t;
    rec_time_ = orienting_ ? draw_landmark_time() : draw_recognition_time();
    dwell_saw_d_ = false;
    touch_pos_ = pos_;
  }
  if (mode_ == Mode::dwell && ch_.visual && p.contact && p.visible_deformation > 0)
    dwell_saw_d_ = true;
  if (mode_ == Mode::press || mode_ == Mode::hold) {
    // What this press does to the picture: the indentation since the press first touched. The
    // demonstration's d* is an indentation from rest; deformation the tissue has not yet
    // recovered from the previous press is not this press's doing (after a deep press on a soft
    // spot of C it was still beyond d* when the next press touched, so the visual marker fired
    // at 0.1 N and the learned target collapsed to 0). Marker, visual force estimate and the
    // felt/seen ratio all use this one quantity.
    if (p.contact && press_d0_ < 0) press_d0_ = p.visible_deformation;
    Percept q = p;
    q.visible_deformation =
        p.contact && press_d0_ >= 0 ? std::max(0.0, p.visible_deformation - press_d0_) : 0.0;
    const double f = perceived_force(q);
    if (ch_.haptic) peak_felt_ = std::max(peak_felt_, p.force.norm() * (1.0 + eps_h_));
    if (ch_.visual) peak_seen_d_ = std::max(peak_seen_d_, q.visible_deformation * (1.0 + eps_v_));
    // Reaction times vary from trial to trial: one draw per press (rt_scale_).
    const double rt_audio = p_.reaction_time_audio * rt_scale_;
    // The sound means "target reached": learn the force felt at its onset, release after a
    // reaction time.
    // Guidance hypothesis: the more the trainee relies on the marker, the less of what it
    // marks reaches the internal memory of the force.
    const double guided = 1.0 - p_.guidance_dependence * s_.reliance;
    if (ch_.audio && p.audio && !audio_seen_) {
      audio_seen_ = true;
      marker_this_press_ = true;
      learn_target(f, perceived_variance(q), guided);
      if (release_at_ < 0) release_at_ = p.t + rt_audio;
    }
    if (call && !call_heard_) {
      call_heard_ = true;
      marker_this_press_ = true;
      learn_target(f, perceived_variance(q), guided);
      if (release_at_ < 0 || p.t + rt_audio < release_at_) release_at_ = p.t + rt_audio;
    }
    if (audio_seen_ || call_heard_) marker_in_session_ = true;
    // Seen deformation reaching what the demonstration showed at the target: the felt force
    // there is an observation of the target (visual-haptic learning). Its variance adds how
    // inconsistently felt force and seen deformation went together so far (a simulator whose
    // picture does not follow the force teaches less).
    if (ch_.visual && ch_.haptic && s_.demo_d > 0 && !visual_marker_ &&
        q.visible_deformation * (1.0 + eps_v_) >= s_.demo_d) {
      visual_marker_ = true;
      double var = perceived_variance(q) + std::pow(p_.visual_weber * f, 2);
      if (s_.k_count >= 2) {
        const double m = s_.k_log_sum / s_.k_count;
        var += std::max(0.0, s_.k_log_sq / s_.k_count - m * m) * f * f;
      }
      learn_target(f, var);
      const double at = p.t + p_.reaction_time_visual * rt_scale_;
      if (release_at_ < 0 || at < release_at_) release_at_ = at;
    }
    // Without an expected marker the press stops at the intended force; waiting for a marker it
    // goes on, to a limit that grows with the reliance and with each marker that failed.
    // How far it goes on is also this person's own (overshoot_factor).
    const double wait =
        expect_marker_
            ? std::pow(1.0 + p_.marker_wait_overshoot * s_.overshoot_factor * s_.reliance,
                       1 + std::min(misses_, 3))
            : 1.0;
    // While the trainee sees the part deform and knows what the target looks like, the press
    // aims at that picture (it ends at the visual marker above), bounded like a marker wait.
    const bool aiming_visually = ch_.visual && s_.demo_d > 0 && q.visible_deformation > 0;
    const double limit =
        aiming_visually ? std::max(wait, 1.0 + p_.marker_wait_overshoot) * 1.5 : wait;
    if (mode_ == Mode::press && release_at_ < 0 && f >= intended_ * limit) {
      mode_ = Mode::hold;
      mode_start_ = p.t;
      visual_bound_stop_ = aiming_visually;
    }
  }
  last_ = p;
}

void Trainee::end_session(double study_time) {
  s_.last_session_end = study_time;
  if (identified_) ++s_.finds;
}

Instructor::Instructor(const InstructorParams& params, std::uint64_t seed)
    : p_(params), rng_(derive_seed(seed, "instructor")) {
  reset_press();
}

bool Instructor::observe(const Percept& p, Channels ch) {
  if (called_) return false;
  if (ch.audio && p.audio && !prev_audio_) {
    double at = p.t + p_.reaction_time_audio * rt_scale_;
    if (call_at_ < 0 || at < call_at_) call_at_ = at;
  }
  prev_audio_ = p.audio;
  // The indentation since this press touched (as the trainee's own visual marker).
  if (!p.contact) d0_ = -1.0;
  if (p.contact && d0_ < 0) d0_ = p.visible_deformation;
  const double seen = p.contact && d0_ >= 0 ? std::max(0.0, p.visible_deformation - d0_) : 0.0;
  if (ch.visual && target_d_ > 0 && seen >= target_d_ * (1.0 + eps_)) {
    double at = p.t + p_.reaction_time_visual * rt_scale_;
    if (call_at_ < 0 || at < call_at_) call_at_ = at;
  }
  if (call_at_ >= 0 && p.t >= call_at_) {
    called_ = true;
    return true;
  }
  return false;
}

void Instructor::reset_press() {
  called_ = false;
  call_at_ = -1.0;
  d0_ = -1.0;
  prev_audio_ = false;
  eps_ = p_.visual_weber * rng_.normal();
  rt_scale_ = std::max(0.3, 1.0 + p_.reaction_time_cv * rng_.normal());
}

}  // namespace palplab::protocols::participants
