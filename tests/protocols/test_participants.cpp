// The virtual participant model on a flat test tissue: a 0.2 m square surface at z = 0 with
// linear stiffness, a disc-shaped "feature" region, optional visible deformation and a sound at
// ST. This stand-in renders exactly what a Scene renders (force, contact, region, deformation,
// audio) with known physics, so the model's learning can be checked against known truths.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "common/input_error.hpp"
#include "common/seed.hpp"
#include "flat_tissue.hpp"
#include "protocols/participants/model.hpp"
#include "protocols/participants/params.hpp"

using namespace palplab;
using namespace palplab::protocols::participants;
using palplab::protocols::participants::fixtures::FlatTissue;

namespace {

// Runs one session of `duration` s; returns peak forces of the presses on the feature.
std::vector<double> run_session(Trainee& tr, const FlatTissue& tissue, double study_time,
                                double duration, std::uint64_t pseed, std::uint64_t seed,
                                Channels ch = {}) {
  tr.begin_session(tissue.view(), 2.5, study_time, duration, pseed, seed, ch);
  std::vector<double> peaks;
  double peak = 0.0;
  bool in = false;
  const int steps = static_cast<int>(duration * 1000);
  for (int i = 1; i <= steps; ++i) {
    double t = i * 0.001;
    Percept p = tissue.render(t, tr.command(t));
    tr.perceive(p, false);
    if (p.contact) {
      peak = std::max(peak, p.force.norm());
      in = true;
    } else if (in) {
      if (tr.identified() && peak > 0.5) peaks.push_back(peak);
      peak = 0.0;
      in = false;
    }
  }
  tr.end_session(study_time + duration);
  return peaks;
}

// Mean |learned target - reference| over `n` virtual participants after `sessions` training
// sessions of 60 s and a retention interval `retention_s`. With `learners_only`, only
// participants who received at least one target marker count (the others keep their briefing
// belief whatever the cue reliability); their number is returned in *learners.
double mean_learned_error(FlatTissue tissue, const nlohmann::json& overrides, int sessions,
                          double retention_s, double reference, int n = 40,
                          bool learners_only = false, int* learners = nullptr) {
  auto params = trainee_params(overrides);
  double err = 0.0;
  int counted = 0;
  for (int k = 0; k < n; ++k) {
    Trainee tr(params, TraineeState{});
    std::uint64_t ps = derive_seed(99, static_cast<std::uint64_t>(k));
    double t = 0;
    for (int s = 0; s < sessions; ++s) {
      run_session(tr, tissue, t, 60.0, ps, derive_seed(ps, static_cast<std::uint64_t>(s)));
      t += 60.0 + 600.0;
    }
    // Forgetting is applied at the start of the next session: begin one after the interval.
    tr.begin_session(tissue.view(), 2.5, t - 600.0 + retention_s, 1.0, ps, 1, {});
    if (learners_only && tr.state().feedback_count == 0) continue;
    err += std::abs(tr.state().target_mean - reference);
    ++counted;
  }
  if (learners) *learners = counted;
  return err / std::max(counted, 1);
}

// A quick, sure searcher, for tests about pressing and learning rather than about how long a
// search takes: short recognition and landmark judgements, no misses. (Since the power law of
// practice was fitted on 2026-12-04 a novice's first landmark judgement takes ~34 s, so with the
// defaults a 60 s session is mostly search.)
nlohmann::json quick_searcher(nlohmann::json extra = nlohmann::json::object()) {
  nlohmann::json j = {{"recognition_time", 0.3}, {"landmark_time", 1.0}, {"miss_probability", 0.0}};
  j.update(extra);
  return j;
}

// A briefed trainee who believes the target is `target` N (the variance of a 30 % briefing of
// 2.5 N) and knows where the feature is (3 mm).
TraineeState briefed_state(const FlatTissue& tissue, double target) {
  TraineeState st;
  st.initialised = true;
  st.prior_mean = st.target_mean = target;
  st.prior_var = st.target_var = std::pow(0.3 * 2.5, 2);
  st.place = tissue.feature;
  st.place_sd = 0.003;
  return st;
}

}  // namespace

TEST(Perception, MleWeightsAreInverseVariances) {
  std::vector<double> w;
  Estimate e = mle_combine({{2.0, 0.04}, {3.0, 0.01}}, &w);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NEAR(w[0], (1 / 0.04) / (1 / 0.04 + 1 / 0.01), 1e-12);
  EXPECT_NEAR(w[1], 0.8, 1e-12);
  EXPECT_NEAR(e.value, 0.2 * 2.0 + 0.8 * 3.0, 1e-12);
  EXPECT_NEAR(e.variance, 1.0 / (25.0 + 100.0), 1e-12);
  // The combined estimate is never less precise than the best cue alone.
  EXPECT_LT(e.variance, 0.01);
  // One cue: itself.
  Estimate one = mle_combine({{1.5, 0.3}}, &w);
  EXPECT_DOUBLE_EQ(one.value, 1.5);
  EXPECT_DOUBLE_EQ(w[0], 1.0);
}

