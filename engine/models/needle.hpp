#pragma once
// Needle insertion through layered tissue (issue 16, SPEC §4): a rigid straight needle pushed
// along an axis through a tet mesh whose tets carry their tissue type (attribute).
//
// Model (1-D along the needle, quasi-static; after Okamura, Simone & O'Leary 2004):
//   * At first contact (the tip passes the outer surface along its axis) the entry point E and
//     the axis a are locked; depth s = (tip - E)·a. Lateral motion of the tip afterwards is
//     reported (lateral_offset) but does not bend the track.
//   * The line E + t a crosses tissue interfaces at depths b_0 = 0 < b_1 < ... (precomputed per
//     insertion from the mesh's interface faces). Interface k is "punctured" once passed.
//   * Pressing on the next unpunctured interface j (s > b_j) deflects it: tip force
//     k_j (s - b_j), k_j = puncture_stiffness of the tissue beyond. When that force reaches the
//     tissue's puncture_force the interface is punctured (tissue_entered) and the tip moves on
//     (several interfaces may go in one step). A rigid tissue (bone) is never punctured: its
//     surface is a wall of stiffness k (bone_contact when pressing starts).
//   * Advancing into fresh tissue (deeper than ever in this insertion) adds the cutting_force of
//     the tissue at the tip; the shaft feels friction sum_i friction_i · L_i (L_i = shaft length
//     in tissue i) against the direction of motion (none at rest: no static friction).
//   * Withdrawing re-crosses interfaces without force peaks (tissue_left / tissue_entered);
//     pulling the tip out of the body ends the insertion (a new contact starts a new one).
// Force convention: axial_force >= 0 resists insertion; the force on the hand is
// force = -axial_force · a (N). Lengths in m.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "engine/mesh/materials.hpp"
#include "engine/mesh/tet_mesh.hpp"

namespace palplab::engine {

using Vec3 = mesh::Vec3;

struct NeedleEvent {
  enum class Kind { tissue_entered, tissue_left, bone_contact, target_reached };
  Kind kind = Kind::tissue_entered;
  int tissue = -1;               // tissue attribute (bone_contact: the bone's)
  std::string name;              // tissue name from the material table
  double depth = 0;              // m below the entry point along the axis where it happened
  Vec3 position = Vec3::Zero();  // m, the tip (undeformed coordinates)
};
const char* to_string(NeedleEvent::Kind k);

struct NeedleStep {
  bool inserted = false;      // the tip has touched the body (an insertion is under way)
  double depth = 0;           // m, commanded depth s (0 before contact)
  double tip_depth = 0;       // m, depth of the tip in undeformed tissue (s, or the pressed
                              //   interface's depth while it deflects)
  Vec3 tip = Vec3::Zero();    // m, tip position in undeformed tissue (the input tip before contact)
  int tissue = -1;            // tissue attribute at the tip, -1 outside the body
  double tip_force = 0;       // N, spring force of the pressed interface (pre-puncture / bone)
  double cutting_force = 0;   // N
  double friction_force = 0;  // N, signed: > 0 while inserting, < 0 while withdrawing
  double axial_force = 0;     // N, the sum (resisting insertion when > 0)
  Vec3 force = Vec3::Zero();  // N, force on the hand: -axial_force · axis
  double tip_to_target = 0;   // m, distance from the tip to the target tissue (0 inside it)
  double lateral_offset = 0;  // m, distance of the input tip from the locked needle axis
  std::vector<NeedleEvent> events;
};

// One tissue interval along a line: depths [enter, exit) of the line parameter.
struct NeedleLayer {
  double enter = 0, exit = 0;
  int tissue = -1;
};

struct NeedleOptions {
  int target_tissue = 107;  // membrane
  // Motion below this (m per step) counts as rest: no friction, no cutting.
  double rest_tolerance = 1e-7;
};

struct NeedleTissue {
  int attribute = -1;
  std::string name;
  bool rigid = false;
  mesh::NeedleParams params;
};

class NeedleModel {
 public:
  // Precomputes the tissue-interface faces, a point-location grid and the target's surface.
  // Throws InputError when a tissue of the mesh has no material or no needle parameters, or the
  // mesh has no tet of the target tissue.
  NeedleModel(const mesh::TetMesh& m, const mesh::MaterialTable& materials,
              const NeedleOptions& opt = {});
  // The same from the tet arrays alone (#N by 3 nodes in m, #T by 4 tets, #T tissue attributes).
  // `precomputed` (empty = none) = a save() of a model built from the same arrays and target
  // tissue (a .psim
  // file's): restored instead of recomputed, so the model steps bit-identically; a blob made
  // from other inputs, or malformed, is ignored (recomputed). A .psim file's checksum guards the
  // bytes; the digest here guards against a blob meant for another mesh.
  NeedleModel(const mesh::Positions& V, const mesh::Tets& T, const Eigen::VectorXi& attribute,
              const mesh::MaterialTable& materials, const NeedleOptions& opt,
              std::string_view precomputed = {});
  // The precomputation (interface faces, target surface, point-location grid) as bytes, tagged
  // with a SHA-256 digest of the inputs (nodes, tets, attributes, target tissue).
  std::string save() const;
  bool restored() const { return restored_; }  // built from a precomputed blob

