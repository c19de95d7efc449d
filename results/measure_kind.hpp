#pragma once
// What kind of quantity each of palplab's own measures is where its unit does not say it: the
// counts (protocols/measures.cpp) have unit "1" like the proportions (feature_identified) but
// are none. One list for every module: the report's intervals (a count gets a t interval, never
// one of a proportion, even when every value is 0 or 1), calibrate's range checks.
#include <string_view>

namespace palplab::results {

inline bool is_count_measure(std::string_view measure) {
  return measure == "palpations" || measure == "sft_reached" || measure == "insertion_attempts" ||
         measure == "layers_passed" || measure == "bone_contacts";
}

}  // namespace palplab::results