TEST(Memory, RetentionIsAPowerLawThatSlowsAfterConsolidation) {
  auto p = trainee_params(nlohmann::json::object());
  EXPECT_DOUBLE_EQ(retention(0.0, p), 1.0);
  const double tau = p.forgetting_tau, d = p.forgetting_exponent;
  EXPECT_NEAR(retention(600.0, p), std::pow(1 + 600.0 / tau, -d), 1e-12);
  EXPECT_GT(retention(600.0, p), retention(86400.0, p));
  EXPECT_GT(retention(86400.0, p), retention(6 * 86400.0, p));
  // continuous at the consolidation time, slower afterwards
  const double tc = p.consolidation_time;
  EXPECT_NEAR(retention(tc * (1 - 1e-9), p), retention(tc * (1 + 1e-9), p), 1e-6);
  double full = std::pow(1 + 6 * 86400.0 / tau, -d);
  EXPECT_GT(retention(6 * 86400.0, p), full);
}

TEST(Trainee, FindsTheFeatureAndPresses) {
  FlatTissue tissue;
  // A quick, sure recogniser: this test is about pressing, not about how long a search takes.
  Trainee tr(trainee_params(quick_searcher()), TraineeState{});
  auto peaks = run_session(tr, tissue, 0.0, 60.0, 5, 6);
  EXPECT_TRUE(tr.identified());
  EXPECT_GE(peaks.size(), 5u);
  for (double f : peaks) {
    EXPECT_GT(f, 1.0);
    EXPECT_LT(f, 5.0);
  }
}

// Feeling the landmarks' compliance: a landmark whose felt stiffness differs from the previous
// one's by more than stiffness_weber counts compliance_recognition_gain more practice; on a
// tissue that feels equally stiff everywhere (as A's and B's penalty contact) the gain changes
// nothing at all, and neither does a difference below the JND.
TEST(Trainee, ALandmarkThatFeelsDifferentCountsMorePractice) {
  auto practice = [](const FlatTissue& tissue, double gain) {
    Trainee tr(trainee_params(quick_searcher({{"compliance_recognition_gain", gain}})),
               TraineeState{});
    run_session(tr, tissue, 0.0, 60.0, 5, 6);
    EXPECT_TRUE(tr.identified());
    return tr.state().landmark_practice;
  };
  FlatTissue uniform;
  const double base = practice(uniform, 0.0);
  EXPECT_GE(base, 2.0);  // the route has landmarks before the feature
  EXPECT_EQ(practice(uniform, 3.0), base);
  // The first landmark (below the start) three times softer than the others: the second feels
  // different (one distinct landmark), the ones after it do not.
  FlatTissue soft_start;
  soft_start.k_start = soft_start.k / 3.0;
  soft_start.start_radius = 0.02;
  const double soft0 = practice(soft_start, 0.0);
  EXPECT_EQ(soft0, base);  // without the gain the stiffness does not matter to the practice
  EXPECT_EQ(practice(soft_start, 3.0), soft0 + 3.0);
  // 10 % softer: below the 23 % JND, nothing.
  FlatTissue slightly;
  slightly.k_start = slightly.k / 1.1;
  slightly.start_radius = 0.02;
  EXPECT_EQ(practice(slightly, 3.0), base);
}

TEST(Trainee, SameSeedSameBehaviour) {
  FlatTissue tissue;
  auto params = trainee_params({});
  Trainee a(params, TraineeState{}), b(params, TraineeState{});
  auto pa = run_session(a, tissue, 0, 30, 11, 12), pb = run_session(b, tissue, 0, 30, 11, 12);
  EXPECT_EQ(pa, pb);
  EXPECT_EQ(a.state().to_json(), b.state().to_json());
  // state survives a JSON round trip exactly (resume)
  EXPECT_EQ(TraineeState::from_json(a.state().to_json()).to_json(), a.state().to_json());
}

TEST(Trainee, MoreReliableCuesGiveSmallerLearnedForceError) {
  // The sound at ST marks the target; the force felt at its onset is what is learned, so the
  // learned target's error shrinks with the reliability of the force percept. Two 60 s sessions
  // (tens of markers), errors right after them, over the participants who heard the marker.
  FlatTissue with_visual, without_visual, no_marker;
  without_visual.visual = false;
  no_marker.audio = false;
  no_marker.visual = false;
  const double ref = 2.3;  // the force the cue marks
  int n_av = 0, n_a = 0, n_fine = 0;
  // A sharp visual cue combined by MLE with the haptic one (Ernst & Banks 2002).
  // Haptic Weber fraction 0.08 (force JNDs of 7-10 %) against 0.03 for the finer sense below.
  // Landmark judgements of 1 s: the two minutes are for learning the force, not for searching.
  double e_av = mean_learned_error(
      with_visual, {{"visual_weber", 0.02}, {"weber_fraction", 0.08}, {"landmark_time", 1.0}}, 2,
      0.0, ref, 60, true, &n_av);
  double e_a =
      mean_learned_error(without_visual, {{"weber_fraction", 0.08}, {"landmark_time", 1.0}}, 2, 0.0,
                         ref, 60, true, &n_a);
  // A finer haptic sense (smaller Weber fraction).
  double e_fine =
      mean_learned_error(without_visual, {{"weber_fraction", 0.03}, {"landmark_time", 1.0}}, 2, 0.0,
                         ref, 60, true, &n_fine);
  ASSERT_GE(n_a, 15) << e_a;
  ASSERT_GE(n_av, 15) << e_av;
  ASSERT_GE(n_fine, 15) << e_fine;
  EXPECT_LT(e_av, e_a) << e_av << " vs " << e_a;
  EXPECT_LT(e_fine, e_a) << e_fine << " vs " << e_a;
  // No marker at all: nothing is learned; everyone keeps the briefing's error.
  int n_none = 0;
  double e_none_all = mean_learned_error(no_marker, {}, 1, 0.0, ref, 60, true, &n_none);
  EXPECT_EQ(n_none, 0);
  (void)e_none_all;
  double e_a_all = mean_learned_error(without_visual, {}, 4, 0.0, ref);
  double e_none = mean_learned_error(no_marker, {}, 4, 0.0, ref);
  EXPECT_LT(e_a_all, e_none) << e_a_all << " vs " << e_none;
}

