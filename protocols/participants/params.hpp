#pragma once
// Parameters of the virtual trainee and instructor models (docs/PARTICIPANTS.md gives the model,
// each parameter's meaning and its literature source). A study's "participant_model.parameters"
// and "roles.instructor.parameters" override the defaults by name; unknown names and values
// outside [min, max] are input errors.
//
// Nothing here (or anywhere in the models) depends on a prototype's id or name: the models see
// only what the simulator renders.
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace palplab::protocols::participants {

struct ParamSpec {
  const char* name;
  double value;  // default
  double min, max;
  const char* unit;
  const char* meaning;
};

const std::vector<ParamSpec>& trainee_param_specs();
const std::vector<ParamSpec>& instructor_param_specs();

// Defaults overridden by `overrides` (an object name -> number; validated before).
std::map<std::string, double> resolve_params(const std::vector<ParamSpec>& specs,
                                             const nlohmann::json& overrides);

}  // namespace palplab::protocols::participants
