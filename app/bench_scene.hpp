#pragma once
// Shared pieces of the scene-level bench sections (app/bench_section_*.cpp): prototype variants
// written as JSON files (the shipped prototypes/*.json with keys changed, docs/FORMATS.md), a
// fixed-trajectory press timed step by step, and figure output.
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "app/bench.hpp"
#include "engine/haptics/scene.hpp"

namespace palplab::app {

// The bench's scratch directory, <tmp>/palplab_bench_<pid>: made on first use, removed with
// what it holds when the process exits.
const std::filesystem::path& bench_scratch_dir();

// prototypes/<id>.json with `edit` applied, written to bench_scratch_dir() as <id>_<tag>.json;
// returns its path (build it with prototypes::build_scene).
std::string prototype_variant(const BenchOptions& o, const std::string& id, const std::string& tag,
                              const std::function<void(nlohmann::json&)>& edit);

// One press whose trajectory does not depend on the force (so runs of different models are
// compared at the same device positions and times): the HCP starts 2 mm outside the node of
// `region` nearest its centroid and moves along the inward normal at 2 cm/s to `depth` (m),
// holds until `steps` haptic steps have passed (the one press script, engine/haptics/press.hpp,
// under position control, in lock-step). Per step: wall time (s), force magnitude (N),
// visible deformation (m), depth (m).
struct PressTrace {
  std::vector<double> step_s, contact_step_s, force, deformation, depth;
  long awake_max = 0;
  bool diverged = false;
};
PressTrace fixed_press(engine::Scene& s, const std::string& region, double depth, int steps);

// max_k |a_k - b_k| / max_k |b_k| over the common length (b is the reference).
double max_rel_diff(const std::vector<double>& a, const std::vector<double>& b);

// Writes `svg` to <svg_dir>/<file> when figures were asked for.
void write_figure(const BenchOptions& o, const std::string& file, const std::string& svg);

}  // namespace palplab::app