TEST(Trainee, AMissedMarkerBelowTheBeliefRaisesIt) {
  // A trainee who expects the sound at the target but whose belief lies below the sound
  // threshold (heard it once, learned little, presses short of it): each press that ends
  // without the sound says "the target is above this force" (a censored observation), so the
  // belief climbs until the presses reach the sound and it is learned. Before this update the
  // expectation extinguished after a few such misses and the belief stayed at the low briefing
  // (group A's low tail in exp2: learned 1.4 N for ST 2.3 N). Within one exp2 training session
  // (300 s): with the shipped correlated press errors (press_error_correlation 0.9) the climb is
  // slower than with independent ones (measured 6 / 9 / 10 of 10 after 60 / 120 / 240 s; 10 of 10
  // after 60 s at rho 0 and the previous marker_wait_overshoot 0.1286), since successive presses
  // repeat their shortfall; without the censored update none climbed (the expectation
  // extinguishes and the presses stay at the belief).
  FlatTissue tissue;
  tissue.visual = false;
  const auto params = trainee_params(quick_searcher());
  int climbed = 0;
  const int n = 10;
  for (int k = 0; k < n; ++k) {
    TraineeState st = briefed_state(tissue, 1.3);  // N, well below ST 2.3 N
    st.feedback_count = 1;                         // heard the sound once
    st.demo_sound = true;
    st.reliance = 1.0;
    Trainee tr(params, st);
    const std::uint64_t ps = derive_seed(7, static_cast<std::uint64_t>(k));
    run_session(tr, tissue, 0.0, 300.0, ps, derive_seed(ps, 1));
    ASSERT_TRUE(tr.identified());
    // Learned from the sound again, and near what it marks (2.3 N; the Weber error of the
    // felt force at the onset is 8 %, i.e. 0.18 N).
    if (tr.state().feedback_count > 3 && std::abs(tr.state().target_mean - 2.3) < 0.3) ++climbed;
  }
  EXPECT_EQ(climbed, n);
}

TEST(Trainee, AMissedMarkerFarAboveTheBeliefTeachesLittle) {
  // When the sound is withdrawn (a haptic-only test), misses at forces well above the belief are
  // better explained by "the cue is gone" than by "the target is higher": the belief rises only
  // by the first, ambiguous misses, and the reliance extinguishes.
  FlatTissue tissue;
  tissue.visual = false;
  tissue.audio = false;
  const auto params = trainee_params(quick_searcher());
  TraineeState st;
  st.initialised = true;
  st.prior_mean = 2.5;
  st.prior_var = std::pow(0.3 * 2.5, 2);
  st.target_mean = 2.3;
  st.target_var = std::pow(0.35, 2);  // a learned 2.3 N after 10 min of forgetting
  st.place = tissue.feature;
  st.place_sd = 0.003;
  st.feedback_count = 200;
  st.demo_sound = true;
  st.reliance = 0.9;
  Trainee tr(params, st);
  auto peaks = run_session(tr, tissue, 0.0, 60.0, 3, 4);
  ASSERT_GE(peaks.size(), 8u);
  EXPECT_LT(tr.state().reliance, 0.05);
  // Bounded: far below what presses at the largest marker wait would teach if every miss were
  // read as "not there yet" (the belief would follow the peaks up, 2.3 * 1.13^4 = 3.8 N).
  EXPECT_GT(tr.state().target_mean, 2.3);
  EXPECT_LT(tr.state().target_mean, 3.0);
  // The last presses, with the expectation gone, aim at the belief: no further climb.
  EXPECT_NEAR(peaks.back(), tr.state().target_mean, 0.35 * tr.state().target_mean);
}