  // One haptic/simulation step: the device's tip position and needle axis (need not be unit).
  NeedleStep step(const Vec3& tip, const Vec3& axis);
  // Forget the current insertion (the needle is out; counters stay).
  void reset();

  // Tissue intervals of the line origin + t·dir (dir normalised), t >= 0, in order; outside
  // gaps have tissue -1.
  std::vector<NeedleLayer> layers_along(const Vec3& origin, const Vec3& dir) const;
  int tissue_at(const Vec3& p) const;               // -1 outside the mesh
  double distance_to_target(const Vec3& p) const;   // m, 0 inside the target
  const NeedleTissue& tissue(int attribute) const;  // throws std::out_of_range

  // Faces of each tissue's closed surface: faces of its tets whose neighbour is another tissue
  // or none (node indices of the mesh, in the tet's own face order), with the tissue.
  struct TissueFace {
    int tissue = -1;
    std::array<int, 3> v{};
  };
  const std::vector<TissueFace>& tissue_faces() const { return tissue_faces_; }

  int insertions() const { return insertions_; }  // contacts started (attempts)
  int bone_contacts() const { return bone_contacts_; }
  // Tissues entered in the current insertion, in order (one entry per entering).
  const std::vector<int>& entered() const { return entered_; }

 private:
  struct Tri {
    Vec3 a, b, c;
  };
  void check_tissues(const mesh::MaterialTable& materials);
  void precompute();
  bool restore(std::string_view blob);
  std::array<std::uint8_t, 32> inputs_digest() const;
  bool restored_ = false;
  mesh::Positions V_;  // copies: the model does not keep a reference to the mesh
  mesh::Tets T_;
  Eigen::VectorXi A_;
  NeedleOptions opt_;
  std::vector<NeedleTissue> tissues_;  // one per distinct attribute
  std::vector<Tri> interfaces_;        // faces between different tissues or on the boundary
  std::vector<Tri> target_faces_;      // the target tissue's surface
  std::vector<TissueFace> tissue_faces_;
  // Uniform grid over the mesh's bounding box: tets per cell (point location).
  Vec3 lo_, cell_;
  int nx_ = 1, ny_ = 1, nz_ = 1;
  mesh::Csr grid_;

  // Current insertion.
  bool inserted_ = false;
  Vec3 entry_ = Vec3::Zero(), axis_ = Vec3::UnitZ();
  std::vector<double> bounds_;  // b_k: interface depths
  std::vector<int> beyond_;     // tissue in [b_k, b_k+1) (-1 outside)
  int punctured_ = 0;           // interfaces passed
  int interval_ = -1;           // interval of the tip (-1: before b_0)
  double s_prev_ = 0, deepest_ = 0;
  bool bone_pressing_ = false, target_reached_ = false;
  std::vector<int> entered_;
  int insertions_ = 0, bone_contacts_ = 0;
};

}  // namespace palplab::engine
