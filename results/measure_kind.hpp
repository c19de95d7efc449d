#pragma once
// palplab's own measures (computed in protocols/measures.cpp): one table for every module. The
// study validator takes from it the names a study may declare, their units and a task's default
// list; the store its checks of a database's values; the report the measures it analyses when
// a study declares no analyses; calibrate its range checks. The counts have unit "1" like the
// proportions (feature_identified) but are none: a count gets a t interval, never one of a
// proportion, even when every value is 0 or 1.
#include <array>
#include <limits>
#include <string_view>

namespace palplab::results {

struct MeasureKind {
  std::string_view name;
  std::string_view unit;
  std::string_view task;  // the task kind that records it: "palpation" or "needle_insertion"
  double hi;              // largest value (values are >= 0); infinity: none
  bool count;             // a count of events
  bool by_default;        // in the task's default list (a study without "measures")
};

inline constexpr double kNoBound = std::numeric_limits<double>::infinity();

inline constexpr std::array<MeasureKind, 11> kMeasureKinds = {{
    {"palpation_force", "N", "palpation", kNoBound, false, true},
    {"exploration_time", "s", "palpation", kNoBound, false, true},
    {"feature_identified", "1", "palpation", 1.0, false, true},
    {"accuracy", "%", "palpation", 100.0, false, true},
    {"palpations", "1", "palpation", kNoBound, true, false},
    {"sft_reached", "1", "palpation", kNoBound, true, false},
    {"insertion_attempts", "1", "needle_insertion", kNoBound, true, true},
    {"layers_passed", "1", "needle_insertion", kNoBound, true, true},
    {"tip_to_target_mm", "mm", "needle_insertion", kNoBound, false, true},
    {"bone_contacts", "1", "needle_insertion", kNoBound, true, true},
    {"procedure_time", "s", "needle_insertion", kNoBound, false, true},
}};

// The measure called name; nullptr for a name palplab does not compute.
inline const MeasureKind* find_measure_kind(std::string_view name) {
  for (const MeasureKind& m : kMeasureKinds)
    if (m.name == name) return &m;
  return nullptr;
}

// The task kind whose table rows apply ("needle_insertion", else the palpation task's).
inline std::string_view measure_task(std::string_view task_kind) {
  return task_kind == "needle_insertion" ? "needle_insertion" : "palpation";
}

inline bool is_count_measure(std::string_view measure) {
  const MeasureKind* m = find_measure_kind(measure);
  return m && m->count;
}

}  // namespace palplab::results