namespace {
// Mean learned target (N) of `n` trainees after two 120 s sessions with the visual marker only
// (no sound), each briefed with a demonstration whose picture at the target is `demo_d` (m).
double mean_learned_with_demonstration(const FlatTissue& tissue, const nlohmann::json& overrides,
                                       double demo_d, int n, double* sd) {
  const auto params = trainee_params(overrides);
  double s1 = 0.0, s2 = 0.0;
  for (int k = 0; k < n; ++k) {
    Trainee tr(params, TraineeState{});
    tr.set_demonstration(Demonstration{demo_d, false});
    const std::uint64_t ps = derive_seed(1411, static_cast<std::uint64_t>(k));
    run_session(tr, tissue, 0.0, 120.0, ps, derive_seed(ps, 0));
    run_session(tr, tissue, 720.0, 120.0, ps, derive_seed(ps, 1));
    const double m = tr.state().target_mean;
    s1 += m;
    s2 += m * m;
  }
  const double mean = s1 / n;
  *sd = std::sqrt(std::max(0.0, (s2 - n * mean * mean) / (n - 1)));
  return mean;
}
}  // namespace

TEST(Trainee, PressesWhereTheTargetWasShownSoThePictureMeansTheTargetForce) {
  // A feature whose stiffness varies from place to place (800 N/m within 8 mm of its centre,
  // 300 N/m on its rim; prototype C's ovary: 600 N/m at its centre, 167-450 N/m where the exp2
  // searches ended). The briefing shows the target press (2.5 N) at the centre: 3.125 mm. A
  // trainee who presses wherever its search touched the feature (the model before, switch 0)
  // sees that picture on the rim at 300 N/m x 3.125 mm = 0.94 N and learns too low a target
  // (exp2's C trainees learned 1.80 +- 0.33 N for 2.5 N). Pressing where the target was shown
  // (each press a reach to the demonstrated place, visual_spatial_sd scatter), the visual marker
  // means the demonstrated force. Aims sharper than the default (2 mm instead of 4 mm) keep them
  // off this small test feature's rim. Measured (10 trainees, two 120 s sessions, same seeds):
  // switch 1 2.56 +- 0.29 N (the spread is that of the remembered picture, 10 % visual Weber
  // noise), switch 0 1.69 +- 0.72 N (five of ten pressed the rim: 0.88-1.61 N).
  FlatTissue tissue;
  tissue.audio = false;
  tissue.k_edge = 300.0;
  tissue.core_radius = 0.011;
  const double mpf = 2.5, demo_d = mpf / tissue.k;
  double sd_new = 0.0, sd_old = 0.0;
  const double now =
      mean_learned_with_demonstration(tissue, {{"visual_spatial_sd", 0.002}}, demo_d, 10, &sd_new);
  const double before = mean_learned_with_demonstration(
      tissue, {{"visual_spatial_sd", 0.002}, {"press_at_demonstrated_place", 0}}, demo_d, 10,
      &sd_old);
  std::printf(
      "learned target: at the demonstrated place %.2f +- %.2f N, where found %.2f +- %.2f N\n", now,
      sd_new, before, sd_old);
  EXPECT_NEAR(now, mpf, 0.1 * mpf);
  EXPECT_LT(sd_new, sd_old);
  // The old behaviour on the same tissue, same seeds: the rim's picture teaches too low a force.
  EXPECT_LT(before, now - 0.3);
}

TEST(Trainee, TheRememberedPictureAveragesTheDemonstrationsPresses) {
  // The briefing shows the target press at 5 places; each press is seen with its own visual
  // Weber noise and their mean is kept (ensemble averaging), so the remembered picture's relative
  // error is about visual_weber / sqrt(5) - not visual_weber, as when one draw was put on the
  // mean. 1000 trainees: the sample SD's relative SE is 1/sqrt(2 * 999) = 2.2 %, 10 % is 4.5 SE.
  FlatTissue tissue;
  const auto params = trainee_params({});
  const std::vector<double> seen = {0.0040, 0.0050, 0.0055, 0.0045, 0.0060};
  double mean_seen = 0.0, mean_sq = 0.0;
  for (double d : seen) mean_seen += d / seen.size(), mean_sq += d * d / seen.size();
  // SD of mean(d_i (1 + w z_i)) over its mean: w sqrt(mean d^2) / (mean d sqrt(5)).
  const double expected5 = params.visual_weber * std::sqrt(mean_sq) / mean_seen / std::sqrt(5.0);
  auto relative_spread = [&](const Demonstration& demo, double* mean) {
    double s1 = 0.0, s2 = 0.0;
    const int n = 1000;
    for (int k = 0; k < n; ++k) {
      Trainee tr(params, TraineeState{});
      tr.set_demonstration(demo);
      const std::uint64_t ps = derive_seed(2712, static_cast<std::uint64_t>(k));
      tr.begin_session(tissue.view(), 2.5, 0.0, 1.0, ps, 1, {});
      s1 += tr.state().demo_d;
      s2 += tr.state().demo_d * tr.state().demo_d;
    }
    *mean = s1 / n;
    return std::sqrt((s2 - n * *mean * *mean) / (n - 1)) / *mean;
  };
  double m5 = 0.0, m1 = 0.0;
  const double cv5 = relative_spread(Demonstration{mean_seen, false, seen}, &m5);
  const double cv1 = relative_spread(Demonstration{mean_seen, false, {}}, &m1);
  std::printf("remembered picture: 5 presses %.4f (expected %.4f), one picture %.4f (%.4f)\n", cv5,
              params.visual_weber / std::sqrt(5.0), cv1, params.visual_weber);
  EXPECT_NEAR(cv5, params.visual_weber / std::sqrt(5.0),
              0.15 * params.visual_weber / std::sqrt(5.0));
  EXPECT_NEAR(cv1, params.visual_weber, 0.1 * params.visual_weber);
  // Unbiased: the mean picture is the mean deformation shown (within 4 SE of the mean).
  EXPECT_NEAR(m5, mean_seen, 4 * expected5 / std::sqrt(1000.0) * mean_seen);
}

