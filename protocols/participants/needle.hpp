#pragma once
// The virtual trainee of a needle-insertion task (docs/PARTICIPANTS.md "Needle insertion"). Like
// the palpation trainee it acts only on what the simulator renders (force on the hand; with
// the transparency cue the tip's distance to the target and the tissue at the tip) plus the
// briefing (an atlas description: roughly where to enter and how deep the target lies).
//
// 1. Landmark-guided entry point: the believed entry point (the briefed one, misremembered by
//    spatial_prior_sd) is the centre of a square grid of palpation_grid^2 skin points,
//    palpation_spacing apart. The finger presses each point palpation_depth in along the skin
//    normal and judges the force at full depth (Weber error). Where bone lies close under the
//    skin the tissue feels stiffer, so the entry is the softest point: the gap between the bony
//    prominences.
// 2. Insertion: the needle is aimed along the inward skin normal of the chosen point, with an
//    angular error (aim_angle_sd) and an entry offset (aim_position_sd), and advanced at
//    needle_speed. Stop rules: with the tip visible, when it is seen in the target tissue;
//    otherwise at the believed depth, or earlier at a felt pop (force drop >= pop_drop) within
//    pop_window of it (loss of resistance). A steady force >= bone_stop_force without a pop is
//    bone: pull out and insert again (new aim), at most max_insertions times.
// 3. Learning: a target seen reached gives the depth at which it was reached (visual error
//    visual_spatial_sd), merged into the depth belief like the force belief (Kalman update).
//    A visible miss is knowledge of results too: the depth at which the drawn tip passed
//    closest to the target is an observation of the target's depth whose error grows with the
//    miss distance r (variance visual_spatial_sd^2 + r^2). Without the tip visible nothing about
//    the depth is learnt.
//
// Units: m, N, s. The trainee knows its own hand position (proprioception) and the skin surface.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <utility>
#include <vector>

#include "protocols/participants/model.hpp"

namespace palplab::protocols::participants {

struct NeedleBriefing {
  Eigen::Vector3d entry = Eigen::Vector3d::Zero();  // m, the atlas entry point (near the skin)
  double target_depth = 0.03;                       // m, target depth below the skin
};

// One step's command: the device position, the tool and the stylus axis (unit).
struct ToolCommand {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  std::string tool = "finger";
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();
};

class NeedleTrainee {
 public:
  NeedleTrainee(const TraineeParams& params, TraineeState state);
  void begin_session(const SurfaceView& view, const NeedleBriefing& briefing,
                     std::uint64_t participant_seed, std::uint64_t seed);
  ToolCommand command(double t);
  void perceive(const Percept& p);
  void end_session(double study_time);

  const TraineeState& state() const { return s_; }
  // For tests and logs.
  int chosen_node() const { return chosen_; }
  int insertions() const { return insertions_; }
  bool done() const { return mode_ == Mode::done; }
  // The palpated points (skin nodes) and the force judged at each (N).
  const std::vector<int>& palpated() const { return grid_; }
  const std::vector<double>& judged() const { return judged_; }

 private:
  enum class Mode { travel, press, lift, approach, insert, withdraw, done };
  void next_palpation();
  void start_insertion();
  void stop();

  TraineeParams p_;
  TraineeState s_;
  Rng rng_{0};
  SurfaceView view_;
  NeedleBriefing brief_;
  Mode mode_ = Mode::travel;
  Eigen::Vector3d pos_ = Eigen::Vector3d::Zero(), goal_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d n_ = Eigen::Vector3d::UnitZ();  // outward normal of the current skin point
  std::vector<int> grid_;
  std::vector<double> judged_;
  std::size_t gi_ = 0;
  double peak_felt_ = 0.0;
  int chosen_ = -1;
  // needle
  std::string tool_ = "finger";
  Eigen::Vector3d entry_ = Eigen::Vector3d::Zero(), axis_ = Eigen::Vector3d::UnitY();
  double depth_ = 0.0, stop_depth_ = 0.0;  // m along the needle from the skin entry
  double run_peak_ = 0.0;                  // N, felt axial force peak since the last pop
  int insertions_ = 0;
  bool seen_target_ = false;
  double seen_depth_ = 0.0;
  // Knowledge of results of a visible miss: per insertion with the tip visible, the depth at
  // which the drawn tip came closest to the target and that distance (m).
  double closest_ = -1.0, closest_depth_ = 0.0;
  std::vector<std::pair<double, double>> misses_;  // (depth, distance) per insertion
  void end_insertion();
  double last_t_ = 0.0;
};

}  // namespace palplab::protocols::participants
