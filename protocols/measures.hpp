#pragma once
// Session measures computed from the LOGGED samples and events (never from the participant
// model's internals), so a session replayed from the database gives the same numbers:
//   feature_identified  1 if the contact stayed on the feature region for identify_dwell s
//   exploration_time    s from the session start to that identification (undefined if none)
//   palpation_force     N, the largest |F| from the identification to the session end
//   accuracy            %, palpations after the identification whose peak |F| is within
//                       accuracy_tolerance of the feature's MPF (undefined without palpations)
//   palpations          number of palpations after the identification (a contact whose peak
//                       |F| reaches palpation_onset)
//   sft_reached         number of sft_reached events (threshold exceedances)
#include <vector>

#include "results/store.hpp"

namespace palplab::protocols {

struct MeasureInputs {
  const results::SampleSeries* samples = nullptr;
  const std::vector<results::EventRecord>* events = nullptr;
  const std::vector<int>* vertex_region = nullptr;  // #V region index per surface node
  int feature_region = -1;
  double mpf = 0.0;                  // N, the feature's MPF
  double accuracy_tolerance = 0.25;  // N
  double identify_dwell = 0.2;       // s
  double palpation_onset = 0.5;      // N
};

std::vector<results::MeasureRecord> compute_measures(const MeasureInputs& in);

// Needle-insertion measures from the logged events of a session (docs/FORMATS.md "Needle"):
//   insertion_attempts  number of insertion_start events (the tip passed the skin surface)
//   layers_passed       distinct tissues entered (tissue_entered) in the last insertion
//   tip_to_target_mm    mm, the last logged tip_to_target of the session (undefined if none)
//   bone_contacts       number of bone_contact events
//   procedure_time      s from the session start to the last needle event (insertion_start,
//                       tissue_entered/left, bone_contact, target_reached, tip_to_target): when
//                       the needle last moved in the tissue (undefined without an insertion)
std::vector<results::MeasureRecord> compute_needle_measures(
    const std::vector<results::EventRecord>& events);

}  // namespace palplab::protocols