// visual_volume_weight w: a seen deformation is judged as d^(1-w) (V / 1 cm^2)^w from the
// indentation d and the pushed-in volume V of the drawn surface; the briefing's remembered
// picture is judged so press by press. w = 0 is the indentation alone, whatever the volume.
TEST(Trainee, TheDeformationIsJudgedByTheWholePictureWithTheVolumeWeight) {
  EXPECT_EQ(seen_deformation(0.004, 3e-6, 0.0), 0.004);
  EXPECT_DOUBLE_EQ(seen_deformation(0.004, 3e-6, 1.0), 3e-6 / kSeenVolumeArea);
  EXPECT_DOUBLE_EQ(seen_deformation(0.004, 3e-6, 0.5), std::sqrt(0.004 * 3e-6 / kSeenVolumeArea));
  EXPECT_EQ(seen_deformation(0.004, 0.0, 0.5), 0.0);  // no volume drawn: nothing seen of it
  // Two identical presses: the same person (seed) sees them with the same Weber draws whatever
  // w, so the remembered picture scales exactly as the judged deformation does.
  FlatTissue tissue;
  const Demonstration demo{0.004, false, {0.004, 0.004}, 3e-6, {3e-6, 3e-6}};
  auto remembered = [&](double w) {
    Trainee tr(trainee_params({{"visual_volume_weight", w}}), TraineeState{});
    tr.set_demonstration(demo);
    tr.begin_session(tissue.view(), 2.5, 0.0, 1.0, 7, 1, {});
    return tr.state().demo_d;
  };
  const double d0 = remembered(0.0);
  EXPECT_NE(d0, 0.004);  // seen with visual Weber noise
  for (double w : {0.5, 1.0})
    EXPECT_NEAR(remembered(w) / d0, seen_deformation(0.004, 3e-6, w) / 0.004, 1e-12) << w;
}

TEST(Trainee, APressStoppedShortOfTheRememberedPictureRaisesTheBelief) {
  // A trainee briefed far too low (0.9 N for a 2.5 N target; exp4's P15 in the predictions of
  // 2026-12-02) aims each press at the picture the demonstration showed, bounded at
  // 1.5 (1 + marker_wait_overshoot) = 1.66 x its belief = 1.5 N, where the indentation is still
  // short of the picture (2.5 N / 800 N/m = 3.1 mm). Such a press says "the target lies above
  // this force" (the picture is in view, so nothing else explains it): the belief climbs until
  // the presses reach the picture, whose force is then learned. Before, nothing was learned from
  // such presses: the belief stayed at 0.9 N with no observation in four training sessions.
  FlatTissue tissue;
  tissue.audio = false;
  const auto params = trainee_params(quick_searcher());
  const int n = 10;
  int learned = 0;
  for (int k = 0; k < n; ++k) {
    TraineeState st = briefed_state(tissue, 0.9);  // N
    st.demo_d = 2.5 / tissue.k;                    // m, the picture at the target
    Trainee tr(params, st);
    const std::uint64_t ps = derive_seed(15, static_cast<std::uint64_t>(k));
    run_session(tr, tissue, 0.0, 120.0, ps, derive_seed(ps, 1));
    ASSERT_TRUE(tr.identified());
    // Reached the picture and learned from it, near the force it marks (one observation's SD
    // is 0.25 N: Weber 8 %, the remembered picture 5 %, memory 3 % of 2.5 N).
    if (tr.state().feedback_count > 3 && std::abs(tr.state().target_mean - 2.5) < 0.35) ++learned;
  }
  EXPECT_EQ(learned, n);
}

