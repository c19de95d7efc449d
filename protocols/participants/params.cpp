#include "protocols/participants/params.hpp"

#include <cmath>
#include <string_view>

#include "common/input_error.hpp"

namespace palplab::protocols::participants {

namespace {

using T = TraineeParams;
using I = InstructorParams;

ParamSpec tspec(const char* name, double T::*m, double lo, double hi, const char* unit,
                const char* meaning, const char* source) {
  return {name, TraineeParams{}.*m, lo, hi, unit, meaning, source, m, nullptr};
}
ParamSpec ispec(const char* name, double I::*m, double lo, double hi, const char* unit,
                const char* meaning, const char* source) {
  return {name, InstructorParams{}.*m, lo, hi, unit, meaning, source, nullptr, m};
}

constexpr const char* kRt =
    "Kosinski 2008 (review of simple reaction times: ~0.16 s to sound, "
    "~0.19 s to light)";

// Overrides applied to a struct through the spec table; `set` writes one field.
template <class P, class Set>
P apply(const std::vector<ParamSpec>& specs, const nlohmann::json& overrides,
        const std::string& where, Set set) {
  P p;
  if (overrides.is_null()) return p;
  if (!overrides.is_object())
    throw InputError("participant parameters: expected an object of name -> number", where);
  for (auto it = overrides.begin(); it != overrides.end(); ++it) {
    const ParamSpec* s = find_param(specs, it.key());
    if (!s) {
      std::string names;
      for (const auto& x : specs) names += std::string(names.empty() ? "" : ", ") + x.name;
      throw InputError(
          "unknown participant parameter \"" + it.key() + "\"; expected one of: " + names, where);
    }
    if (!it.value().is_number())
      throw InputError("participant parameter \"" + it.key() + "\": expected a number", where);
    const double v = it.value().get<double>();
    if (!(v >= s->min && v <= s->max))
      throw InputError("participant parameter \"" + it.key() + "\": expected a value in [" +
                           nlohmann::json(s->min).dump() + ", " + nlohmann::json(s->max).dump() +
                           "]" + (std::string(s->unit) == "1" ? "" : " " + std::string(s->unit)) +
                           ", got " + nlohmann::json(v).dump(),
                       where);
    set(p, *s, v);
  }
  return p;
}

}  // namespace

const std::vector<ParamSpec>& trainee_param_specs() {
  static const std::vector<ParamSpec> specs = {
      tspec("weber_fraction", &T::weber_fraction, 0.01, 0.5, "1",
            "haptic force JND as a fraction of force; perception SD = weber_fraction * F",
            "Jones 1989; Pang, Tan & Durlach 1991 (force JND 7-10 %)"),
      tspec("visual_weber", &T::visual_weber, 0.01, 1.0, "1",
            "relative SD of the perceived visible deformation",
            "Ernst & Banks 2002 (visual size estimates, SD a few % to >10 % with noise)"),
      tspec("motor_noise_cv", &T::motor_noise_cv, 0.0, 0.5, "1",
            "signal-dependent motor noise: SD of the produced force / intended force",
            "Harris & Wolpert 1998 (SD proportional to force)"),
      tspec("press_error_correlation", &T::press_error_correlation, 0.0, 0.99, "1",
            "lag-1 correlation of the motor and haptic errors of successive presses of a "
            "session (AR(1), stationary: each error keeps its SD)",
            "Gilden, Thornton & Mallon 1995; van Beers 2009 (serially correlated errors of "
            "repeated productions without feedback)"),
      tspec("prior_target_cv", &T::prior_target_cv, 0.0, 2.0, "1",
            "relative SD of the target force believed after the briefing (MPF told in words)",
            "model assumption; fitted to exp2 (docs/PARTICIPANTS.md)"),
      tspec("memory_noise_cv", &T::memory_noise_cv, 0.0, 1.0, "1",
            "relative SD added to the force memory each time it is stored",
            "model assumption (memory noise of the Kalman observation)"),
      tspec("forgetting_exponent", &T::forgetting_exponent, 0.0, 2.0, "1",
            "power-law forgetting: learned share kept = (1 + dt/forgetting_tau)^-exponent",
            "Wixted & Ebbesen 1991 (power law of forgetting)"),
      tspec("forgetting_tau", &T::forgetting_tau, 1e-3, 1e7, "s", "time scale of the power law",
            "Wixted & Ebbesen 1991"),
      tspec("consolidation_time", &T::consolidation_time, 0.0, 1e8, "s",
            "after this delay a memory is consolidated: forgetting slows by consolidated_factor",
            "Brashers-Krug, Shadmehr & Bizzi 1996 (motor memory consolidates within 4-6 h)"),
      tspec("consolidated_factor", &T::consolidated_factor, 0.0, 1.0, "1",
            "exponent multiplier for the part of a retention interval after consolidation",
            "Walker et al. 2003 (consolidated motor memories are more stable)"),
      tspec("forgetting_contraction", &T::forgetting_contraction, 0.0, 1.0, "1",
            "share of the forgetting that moves the remembered target force back towards the "
            "briefing (1: mean and uncertainty decay; 0: the mean is kept, the uncertainty grows)",
            "Laabs 1973 (motor short-term memory: the constant error of a reproduction does "
            "not change with the retention interval, the variable error grows)"),
      tspec("spatial_prior_sd", &T::spatial_prior_sd, 0.0, 1.0, "m",
            "SD of the believed feature position before any session (briefing: anatomy)",
            "model assumption"),
      tspec("spatial_memory_sd", &T::spatial_memory_sd, 0.0, 1.0, "m",
            "SD of storing a found feature position", "model assumption"),
      tspec("spatial_forgetting_sd", &T::spatial_forgetting_sd, 0.0, 1.0, "m",
            "spatial SD added at full forgetting (scaled by the same power law)",
            "model assumption"),
      tspec("explore_speed", &T::explore_speed, 1e-4, 2.0, "m/s",
            "HCP speed while searching the surface", "model assumption"),
      tspec("press_speed", &T::press_speed, 1e-5, 1.0, "m/s",
            "HCP speed into the surface while pressing",
            "model assumption (slow deliberate press)"),
      tspec("release_speed", &T::release_speed, 1e-5, 1.0, "m/s",
            "HCP speed out of the surface on release", "model assumption"),
      tspec("recognition_time", &T::recognition_time, 0.0, 30.0, "s",
            "median light-touch time a novice needs to tell whether the touched part is the "
            "feature (before practice)",
            "Klatzky, Lederman & Metzger 1985 (haptic recognition of objects takes 1-2 s)"),
      tspec("hold_time", &T::hold_time, 0.0, 10.0, "s",
            "hold at the intended force before releasing", "model assumption"),
      tspec("rest_time", &T::rest_time, 0.0, 60.0, "s", "pause between palpations",
            "model assumption"),
      tspec("reaction_time_audio", &T::reaction_time_audio, 0.0, 2.0, "s",
            "simple reaction time to a sound", kRt),
      tspec("reaction_time_visual", &T::reaction_time_visual, 0.0, 2.0, "s",
            "simple reaction time to a visual event", kRt),
      tspec("reaction_time_cv", &T::reaction_time_cv, 0.0, 1.0, "1",
            "trial-to-trial SD of a reaction time / its mean (truncated at 0.3x the mean)",
            "Luce 1986 (RT distributions, CV ~0.1-0.2)"),
      tspec("lift_height", &T::lift_height, 0.0, 0.2, "m",
            "height above the surface while moving between points", "model assumption"),
      tspec("max_force", &T::max_force, 0.5, 100.0, "N",
            "largest force the trainee will push against; above it the hand yields along the "
            "felt force and a press ends",
            "model assumption (far above the 2.5-5 N task forces)"),
      tspec("guidance_dependence", &T::guidance_dependence, 0.0, 1.0, "1",
            "share of the learning from a binary target marker (sound, call) that does not reach "
            "the internal force memory when the trainee fully relies on the marker",
            "guidance hypothesis: Salmoni, Schmidt & Walter 1984; Winstein & Schmidt 1990"),
      tspec("guidance_rate", &T::guidance_rate, 0.0, 1.0, "1",
            "reliance on a marker gained per press in which it came (reliance += rate*(1-r))",
            "Salmoni, Schmidt & Walter 1984 (dependence grows with frequent feedback)"),
      tspec("extinction_rate", &T::extinction_rate, 0.0, 1.0, "1",
            "share of the reliance lost per press in which an expected marker did not come",
            "model assumption (extinction of an expectation)"),
      tspec("marker_wait_overshoot", &T::marker_wait_overshoot, 0.0, 2.0, "1",
            "a press awaiting a marker goes on to intended*(1+overshoot*reliance) per miss",
            "Winstein & Schmidt 1990 (performance drops once the guiding feedback is withdrawn)"),
      tspec("overshoot_individual_cv", &T::overshoot_individual_cv, 0.0, 2.0, "1",
            "between-person SD (log scale) of a factor on marker_wait_overshoot: how far this "
            "person's press goes on awaiting a marker (lognormal, median 1, drawn at the briefing)",
            "Park, Shea & Wright 2000 (dependence on concurrent feedback, shown by the error once "
            "it is withdrawn); its spread between people: a model assumption fitted to exp2"),
      tspec(
          "visual_volume_weight", &T::visual_volume_weight, 0.0, 1.0, "1",
          "how much a seen deformation is judged by the volume the whole drawn surface is "
          "pushed in by rather than by the indentation under the probe (log-linear mix)",
          "softness is seen in the whole object's deformation (J Vis abstract, "
          "jov.arvojournals.org articleid 2699219: features of the whole mesh predict it, r = "
          ".93; Bi et al. 2019, J Vis 19(5):18); the weight a model assumption, off until fitted"),
      tspec("visual_spatial_sd", &T::visual_spatial_sd, 1e-5, 1.0, "m",
            "SD of locating the touched point by eye when it visibly deforms; combined with the "
            "haptic SD (spatial_memory_sd) by inverse variances",
            "van Beers, Sittig & Denier van der Gon 1999 (visual-proprioceptive localisation)"),
      tspec("visual_recognition_gain", &T::visual_recognition_gain, 0.0, 10.0, "1",
            "recognition time / (1 + gain) when the touched part visibly deforms",
            "Ernst & Banks 2002 (a second cue makes the judgement more reliable, so faster)"),
      tspec("compliance_recognition_gain", &T::compliance_recognition_gain, 0.0, 10.0, "1",
            "a landmark judgement whose felt stiffness (force / hand travel since the touch) "
            "differs from the session's previous landmark's by more than stiffness_weber counts "
            "gain more practice judgements (0: off)",
            "Lederman & Klatzky 1987 (pressure reveals hardness); Ernst & Banks 2002 (a second "
            "cue)"),
      tspec("stiffness_weber", &T::stiffness_weber, 0.01, 2.0, "1",
            "stiffness JND / stiffness: the felt difference between landmarks that counts",
            "Jones & Hunter 1990 (stiffness Weber fraction 23 %)"),
      tspec("recognition_cv", &T::recognition_cv, 0.0, 2.0, "1",
            "trial-to-trial SD / mean of a recognition time (lognormal)",
            "Luce 1986 (decision times are right-skewed)"),
      tspec("miss_probability", &T::miss_probability, 0.0, 0.95, "1",
            "chance that touching the feature does not lead to recognising it (search goes on)",
            "model assumption (novices misjudge what they touch)"),
      tspec("practice_exponent", &T::practice_exponent, 0.0, 2.0, "1",
            "recognition time * (1 + sessions in which the feature was found)^-exponent; landmark "
            "time * (1 + landmark judgements made)^-exponent",
            "Newell & Rosenbloom 1981 (power law of practice); value fitted to exp2 A/B "
            "(2026-12-04)"),
      tspec("individual_cv", &T::individual_cv, 0.0, 2.0, "1",
            "between-person SD (log scale) of a speed factor on exploration and recognition",
            "individual differences in speed; value fitted to the whole exp2 (2026-12-05)"),
      tspec("landmark_spacing", &T::landmark_spacing, 0.0, 1.0, "m",
            "orienting: distance between the landmarks touched on the route from where the hand "
            "first meets the organ to the believed feature position (0: no orienting, the "
            "search starts at the believed position)",
            "landmark-based haptic navigation (Lederman & Klatzky 1987: without vision a scene "
            "is learnt by following its contours; Klatzky & Lederman 2003); value to be fitted"),
      tspec("landmark_time", &T::landmark_time, 0.0, 60.0, "s",
            "median time a novice of average speed needs to judge where the hand is at one "
            "landmark (light touch; shortened by practice like recognition_time)",
            "Lederman & Klatzky 1987 (an exploratory procedure takes ~1-10 s, contour following "
            "the longest); Klatzky, Lederman & Metzger 1985 (1-2 s per object); value fitted "
            "with practice_exponent to exp2 A/B (2026-12-04)"),
      tspec("trace_speed", &T::trace_speed, 1e-4, 1.0, "m/s",
            "hand speed from one landmark to the next while orienting (slower than a seen reach)",
            "Lederman & Klatzky 1987 (deliberate exploratory movements of a few cm/s); value "
            "an assumption"),
      tspec("press_at_demonstrated_place", &T::press_at_demonstrated_place, 0, 1, "1",
            "1: once the feature is found every press aims at the place where the target press "
            "was demonstrated (the feature's centre; scatter visual_spatial_sd per axis); 0: the "
            "presses stay where the search touched the feature (values above 0 count as 1)",
            "observational learning takes over a demonstration's goal, its end point (Hodges, "
            "Williams, Hayes & Breslin 2007); switch, not fitted"),
      // ---- needle insertion
      tspec("palpation_grid", &T::palpation_grid, 1, 15, "1",
            "needle task: points per side of the square grid palpated around the believed entry "
            "point (rounded to an integer)",
            "model assumption (landmark palpation before a joint injection: feel the bony "
            "prominences around the soft spot; Sibbitt et al. 2011 on blind injection technique)"),
      tspec("palpation_spacing", &T::palpation_spacing, 0.001, 0.05, "m",
            "needle task: distance between palpated points (about a fingertip's width or less)",
            "model assumption (two-point discrimination of the fingertip is 2-3 mm; Johnson & "
            "Phillips 1981)"),
      tspec("palpation_depth", &T::palpation_depth, 0.001, 0.03, "m",
            "needle task: how deep each palpation presses the skin in",
            "model assumption (a firm clinical palpation indents soft tissue by some mm)"),
      tspec("palpation_speed", &T::palpation_speed, 1e-3, 0.5, "m/s",
            "needle task: finger speed into and out of the skin", "model assumption"),
      tspec("aim_angle_sd", &T::aim_angle_sd, 0.0, 0.5, "rad",
            "needle task: SD of the needle direction about the intended one (per insertion)",
            "model assumption of the order of free-hand needle angle errors of a few degrees "
            "(e.g. 2-5 deg in free-hand insertion studies); value to be fitted"),
      tspec("aim_position_sd", &T::aim_position_sd, 0.0, 0.02, "m",
            "needle task: SD of the skin entry point about the chosen one (per insertion, "
            "tangential)",
            "model assumption (free-hand positioning error of about a millimetre)"),
      tspec("needle_speed", &T::needle_speed, 1e-4, 0.1, "m/s",
            "needle task: insertion speed along the needle",
            "Okamura, Simone & O'Leary 2004 (insertions at about 3 mm/s); a clinician's pace "
            "of a few mm/s"),
      tspec("depth_prior_cv", &T::depth_prior_cv, 0.0, 1.0, "1",
            "needle task: relative SD of the target depth belief left by the briefing (the "
            "belief is updated only where the tip is seen reaching the target)",
            "model assumption (analogous to prior_target_cv)"),
      tspec("bone_stop_force", &T::bone_stop_force, 0.1, 8.0, "N",
            "needle task: an axial force this high without a pop is taken for bone: the trainee "
            "withdraws and inserts again",
            "model assumption (above the puncture forces of skin and capsule, ~1-1.5 N; "
            "Abolhassani et al. 2007)"),
      tspec("pop_drop", &T::pop_drop, 0.01, 5.0, "N",
            "needle task: a drop of the felt axial force this large is a felt puncture (pop)",
            "model assumption (several times the haptic JND of ~0.1 N at 1 N; Jones 1989)"),
      tspec("pop_window", &T::pop_window, 0.0, 1.0, "1",
            "needle task: a pop felt within this share of the believed target depth is taken "
            "for the capsule (loss of resistance) and the insertion stops there",
            "model assumption (clinicians stop at the capsule pop near the expected depth)"),
      tspec("max_insertions", &T::max_insertions, 1, 20, "1",
            "needle task: insertions (after bone contact) before the trainee stops trying",
            "model assumption (clinical practice limits redirections)"),
  };
  return specs;
}

const std::vector<ParamSpec>& instructor_param_specs() {
  static const std::vector<ParamSpec> specs = {
      ispec("reaction_time_audio", &I::reaction_time_audio, 0.0, 2.0, "s",
            "time from the sound to the call", kRt),
      ispec("reaction_time_visual", &I::reaction_time_visual, 0.0, 2.0, "s",
            "time from seeing the target deformation", kRt),
      ispec("reaction_time_cv", &I::reaction_time_cv, 0.0, 1.0, "1",
            "trial-to-trial SD of a reaction time / its mean (truncated at 0.3x the mean)",
            "Luce 1986"),
      ispec("visual_weber", &I::visual_weber, 0.01, 1.0, "1",
            "relative SD of the instructor's deformation judgement", "Ernst & Banks 2002"),
      ispec("trainee_reaction_time", &I::trainee_reaction_time, 0.0, 2.0, "s",
            "trainee's reaction to the spoken call", kRt),
      ispec("weber_fraction", &I::weber_fraction, 0.01, 0.5, "1",
            "the instructor's haptic force JND / force, in the own calibration press",
            "Jones 1989; Pang, Tan & Durlach 1991"),
  };
  return specs;
}

bool needle_task_param(const ParamSpec& spec) {
  return std::string_view(spec.meaning).starts_with("needle task:");
}

const ParamSpec* find_param(const std::vector<ParamSpec>& specs, const std::string& name) {
  for (const auto& s : specs)
    if (name == s.name) return &s;
  return nullptr;
}

TraineeParams trainee_params(const nlohmann::json& overrides, const std::string& where) {
  return apply<TraineeParams>(
      trainee_param_specs(), overrides, where,
      [](TraineeParams& p, const ParamSpec& s, double v) { p.*(s.trainee) = v; });
}

InstructorParams instructor_params(const nlohmann::json& overrides, const std::string& where) {
  return apply<InstructorParams>(
      instructor_param_specs(), overrides, where,
      [](InstructorParams& p, const ParamSpec& s, double v) { p.*(s.instructor) = v; });
}

nlohmann::json to_json(const TraineeParams& p) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& s : trainee_param_specs()) j[s.name] = p.*(s.trainee);
  return j;
}

nlohmann::json to_json(const InstructorParams& p) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& s : instructor_param_specs()) j[s.name] = p.*(s.instructor);
  return j;
}

}  // namespace palplab::protocols::participants
