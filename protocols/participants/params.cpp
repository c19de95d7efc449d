#include "protocols/participants/params.hpp"

namespace palplab::protocols::participants {

const std::vector<ParamSpec>& trainee_param_specs() {
  static const std::vector<ParamSpec> specs = {
      {"weber_fraction", 0.08, 0.01, 0.5, "1",
       "haptic force JND as a fraction of force; perception SD = weber_fraction * F"},
      {"visual_weber", 0.10, 0.01, 1.0, "1", "relative SD of the perceived visible deformation"},
      {"motor_noise_cv", 0.05, 0.0, 0.5, "1",
       "signal-dependent motor noise: SD of the produced force / intended force"},
      {"prior_target_cv", 0.30, 0.0, 2.0, "1",
       "relative SD of the target force believed after the briefing (MPF told in words)"},
      {"memory_noise_cv", 0.03, 0.0, 1.0, "1",
       "relative SD added to the force memory each time it is stored"},
      {"forgetting_exponent", 0.05, 0.0, 2.0, "1",
       "power-law forgetting: learned share kept = (1 + dt/forgetting_tau)^-exponent"},
      {"forgetting_tau", 60.0, 1e-3, 1e7, "s", "time scale of the power law"},
      {"consolidation_time", 21600.0, 0.0, 1e8, "s",
       "after this delay a memory is consolidated: forgetting slows by consolidated_factor"},
      {"consolidated_factor", 0.5, 0.0, 1.0, "1",
       "exponent multiplier for the part of a retention interval after consolidation"},
      {"spatial_prior_sd", 0.03, 0.0, 1.0, "m",
       "SD of the believed feature position before any session (briefing: anatomy)"},
      {"spatial_memory_sd", 0.01, 0.0, 1.0, "m", "SD of storing a found feature position"},
      {"spatial_forgetting_sd", 0.01, 0.0, 1.0, "m",
       "spatial SD added at full forgetting (scaled by the same power law)"},
      {"explore_speed", 0.05, 1e-4, 2.0, "m/s", "HCP speed while searching the surface"},
      {"press_speed", 0.004, 1e-5, 1.0, "m/s", "HCP speed into the surface while pressing"},
      {"release_speed", 0.02, 1e-5, 1.0, "m/s", "HCP speed out of the surface on release"},
      {"recognition_time", 0.3, 0.0, 10.0, "s",
       "light-touch time needed to tell whether the touched part is the feature"},
      {"hold_time", 0.3, 0.0, 10.0, "s", "hold at the intended force before releasing"},
      {"rest_time", 1.0, 0.0, 60.0, "s", "pause between palpations"},
      {"reaction_time_audio", 0.16, 0.0, 2.0, "s", "simple reaction time to a sound"},
      {"reaction_time_visual", 0.19, 0.0, 2.0, "s", "simple reaction time to a visual event"},
      {"reaction_time_cv", 0.15, 0.0, 1.0, "1",
       "trial-to-trial SD of a reaction time / its mean (truncated at 0.3x the mean)"},
      {"lift_height", 0.01, 0.0, 0.2, "m", "height above the surface while moving between points"},
      {"max_force", 10.0, 0.5, 100.0, "N",
       "largest force the trainee will push against; above it the hand yields along the felt "
       "force and a press ends"},
  };
  return specs;
}

const std::vector<ParamSpec>& instructor_param_specs() {
  static const std::vector<ParamSpec> specs = {
      {"reaction_time_audio", 0.16, 0.0, 2.0, "s", "time from the sound to the call"},
      {"reaction_time_visual", 0.19, 0.0, 2.0, "s", "time from seeing the target deformation"},
      {"reaction_time_cv", 0.15, 0.0, 1.0, "1",
       "trial-to-trial SD of a reaction time / its mean (truncated at 0.3x the mean)"},
      {"visual_weber", 0.10, 0.01, 1.0, "1",
       "relative SD of the instructor's deformation judgement"},
      {"trainee_reaction_time", 0.16, 0.0, 2.0, "s", "trainee's reaction to the spoken call"},
  };
  return specs;
}

std::map<std::string, double> resolve_params(const std::vector<ParamSpec>& specs,
                                             const nlohmann::json& overrides) {
  std::map<std::string, double> p;
  for (const auto& s : specs) p[s.name] = s.value;
  if (overrides.is_object())
    for (auto it = overrides.begin(); it != overrides.end(); ++it)
      if (p.count(it.key()) && it.value().is_number()) p[it.key()] = it.value().get<double>();
  return p;
}

}  // namespace palplab::protocols::participants