TEST(Trainee, AnInstructedTraineeWaitsForTheCallWithoutADemonstratedSound) {
  // Experiment 1: the trainee feels only the force and is told "I will tell you when to
  // release"; the instructor watches the deformation and calls. A trainee briefed low (1.3 N;
  // exp1 C's P13 in the predictions of 2026-12-02) whose demonstration had no sound must still
  // wait for the call, or its presses end at its own belief, below the instructor's target, no
  // call ever comes and nothing is learned (as P13 in all four sessions before the change).
  FlatTissue tissue;
  tissue.audio = false;
  const auto params = trainee_params(quick_searcher());
  const auto iparams = instructor_params({});
  const Channels trainee_ch{true, false, false, true};
  const Channels instructor_ch{false, true, true, false};
  const double at_call = 2.5 + params.press_speed * iparams.reaction_time_visual * tissue.k;
  const int n = 10;
  int learned = 0;
  for (int k = 0; k < n; ++k) {
    TraineeState st = briefed_state(tissue, 1.3);  // N
    st.demo_d = 2.5 / tissue.k;  // what the demonstration showed; no sound (st.demo_sound false)
    Trainee tr(params, st);
    Instructor in(iparams, derive_seed(13, static_cast<std::uint64_t>(k)));
    in.set_target_deformation(2.5 / tissue.k);
    const std::uint64_t ps = derive_seed(13, static_cast<std::uint64_t>(k));
    tr.begin_session(tissue.view(), 2.5, 0.0, 300.0, ps, derive_seed(ps, 1), trainee_ch);
    bool prev_contact = false;
    for (int i = 1; i <= 300000; ++i) {
      const double t = i * 0.001;
      const Percept p = tissue.render(t, tr.command(t));
      const bool call = in.observe(p, instructor_ch);
      if (prev_contact && !p.contact) in.reset_press();
      prev_contact = p.contact;
      tr.perceive(p, call);
    }
    ASSERT_TRUE(tr.identified());
    // Learned from the calls. A call marks the force felt when it is heard: the instructor's
    // target (2.5 N, judged with 10 % visual noise) plus what the press adds during the
    // instructor's reaction time, 4 mm/s x 0.19 s x 800 N/m = 0.61 N (measured: 2.81-3.10 N).
    if (tr.state().feedback_count > 3 && std::abs(tr.state().target_mean - at_call) < 0.4)
      ++learned;
  }
  EXPECT_EQ(learned, n);
}

TEST(Trainee, HowFarAPressWaitsForTheWithdrawnSoundIsThePersonsOwn) {
  // The haptic-only test after training with the sound: a trainee who relies on it presses on
  // past the intended force awaiting it, to intended * (1 + marker_wait_overshoot * factor) on
  // the first press, the factor being the person's own (overshoot_individual_cv).
  FlatTissue tissue;
  tissue.audio = false;
  const auto params = trainee_params(quick_searcher());
  auto first_peak = [&](double factor) {
    TraineeState st = briefed_state(tissue, 2.5);
    st.demo_sound = true;
    st.reliance = 1.0;
    st.overshoot_factor = factor;
    Trainee tr(params, st);
    tr.begin_session(tissue.view(), 2.5, 0.0, 30.0, 7, 8, Channels{});
    // The first press: the first touch beyond the light touches (< 0.3 N) of the search.
    double peak = 0.0;
    for (int i = 1; i <= 30000; ++i) {
      const Percept p = tissue.render(i * 0.001, tr.command(i * 0.001));
      tr.perceive(p, false);
      if (p.contact) peak = std::max(peak, p.force.norm());
      if (!p.contact && peak > 1.0) break;
      if (!p.contact) peak = 0.0;
    }
    return peak;
  };
  const double ov = params.marker_wait_overshoot, p1 = first_peak(1.0), p3 = first_peak(3.0);
  ASSERT_GT(p1, 1.0);
  EXPECT_NEAR(p3 / p1, (1 + 3 * ov) / (1 + ov), 0.005) << p1 << " " << p3;
  EXPECT_NEAR(first_peak(0.0) / p1, 1 / (1 + ov), 0.005);

  // The factor is drawn at the briefing, lognormal with median 1 and the given log-scale SD,
  // after every other draw of the briefing: those are the same whatever the spread.
  const auto spread = trainee_params(quick_searcher({{"overshoot_individual_cv", 0.5}}));
  const int n = 400;
  double sum = 0.0, sq = 0.0;
  for (int k = 0; k < n; ++k) {
    const std::uint64_t ps = derive_seed(21, static_cast<std::uint64_t>(k));
    Trainee a(spread, TraineeState{}), b(params, TraineeState{});
    a.begin_session(tissue.view(), 2.5, 0.0, 1.0, ps, 1, {});
    b.begin_session(tissue.view(), 2.5, 0.0, 1.0, ps, 1, {});
    ASSERT_EQ(b.state().overshoot_factor, 1.0);
    ASSERT_EQ(a.state().prior_mean, b.state().prior_mean);
    ASSERT_EQ(a.state().place, b.state().place);
    ASSERT_EQ(a.state().speed_factor, b.state().speed_factor);
    const double z = std::log(a.state().overshoot_factor);
    sum += z;
    sq += z * z;
  }
  const double mean = sum / n, sd = std::sqrt((sq - n * mean * mean) / (n - 1));
  EXPECT_NEAR(mean, 0.0, 0.075);  // 3 SE (0.5 / sqrt(400))
  EXPECT_NEAR(sd, 0.5, 0.055);    // 3 SE (0.5 / sqrt(2 * 399))
}

