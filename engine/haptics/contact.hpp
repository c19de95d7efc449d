#pragma once
// Contact tracking on the rest surface of a scene: a god-object proxy (Zilles & Salisbury 1995;
// Ruspini et al. 1997) that lives on the surface and cannot cross it, with force shading
// (Morgenbesser & Srinivasan 1996) so the rendered normal is continuous from face to face.
//
//   * While free, the device's PATH from its last position to the current one is tested against
//     the surface (continuous collision): the first face the path enters from outside becomes the
//     proxy's face, however fast the device moves. No step is too long to be caught.
//   * While in contact, the proxy walks face to face over edges to the point p whose shaded
//     normal passes through the device (Phong projection, x = p - d n(p)): a straight push
//     along a node's normal keeps the node, sliding moves p continuously, and p never jumps to
//     the far side of a thin part, however deep the device goes. The projection is solved by
//     Newton's method with a line search (quadratic convergence at any depth short of a focal
//     point), the walk's path bounded per step. Where the device is near or past the local
//     centre of curvature (a 2.5 N press on C's ovary tip, radius ~9 mm, holds 9.3 mm deep) the
//     projection's gain 1 / (1 - d kappa) has no bound: there the proxy follows the device's
//     tangential motion along the surface instead (a god-object on the local tangent plane).
//     Per step the proxy moves at most 1.25 x the projection's gain at the proxy (<= 4) x the
//     device's motion tangential to the contact normal, plus 0.2 % of a mean edge: a proxy that
//     lags the projection catches up slowly instead of jumping (the force's steps, issue 9).
//   * Penetration depth is measured along the shaded normal n(p) = normalize(sum_i w_i N_i) of
//     the proxy's face (w the barycentric weights of the proxy, N the vertex normals): at a
//     vertex it is that vertex's normal, on an edge a blend of its two ends. The contact ends
//     when the depth is <= 0 (the device is back on the outside).
//   * When the side of the device is unknown (the first step after reset, or after a non-finite
//     device position), the inside test is the generalized winding number (Jacobson et al.
//     2013) of the surface at the device; inside, the proxy starts at the Phong projection found
//     from the closest surface point (the closest point itself if there is none near it).
//
// Shapes: V #V by 3 rest positions (m), N #V by 3 unit outward vertex normals, F #F by 3 faces
// (ccw seen from outside).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "engine/mesh/types.hpp"

namespace palplab::engine {

// The search structures of a surface for the contact tracker, built once per surface (a scene's
// prepared mesh holds one, engine/models/model.hpp SceneMesh::face_index; a .psim file stores it,
// engine/haptics/scene_file.hpp, because building it was ~60 % of loading prototype B).
struct FaceIndex {
  struct Node {
    Eigen::AlignedBox3d box;    // bounds of the node's faces (m)
    int left = -1, right = -1;  // children (-1: leaf)
    int begin = 0, end = 0;     // run of `order`
  };
  std::vector<int> vf_offset, vf;             // vertex -> incident faces (CSR, #V + 1 / 3 #F)
  std::vector<int> edge_face;                 // 3 #F: face across the edge opposite each corner, -1
  double mean_edge = 0.0;                     // m, mean face-edge length
  std::vector<Eigen::AlignedBox3d> face_box;  // #F face bounds (m)
  std::vector<Node> bvh;                      // bounding-volume hierarchy over the faces (root 0)
  std::vector<int> order;                     // #F faces grouped by leaf
  // The surface is closed and consistently oriented (surface_closed): winding_number is then 0
  // outside its bounding box without the sum over the faces.
  bool closed = false;
};

// The bounds of each face of (V, F) (FaceIndex::face_box; a .psim file does not store them).
std::vector<Eigen::AlignedBox3d> face_boxes(const mesh::Positions& V, const mesh::Faces& F);
// Whether every edge of F is shared by exactly two faces that run it in opposite directions
// (edge_face as FaceIndex::edge_face of F; no degenerate face): a closed, consistently oriented
// surface. Never reads out of range, whatever edge_face holds.
bool surface_closed(const mesh::Faces& F, const std::vector<int>& edge_face);
// Builds the index of surface (V, F): deterministic (the same bytes for the same surface).
FaceIndex build_face_index(const mesh::Positions& V, const mesh::Faces& F);
// An index read from a file is checked against its surface before use: "" when it is
// consistent (every index in range, the hierarchy a tree over a permutation of the faces),
// otherwise what is wrong. Never reads out of range, whatever the contents.
std::string check_face_index(const FaceIndex& ix, long nv, long nf);

// A point on a surface face.
struct SurfacePoint {
  int face = -1;
  Eigen::Vector3d w = Eigen::Vector3d(1, 0, 0);  // barycentric weights (>= 0, sum 1)
  Eigen::Vector3d p = Eigen::Vector3d::Zero();   // m
};

class ContactTracker {
 public:
  // Builds its own index of (V, F).
  ContactTracker(const mesh::Positions& V, const mesh::Positions& N, const mesh::Faces& F);
  // Uses `index` (build_face_index(V, F), shared between the scenes of one prepared mesh).
  ContactTracker(const mesh::Positions& V, const mesh::Positions& N, const mesh::Faces& F,
                 std::shared_ptr<const FaceIndex> index);

