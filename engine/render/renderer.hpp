#pragma once
// The one OpenGL 3.3 core renderer of palplab, used headless (HeadlessContext, EGL) and in a
// window (GLFW): the same code draws the stills of `palplab render` and the frames of
// `palplab view` / human sessions.
//
// The surface is uploaded once; per frame only positions and normals are streamed (faces are
// re-uploaded only when the topology changed, i.e. after adaptive refinement). Faces are coloured
// by region; faces touching refinement nodes are highlighted while the surface has more faces than
// at rest; regions with alpha < 1 are drawn after the opaque ones, sorted back to front. Needle
// scenes add each tissue's surface inside the skin (SceneGeometry::tissues, in the tissues'
// regions) and the needle, so a transparent skin and soft tissue show bone, target and needle.
// The contact point (HCP) is drawn as a small sphere. Needs a current OpenGL 3.3 core context for
// its whole life (construction, drawing, destruction).
#include <Eigen/Core>
#include <array>
#include <memory>
#include <optional>
#include <vector>

#include "engine/haptics/scene.hpp"
#include "engine/render/camera.hpp"

namespace palplab::render {

using RowMatX3d = mesh::Positions;  // the one V/F types (engine/mesh/types.hpp)
using RowMatX3i = mesh::Faces;

constexpr int kMaxRegions = 32;  // regions beyond this share the unlabelled colour

struct DrawOptions {
  bool wireframe = false;  // edges drawn over the shaded surface
  // Per-region opacity in [0, 1], indexed like SceneGeometry::region_names; missing = 1.
  std::vector<float> region_alpha;
  std::optional<Eigen::Vector3d> device_position;  // m; draws the HCP marker
  bool contact = false;                            // marker colour: magenta in contact, blue not
  double marker_radius = 0.0;                      // m; 0 = 1.2% of the rest bounding radius
  bool highlight_refined = true;
  // Needle scenes with the needle in hand: the stylus axis (tip at device_position, the shaft
  // drawn back along -axis for needle_length m); none = no needle.
  std::optional<Eigen::Vector3d> needle_axis;
  double needle_length = 0.06;
  std::array<float, 3> background = {1.0f, 1.0f, 1.0f};
};

// Region colour (linear RGB in [0, 1]) of region index r; r < 0 = unlabelled (grey).
std::array<float, 3> region_colour(int r);

class Renderer {
 public:
  explicit Renderer(const engine::SceneGeometry& rest);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // The current surface as Scene::current_surface gives it. `coarse_nodes` = SceneStats::
  // surface_coarse_nodes: vertex indices at or above it are refinement nodes.
  void update_surface(const RowMatX3d& V, const RowMatX3i& F, long coarse_nodes);
  // Draws into the bound framebuffer (viewport 0,0,width,height), clearing it first.
  void draw(const Camera& cam, int width, int height, const DrawOptions& opt);
  // Filled rectangle over the image in pixel coordinates (origin top-left), alpha-blended:
  // force bar, flash, panels.
  void overlay_rect(int width, int height, double x0, double y0, double x1, double y1,
                    const std::array<float, 4>& rgba);

  CameraMatrices matrices(const Camera& cam, int width, int height) const;
  const Eigen::Vector3d& rest_centre() const { return centre_; }
  double rest_radius() const { return radius_; }
  long faces_uploaded() const { return faces_uploaded_; }  // counts index-buffer uploads

 private:
  struct Gl;
  std::unique_ptr<Gl> gl_;
  const engine::SceneGeometry& rest_;
  Eigen::Vector3d centre_;
  double radius_ = 1.0;
  long rest_faces_ = 0;
  // CPU copies of what is on the GPU.
  RowMatX3i F_;
  std::vector<int> face_region_;    // #F
  std::vector<int> vertex_region_;  // #V (current numbering)
  std::vector<int> vertex_refined_;
  std::vector<float> stream_;  // #V * 6: position, normal
  long vertex_capacity_ = 0;
  long faces_uploaded_ = 0;
  long coarse_nodes_ = 0;
  // Needle scenes: the tissues' surfaces (SceneGeometry::tissues) drawn after the scene's
  // surface in the same buffers, so transparency sorts them together.
  std::shared_ptr<const engine::TissueSurfaces> inner_;
  long outer_vertices_ = 0, outer_faces_ = 0;  // the scene's surface in V_, F_
  RowMatX3d V_;
  void upload_topology(long nV);
};

}  // namespace palplab::render
