#pragma once
// The evaluations of a calibration, written as they finish (one JSON line each), so that an
// interrupted `palplab calibrate` loses nothing: the same command reads back the lines of the
// same set-up and the optimiser retraces its path from them without simulating (common random
// numbers make a simulation a deterministic function of the parameters), then goes on. A fit of
// hours can so run in parts (docs/PARTICIPANTS.md, "Calibration").
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "protocols/calibrate.hpp"

namespace palplab::protocols {

// What a simulated loss depends on besides the parameters: the study as simulated (its text, the
// group size and its prototypes' files), the fitted names and the human cells the loss compares
// with. Lines of another set-up are kept in the file but not used. The palplab that simulates is
// not part of it (a fit of hours runs in parts, across builds): each line names the build that
// wrote it, and the start, simulated again, must equal its stored evaluation.
std::string calibration_setup(const Study& study, int sim_n, const std::vector<std::string>& keys,
                              const std::vector<HumanCell>& used);

class CalibrationJournal {
 public:
  // Opens `path` for appending (created if missing) and reads its lines of `setup` back; a last
  // line cut short by an interruption is cut off. InputError naming the file when it cannot be
  // read or written, or holds a line that is not a calibration evaluation.
  CalibrationJournal(const std::string& path, const std::string& setup,
                     const std::vector<HumanCell>& used);
  ~CalibrationJournal();
  CalibrationJournal(const CalibrationJournal&) = delete;
  CalibrationJournal& operator=(const CalibrationJournal&) = delete;

  // The stored evaluation at exactly x, or nullptr.
  const std::pair<double, std::vector<CellFit>>* find(const std::vector<double>& x) const;
  // Appends an evaluation, flushed before it returns (InputError when the write fails).
  void append(const std::vector<double>& x, double loss, const std::vector<CellFit>& fit);
  // Evaluations of this set-up read from the file.
  int stored() const { return static_cast<int>(stored_.size()); }
  // Of those, how many another palplab build wrote (used when the start's check passes).
  int other_build() const { return other_build_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_, setup_;
  std::FILE* file_ = nullptr;
  int other_build_ = 0;
  std::map<std::vector<double>, std::pair<double, std::vector<CellFit>>> stored_;
};

// Whether `path` holds a calibration journal (its first line is an evaluation), for the
// output checks of `--journal`.
bool is_calibration_journal(const std::string& path);

}  // namespace palplab::protocols