  // Disengaged, side of the device unknown.
  void reset();
  // A device position that cannot be used (non-finite, absurd): disengaged, side unknown.
  void invalidate();
  // One step: the device moved from `from` (its last valid position) to `x` (m).
  void update(const Eigen::Vector3d& from, const Eigen::Vector3d& x);

  bool engaged() const { return engaged_; }
  // This step's contact began with the device already inside (side unknown before: the start
  // position, or the return of a valid device position); its depth in *depth (m).
  bool started_inside() const { return started_inside_; }
  const SurfacePoint& proxy() const { return proxy_; }
  Eigen::Vector3d normal() const { return n_; }  // shaded outward normal at the proxy
  double depth() const { return depth_; }        // m, (proxy - x) . normal, > 0 in contact
  // Face vertex of the largest weight (with hysteresis, see set_contact); -1 without contact.
  int node() const;

  // --- queries (exposed for tests) ---
  // Closest point of face f to x.
  SurfacePoint closest_on_face(int f, const Eigen::Vector3d& x) const;
  // Closest surface point to x (all faces).
  SurfacePoint closest_point(const Eigen::Vector3d& x) const;
  // Generalized winding number of the surface at x (1 inside a closed surface, 0 outside).
  double winding_number(const Eigen::Vector3d& x) const;
  // First face the segment a -> b enters from outside (smallest parameter); false if none.
  bool first_entry(const Eigen::Vector3d& a, const Eigen::Vector3d& b, SurfacePoint& hit) const;
  // The proxy's walk from `from` to the Phong projection of x (see the top), unbounded.
  SurfacePoint walk(const SurfacePoint& from, const Eigen::Vector3d& x) const;
  struct WalkInfo {
    bool converged = false;  // x on the shaded normal line of the result (|r| <= 1e-12 edge)
    bool capped = false;     // stopped by max_travel before converging
    int iterations = 0;      // Newton iterations
    double residual = 0.0;   // m, |p - t m(p) - x|
    double travel = 0.0;     // m, length of the path of p
    double t = 0.0;          // depth along the unnormalised shaded normal m (depth = t |m|)
    double reach = 0.0;      // reach_margin(result, t)
  };
  // The same walk, its path at most max_travel long (m); what it did in *info (optional).
  SurfacePoint walk(const SurfacePoint& from, const Eigen::Vector3d& x, double max_travel,
                    WalkInfo* info) const;
  // Smallest real part of the eigenvalues 1 - t kappa_i of the normal-line map at s, depth t
  // (along the unnormalised shaded normal): 1 on the surface, 0 at a focal point of the shaded
  // normal field (a centre of curvature), < 0 past it. The Phong projection moves the proxy by
  // up to 1 / reach times the device's tangential motion.
  double reach_margin(const SurfacePoint& s, double t) const;
  // The tangential part of delta (m) walked along the surface from `from` (in each face's
  // plane, its length kept over edges: the surface unfolded).
  SurfacePoint slide(const SurfacePoint& from, const Eigen::Vector3d& delta) const;
  Eigen::Vector3d shaded_normal(const SurfacePoint& s) const;

 private:
  void set_contact(const SurfacePoint& s, const Eigen::Vector3d& x);
  // The proxy at s, the device moved from `from` to x: the Phong projection within the reach,
  // else s slid by the device's tangential motion (see follow's definition). `entry`: the first
  // step of a contact (s the entry point).
  SurfacePoint follow(const SurfacePoint& s, const Eigen::Vector3d& from, const Eigen::Vector3d& x,
                      bool entry = false) const;
  // The Phong projection of x near c (closest_point(x)), or c.
  SurfacePoint projection_near(const SurfacePoint& c, const Eigen::Vector3d& x) const;

  const mesh::Positions& V_;
  const mesh::Positions& N_;
  const mesh::Faces& F_;
  std::shared_ptr<const FaceIndex> index_;
  const FaceIndex& ix_;
  mutable std::vector<int> stack_;

  bool engaged_ = false, outside_known_ = false, started_inside_ = false;
  SurfacePoint proxy_;
  Eigen::Vector3d n_ = Eigen::Vector3d::UnitZ();
  double depth_ = 0.0;
  int node_ = -1;
};

}  // namespace palplab::engine
