#include "protocols/measures.hpp"

#include <cmath>
#include <optional>
#include <set>

namespace palplab::protocols {

std::vector<results::MeasureRecord> compute_measures(const MeasureInputs& in) {
  const auto& s = *in.samples;
  const std::size_t n = s.size();
  auto region = [&](std::size_t i) {
    int node = s.node[i];
    if (node < 0 || node >= static_cast<int>(in.vertex_region->size())) return -1;
    return (*in.vertex_region)[node];
  };
  auto force = [&](std::size_t i) {
    return std::sqrt(s.F[3 * i] * s.F[3 * i] + s.F[3 * i + 1] * s.F[3 * i + 1] +
                     s.F[3 * i + 2] * s.F[3 * i + 2]);
  };
  // Identification: the first moment the contact has stayed on the feature for the dwell time.
  std::optional<std::size_t> id_index;
  double on_since = -1.0;
  for (std::size_t i = 0; i < n; ++i) {
    double t = s.t0 + (i + 1) * s.dt;  // a sample is taken at the end of its step
    if (region(i) == in.feature_region && in.feature_region >= 0) {
      if (on_since < 0) on_since = t - s.dt;
      if (t - on_since >= in.identify_dwell - 1e-12) {
        id_index = i;
        break;
      }
    } else {
      on_since = -1.0;
    }
  }
  std::optional<double> force_max, exploration, accuracy;
  int palpations = 0, accurate = 0;
  if (id_index) {
    exploration = s.t0 + (*id_index + 1) * s.dt;
    double fmax = 0.0, peak = 0.0;
    bool in_contact = false;
    auto close_contact = [&] {
      if (in_contact && peak >= in.palpation_onset) {
        ++palpations;
        if (std::abs(peak - in.mpf) <= in.accuracy_tolerance) ++accurate;
      }
      in_contact = false;
      peak = 0.0;
    };
    for (std::size_t i = *id_index; i < n; ++i) {
      const double f = force(i);
      fmax = std::max(fmax, f);
      if (s.node[i] >= 0) {
        in_contact = true;
        peak = std::max(peak, f);
      } else {
        close_contact();
      }
    }
    close_contact();  // a palpation still going on at the session end counts
    force_max = fmax;
    if (palpations > 0) accuracy = 100.0 * accurate / palpations;
  }
  int sft = 0;
  if (in.events)
    for (const auto& e : *in.events) sft += e.kind == "sft_reached";
  return {{"palpation_force", force_max, "N"},
          {"exploration_time", exploration, "s"},
          {"feature_identified", id_index ? 1.0 : 0.0, "1"},
          {"accuracy", accuracy, "%"},
          {"palpations", static_cast<double>(palpations), "1"},
          {"sft_reached", static_cast<double>(sft), "1"}};
}

std::vector<results::MeasureRecord> compute_needle_measures(
    const std::vector<results::EventRecord>& events) {
  int attempts = 0, bones = 0;
  std::set<std::string> layers;  // tissues (by name, else attribute) of the last insertion
  std::optional<double> distance, last_t;
  for (const auto& e : events) {
    const std::string& k = e.kind;
    const bool needle = k == "insertion_start" || k == "tissue_entered" || k == "tissue_left" ||
                        k == "bone_contact" || k == "target_reached" || k == "tip_to_target";
    if (!needle) continue;
    last_t = e.t;
    if (k == "insertion_start") {
      ++attempts;
      layers.clear();
    } else if (k == "tissue_entered") {
      layers.insert(e.region.empty() ? std::to_string(static_cast<int>(e.value)) : e.region);
    } else if (k == "bone_contact") {
      ++bones;
    } else if (k == "tip_to_target") {
      distance = 1000.0 * e.value;
    }
  }
  return {{"insertion_attempts", static_cast<double>(attempts), "1"},
          {"layers_passed", static_cast<double>(layers.size()), "1"},
          {"tip_to_target_mm", distance, "mm"},
          {"bone_contacts", static_cast<double>(bones), "1"},
          {"procedure_time", last_t, "s"}};
}

}  // namespace palplab::protocols