TEST(Trainee, SuccessivePressErrorsFollowTheirCorrelation) {
  // A haptic-only session with a learned belief and nothing to learn from: each press's force
  // scatters around the belief by motor and Weber noise. With press_error_correlation rho the
  // errors of successive presses are AR(1): the peaks' lag-1 correlation is about rho, their
  // SD stays, and the largest press of a session (the palpation_force measure) exceeds the
  // belief by less than with independent presses (fewer effectively independent draws).
  FlatTissue tissue;
  tissue.visual = false;
  tissue.audio = false;
  struct Result {
    double lag1, cv, max_excess;
  };
  auto run = [&](double rho) {
    const auto params = trainee_params(quick_searcher(
        {{"press_error_correlation", rho}, {"motor_noise_cv", 0.05}, {"weber_fraction", 0.08}}));
    double sxy = 0, sxx = 0, syy = 0, sx = 0, sy = 0, s2 = 0, s1 = 0, excess = 0;
    int pairs = 0, n = 0, sessions = 0;
    for (int k = 0; k < 30; ++k) {
      TraineeState st;
      st.initialised = true;
      st.prior_mean = st.target_mean = 2.4;
      st.prior_var = st.target_var = 0.01;
      st.place = tissue.feature;
      st.place_sd = 0.003;
      Trainee tr(params, st);
      const std::uint64_t ps = derive_seed(7, static_cast<std::uint64_t>(k));
      auto peaks = run_session(tr, tissue, 0.0, 90.0, ps, derive_seed(ps, 1));
      if (peaks.size() < 10) continue;
      for (std::size_t i = 0; i < peaks.size(); ++i) {
        const double e = peaks[i] / 2.4 - 1.0;
        s1 += e;
        s2 += e * e;
        ++n;
        if (i == 0) continue;
        const double x = peaks[i - 1] / 2.4 - 1.0;
        sx += x, sy += e, sxx += x * x, syy += e * e, sxy += x * e;
        ++pairs;
      }
      excess += *std::max_element(peaks.begin(), peaks.end()) - 2.4;
      ++sessions;
    }
    EXPECT_GE(sessions, 25);
    const double cov = sxy / pairs - sx / pairs * sy / pairs;
    const double vx = sxx / pairs - std::pow(sx / pairs, 2),
                 vy = syy / pairs - std::pow(sy / pairs, 2);
    return Result{cov / std::sqrt(vx * vy), std::sqrt(s2 / n - std::pow(s1 / n, 2)),
                  excess / sessions};
  };
  const Result indep = run(0.0), corr = run(0.8);
  std::printf("rho 0: lag-1 %.3f, CV %.3f, max - belief %.3f N; rho 0.8: %.3f, %.3f, %.3f N\n",
              indep.lag1, indep.cv, indep.max_excess, corr.lag1, corr.cv, corr.max_excess);
  // Independent presses: lag-1 correlation near 0 (about 30 x 30 pairs: SE ~ 0.035).
  EXPECT_LT(std::abs(indep.lag1), 0.15) << indep.lag1;
  EXPECT_NEAR(corr.lag1, 0.8, 0.12) << corr.lag1;
  // Each press keeps the SD of the combined motor and Weber error (sqrt(0.05^2 + 0.08^2) =
  // 0.094 with those two set here), correlated or not (the sessions' sample SDs are a bit smaller
  // when correlated).
  EXPECT_NEAR(indep.cv, 0.094, 0.02) << indep.cv;
  EXPECT_NEAR(corr.cv, 0.094, 0.03) << corr.cv;
  // The session maximum: about +2 SD for ~30 independent presses, clearly less when correlated.
  EXPECT_GT(indep.max_excess, 0.35) << indep.max_excess;
  EXPECT_LT(corr.max_excess, indep.max_excess - 0.1) << corr.max_excess << " " << indep.max_excess;
}

// With forgetting_contraction 1 the remembered mean decays towards the briefing, so the error
// of the learned target grows with the retention interval; with 0 (the shipped default since
// 2026-12-03) the mean is kept and the error is the same after 10 minutes as after a week (only
// the uncertainty grows: ForgettingContractionMovesOnlyTheMeansShare).
TEST(Trainee, LongerRetentionGivesLargerErrorOnlyWhenTheMeanContracts) {
  FlatTissue tissue;
  const double ref = 2.3;
  const nlohmann::json contract = {{"forgetting_contraction", 1.0}};
  double e_10min = mean_learned_error(tissue, contract, 4, 600.0, ref);
  double e_1day = mean_learned_error(tissue, contract, 4, 86400.0, ref);
  double e_7days = mean_learned_error(tissue, contract, 4, 7 * 86400.0, ref);
  EXPECT_LT(e_10min, e_1day) << e_10min << " " << e_1day;
  EXPECT_LT(e_1day, e_7days) << e_1day << " " << e_7days;
  const nlohmann::json keep = {{"forgetting_contraction", 0.0}};
  const double k_10min = mean_learned_error(tissue, keep, 4, 600.0, ref);
  const double k_7days = mean_learned_error(tissue, keep, 4, 7 * 86400.0, ref);
  EXPECT_GT(k_10min, 0.0);
  EXPECT_DOUBLE_EQ(k_10min, k_7days);
}

// forgetting_contraction: the share of the forgetting that moves the remembered target back to
// the briefing. The uncertainty decays to the briefing's in both cases; the mean by r at 1 (the
// model before 2026-12-03) and not at all at 0 (constant error unchanged by the retention
// interval, Laabs 1973), halfway at 0.5.
TEST(Trainee, ForgettingContractionMovesOnlyTheMeansShare) {
  FlatTissue tissue;
  const double week = 7 * 86400.0;
  for (double c : {1.0, 0.5, 0.0}) {
    const auto p = trainee_params({{"forgetting_contraction", c}});
    TraineeState st = briefed_state(tissue, 2.0);
    st.target_mean = 2.6;
    st.target_var = 0.01;
    st.last_session_end = 0.0;
    Trainee tr(p, st);
    tr.begin_session(tissue.view(), 2.5, week, 1.0, 7, 1, {});
    const double r = retention(week, p);
    ASSERT_GT(r, 0.0);
    ASSERT_LT(r, 0.9);  // a week forgets a good part
    EXPECT_NEAR(tr.state().target_mean, 2.0 + (1.0 - c * (1.0 - r)) * 0.6, 1e-12) << c;
    EXPECT_NEAR(tr.state().target_var, r * r * 0.01 + (1.0 - r * r) * st.prior_var, 1e-12) << c;
  }
}

TEST(Instructor, CallsAfterReactionTime) {
  // Fixed reaction times here (cv 0) so the call time is exact; variability is tested below.
  auto p = instructor_params({{"reaction_time_cv", 0.0}});
  Instructor in(p, 3);
  Percept q;
  q.contact = true;
  int call_step = -1;
  for (int i = 1; i <= 1000 && call_step < 0; ++i) {
    q.t = i * 0.001;
    q.audio = i >= 100;  // the sound starts at t = 0.1 s
    if (in.observe(q, Channels{false, false, true})) call_step = i;
  }
  EXPECT_EQ(call_step, 100 + 160);  // 0.16 s auditory reaction time
  // visual: calls when the deformation reaches the calibrated target (within its judgement noise)
  Instructor v(p, 4);
  v.set_target_deformation(0.003);
  call_step = -1;
  for (int i = 1; i <= 3000 && call_step < 0; ++i) {
    q.t = i * 0.001;
    q.audio = false;
    q.visible_deformation = 0.00001 * i;  // reaches 3 mm at step 300
    if (v.observe(q, Channels{false, true, false})) call_step = i;
  }
  EXPECT_GT(call_step, 300 * 0.6 + 190);
  EXPECT_LT(call_step, 300 * 1.4 + 190);
  // no cue it may perceive -> no call
  Instructor none(p, 5);
  none.set_target_deformation(0.0);
  bool any = false;
  for (int i = 1; i <= 1000; ++i) {
    q.t = i * 0.001;
    q.audio = true;
    any |= none.observe(q, Channels{true, false, false});
  }
  EXPECT_FALSE(any);
}

TEST(Instructor, ReactionTimesVaryWithTheGivenSpread) {
  auto p = instructor_params({});
  Instructor in(p, 8);
  double sum = 0, sum2 = 0;
  const int n = 400;
  Percept q;
  q.contact = true;
  for (int k = 0; k < n; ++k) {
    int call = -1;
    for (int i = 1; i <= 2000 && call < 0; ++i) {
      q.t = i * 0.001;
      q.audio = i >= 100;
      if (in.observe(q, Channels{false, false, true})) call = i;
    }
    ASSERT_GT(call, 0);
    double rt = (call - 100) * 0.001;
    sum += rt;
    sum2 += rt * rt;
    in.reset_press();
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.16, 0.01);
  EXPECT_NEAR(sd / 0.16, 0.15, 0.03);
}

TEST(Params, DefaultsComeFromTheStructAndEverySpecHasASource) {
  const TraineeParams def;
  for (const auto& s : trainee_param_specs()) {
    ASSERT_NE(s.trainee, nullptr) << s.name;
    EXPECT_DOUBLE_EQ(s.value, def.*(s.trainee)) << s.name;
    EXPECT_LE(s.min, s.value) << s.name;
    EXPECT_GE(s.max, s.value) << s.name;
    EXPECT_GT(std::string(s.source).size(), 5u) << s.name;
  }
  for (const auto& s : instructor_param_specs()) {
    ASSERT_NE(s.instructor, nullptr) << s.name;
    EXPECT_GT(std::string(s.source).size(), 5u) << s.name;
  }
}

TEST(Params, OverridesAreTypedAndBadNamesOrValuesAreInputErrors) {
  auto p = trainee_params({{"weber_fraction", 0.12}, {"hold_time", 0.5}});
  EXPECT_DOUBLE_EQ(p.weber_fraction, 0.12);
  EXPECT_DOUBLE_EQ(p.hold_time, 0.5);
  EXPECT_DOUBLE_EQ(p.motor_noise_cv, TraineeParams{}.motor_noise_cv);
  EXPECT_EQ(to_json(p)["hold_time"].get<double>(), 0.5);
  EXPECT_THROW(trainee_params({{"weber_fracton", 0.1}}), palplab::InputError);
  EXPECT_THROW(trainee_params({{"weber_fraction", 0.9}}), palplab::InputError);
  EXPECT_THROW(trainee_params({{"weber_fraction", "x"}}), palplab::InputError);
  EXPECT_DOUBLE_EQ(instructor_params({{"weber_fraction", 0.05}}).weber_fraction, 0.05);
}
