// Headless renders of an analytic scene (an icosphere) checked against what the camera maths
// predicts: silhouette area and centroid, region colours, transparency, streamed deformation and
// the refined-patch highlight. Skipped (with the reason) only where no EGL device exists;
// .ci/install-deps installs Mesa's llvmpipe so CI always has one.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include "common/input_error.hpp"
#include "engine/mesh/generate.hpp"
#include "engine/mesh/surface_mesh.hpp"
#include "engine/render/headless.hpp"
#include "engine/render/image.hpp"
#include "engine/render/renderer.hpp"
#include "tests/render_support.hpp"

namespace pr = palplab::render;
using palplab::engine::SceneGeometry;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int W = 320, H = 240;

using palplab::testing::coverage;
using palplab::testing::Coverage;

class RenderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    try {
      ctx_ = std::make_unique<pr::HeadlessContext>(W, H);
    } catch (const pr::NoDisplayError& e) {
      GTEST_SKIP() << "no EGL device on this machine: " << e.what();
    }
    const auto m = palplab::mesh::generate_sphere(2562);  // nu = 16, radius 0.05 m
    g_.V = m.V;
    g_.F = m.F;
    g_.N = palplab::mesh::vertex_normals(m.V, m.F);
    g_.region_names = {"top", "bottom"};
    g_.vertex_region.resize(m.V.rows());
    for (long v = 0; v < m.V.rows(); ++v) g_.vertex_region[v] = m.V(v, 2) > 0 ? 0 : 1;
  }
  pr::Image draw(pr::Renderer& r, const pr::Camera& cam, const pr::DrawOptions& opt = {}) {
    ctx_->bind();
    r.draw(cam, W, H, opt);
    return ctx_->read_pixels();
  }
  std::unique_ptr<pr::HeadlessContext> ctx_;
  SceneGeometry g_;
};

TEST_F(RenderTest, SphereSilhouetteHasTheProjectedAreaAndCentre) {
  pr::Renderer r(g_);
  pr::Camera cam;
  cam.azimuth_deg = 40;
  cam.elevation_deg = 20;
  cam.distance = 0.3;  // m; sphere radius 0.05 m at the origin
  const pr::Image img = draw(r, cam);
  const Coverage c = coverage(img);
  // A sphere seen from distance d subtends asin(r/d); its silhouette is a circle of radius
  // tan(asin(r/d)) / tan(fov/2) * H/2 pixels.
  const double alpha = std::asin(0.05 / 0.3);
  const double rad_px = std::tan(alpha) / std::tan(cam.fov_y_deg * kPi / 360.0) * H / 2.0;
  const double expected = kPi * rad_px * rad_px;
  // The inscribed icosphere (nu = 16) loses < 0.5% of the area; edge pixels are +-1 px.
  EXPECT_NEAR(c.count / expected, 1.0, 0.02) << c.count << " pixels, expected " << expected;
  EXPECT_NEAR(c.cx, W / 2.0, 0.5);
  EXPECT_NEAR(c.cy, H / 2.0, 0.5);
}

TEST_F(RenderTest, OffCentreTargetMovesTheCentroidWhereTheCameraProjectsIt) {
  pr::Renderer r(g_);
  pr::Camera cam;
  cam.azimuth_deg = -70;
  cam.elevation_deg = 35;
  cam.distance = 0.4;
  cam.target = Eigen::Vector3d(0.05, 0.03, 0.0);  // m, so the sphere is off the image centre
  const pr::Image img = draw(r, cam);
  const Coverage c = coverage(img);
  const pr::CameraMatrices m = r.matrices(cam, W, H);
  const Eigen::Vector2d p = m.project(Eigen::Vector3d::Zero());
  const Eigen::Vector2d mid(W / 2.0, H / 2.0);
  ASSERT_GT((p - mid).norm(), 40.0);  // really off centre
  // The silhouette of an off-axis sphere is an ellipse; along the radial image direction its
  // edges are at tan(theta -+ alpha), so its centre (= area centroid) is at
  // (tan(theta + alpha) + tan(theta - alpha)) / 2, a little beyond the projected centre.
  const double f = m.proj(1, 1) * H / 2.0;  // px per unit of tan(angle)
  const double tan_theta = (p - mid).norm() / f;
  const double theta = std::atan(tan_theta);
  const double a = std::asin(0.05 / (m.eye).norm());
  const double rho = (std::tan(theta + a) + std::tan(theta - a)) / 2.0;
  const Eigen::Vector2d expected = mid + (p - mid) * (rho / tan_theta);
  EXPECT_GT((expected - p).norm(), 0.3);  // the correction matters at this tolerance
  EXPECT_NEAR(c.cx, expected.x(), 0.3);
  EXPECT_NEAR(c.cy, expected.y(), 0.3);
}

TEST_F(RenderTest, RegionsHaveTheirColours) {
  pr::Renderer r(g_);
  pr::Camera cam;
  cam.azimuth_deg = 0;
  cam.elevation_deg = 0;
  cam.distance = 0.3;
  const pr::Image img = draw(r, cam);
  const auto top = pr::region_colour(0), bottom = pr::region_colour(1);
  // Shading scales the colour; the channel order of the region colour survives.
  const std::uint8_t* a = img.pixel(W / 2, H / 2 - 30);
  const std::uint8_t* b = img.pixel(W / 2, H / 2 + 30);
  ASSERT_GT(top[0], top[2]);
  ASSERT_GT(bottom[2], bottom[0]);
  EXPECT_GT(a[0], a[2] + 30);
  EXPECT_GT(b[2], b[0] + 30);
}

TEST_F(RenderTest, TransparentRegionShowsWhatIsBehindIt) {
  pr::Renderer r(g_);
  pr::Camera cam;
  cam.azimuth_deg = 0;
  cam.elevation_deg = 0;
  cam.distance = 0.3;
  const long full = coverage(draw(r, cam)).count;
  pr::DrawOptions opt;
  opt.region_alpha = {0.0f, 1.0f};  // top invisible
  const Coverage half = coverage(draw(r, cam, opt));
  // Half the disc, plus the band of faces straddling the equator: a face takes the region of its
  // first vertex, and for nu = 16 the band is ~1/(3*16)*pi/2 ~ 3% of the height.
  EXPECT_GT(static_cast<double>(half.count) / full, 0.49);
  EXPECT_LT(static_cast<double>(half.count) / full, 0.55);
  EXPECT_GT(half.cy, H / 2.0);  // what is left is below the centre
  opt.region_alpha = {0.4f, 1.0f};
  const pr::Image see = draw(r, cam, opt);
  // Through the 40%-opaque top, the back faces of the top (also transparent) and the white
  // background show: the pixel is lighter than the opaque one.
  const pr::Image opaque = draw(r, cam);
  const std::uint8_t* t = see.pixel(W / 2, H / 2 - 30);
  const std::uint8_t* o = opaque.pixel(W / 2, H / 2 - 30);
  EXPECT_GT(t[1] + t[2], o[1] + o[2] + 40);
  EXPECT_EQ(coverage(see).count, full);
}

// Needle scenes (SceneGeometry::tissues): a "bone" sphere of radius 0.02 m inside the 0.05 m
// skin sphere. Opaque skin hides it exactly (the image equals one without the tissue surfaces);
// with the skin see-through it changes the pixels of its own projected disc, about
// (tan asin(0.02/0.3) / tan asin(0.05/0.3))^2 = 0.156 of the skin's silhouette at 0.3 m.
TEST_F(RenderTest, BoneInsideTransparentSkinShowsOnlyWhenTheSkinIsTransparent) {
  SceneGeometry skin = g_;
  skin.region_names = {"skin", "bone"};
  std::fill(skin.vertex_region.begin(), skin.vertex_region.end(), 0);
  SceneGeometry with_bone = skin;
  auto bone = std::make_shared<palplab::engine::TissueSurfaces>();
  const auto m = palplab::mesh::generate_sphere(642);
  bone->V = m.V * 0.4;  // radius 0.02 m
  bone->F = m.F;
  bone->vertex_region.assign(m.V.rows(), 1);
  with_bone.tissues = bone;
  pr::Renderer plain(skin), layered(with_bone);
  pr::Camera cam;
  cam.azimuth_deg = 20;
  cam.elevation_deg = 10;
  cam.distance = 0.3;
  auto differing = [](const pr::Image& a, const pr::Image& b) {
    long n = 0;
    for (int y = 0; y < a.height; ++y)
      for (int x = 0; x < a.width; ++x) {
        const std::uint8_t *p = a.pixel(x, y), *q = b.pixel(x, y);
        n += std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2]) > 6;
      }
    return n;
  };
  // Opaque: the bone is hidden, pixel for pixel.
  const pr::Image o_plain = draw(plain, cam), o_layered = draw(layered, cam);
  EXPECT_EQ(differing(o_plain, o_layered), 0);
  // Transparent skin: the bone shows where it projects, nowhere else.
  pr::DrawOptions see;
  see.region_alpha = {0.3f, 1.0f};
  const pr::Image t_plain = draw(plain, cam, see), t_layered = draw(layered, cam, see);
  const long full = coverage(o_plain).count;
  const double share = static_cast<double>(differing(t_plain, t_layered)) / full;
  EXPECT_GT(share, 0.13);
  EXPECT_LT(share, 0.18);
  EXPECT_GT(differing(t_layered, o_layered), full / 2);  // the skin itself changed too
  // The centre pixel (the bone) is darker/less white than through the empty skin.
  const std::uint8_t *c_bone = t_layered.pixel(W / 2, H / 2),
                     *c_empty = t_plain.pixel(W / 2, H / 2);
  EXPECT_NE(c_bone[0] + c_bone[1] + c_bone[2], c_empty[0] + c_empty[1] + c_empty[2]);
}

// The needle (DrawOptions::needle_axis): drawn from the device position back along the axis, in
// front of the sphere here, so pixels change along its projected shaft and nowhere else.
TEST_F(RenderTest, NeedleIsDrawnAlongItsAxisFromTheTip) {
  pr::Renderer r(g_);
  pr::Camera cam;
  cam.azimuth_deg = 0;
  cam.elevation_deg = 0;
  cam.distance = 0.3;
  pr::DrawOptions opt;
  opt.device_position = Eigen::Vector3d(0.06, 0.0, 0.0);  // 1 cm in front (the eye is at +x)
  const pr::Image without = draw(r, cam, opt);
  opt.needle_axis = Eigen::Vector3d(0.0, 0.0, -1.0);  // the shaft goes up (+z) from the tip
  opt.needle_length = 0.04;
  const pr::Image with = draw(r, cam, opt);
  long above = 0, below = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::uint8_t *p = with.pixel(x, y), *q = without.pixel(x, y);
      if (std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2]) > 6)
        (y < H / 2 - 3 ? above : below) += 1;
    }
  EXPECT_GT(above, 40);  // the shaft (~40 px long, >= 1 px wide), above the tip in the image
  EXPECT_LT(below, above / 10);
}

TEST_F(RenderTest, DeformationChangesPixelsOnlyNearIt) {
  pr::Renderer r(g_);
  pr::Camera cam;
  cam.azimuth_deg = 0;
  cam.elevation_deg = 0;
  cam.distance = 0.3;
  const pr::Image before = draw(r, cam);
  // Push the vertices within 1 cm of the point facing the camera (+x) 8 mm inwards.
  pr::RowMatX3d V = g_.V;
  const Eigen::Vector3d pole(0.05, 0.0, 0.0);
  for (long v = 0; v < V.rows(); ++v) {
    const double d = (V.row(v).transpose() - pole).norm();
    if (d < 0.01) V(v, 0) -= 0.008 * (1.0 - d / 0.01);
  }
  r.update_surface(V, g_.F, V.rows());
  const long uploads = r.faces_uploaded();
  const pr::Image after = draw(r, cam);
  EXPECT_EQ(r.faces_uploaded(), uploads);  // positions streamed, faces not re-uploaded
  const Eigen::Vector2d c = r.matrices(cam, W, H).project(pole);
  // The dent spans 1 cm at 0.25 m: ~ 0.01/0.25/tan(17.5 deg)*120 = 15 px around its centre.
  const auto changed = palplab::testing::changed_pixels(before, after, c, 25.0);
  EXPECT_GT(changed.total(), 50);
  EXPECT_EQ(changed.far, 0);
}

TEST_F(RenderTest, RefinedFacesAreHighlightedAndTheMarkerDrawn) {
  pr::Renderer r(g_);
  pr::Camera cam;
  cam.azimuth_deg = 0;
  cam.elevation_deg = 0;
  cam.distance = 0.3;
  // Split the faces around the vertex nearest the +x pole at their centroids (new vertices
  // appended after the coarse ones), as adaptive refinement does.
  long pole = 0;
  for (long v = 1; v < g_.V.rows(); ++v)
    if (g_.V(v, 0) > g_.V(pole, 0)) pole = v;
  pr::RowMatX3d V = g_.V;
  std::vector<Eigen::RowVector3i> faces;
  for (long f = 0; f < g_.F.rows(); ++f) {
    const Eigen::RowVector3i t = g_.F.row(f);
    if (t[0] != pole && t[1] != pole && t[2] != pole) {
      faces.push_back(t);
      continue;
    }
    const long n = V.rows();
    V.conservativeResize(n + 1, 3);
    V.row(n) = (g_.V.row(t[0]) + g_.V.row(t[1]) + g_.V.row(t[2])) / 3.0;
    const int m = static_cast<int>(n);
    faces.push_back({t[0], t[1], m});
    faces.push_back({t[1], t[2], m});
    faces.push_back({t[2], t[0], m});
  }
  pr::RowMatX3i F(faces.size(), 3);
  for (size_t f = 0; f < faces.size(); ++f) F.row(f) = faces[f];
  r.update_surface(V, F, g_.V.rows());
  const Eigen::Vector2d c = r.matrices(cam, W, H).project(g_.V.row(pole).transpose());
  const pr::Image img = draw(r, cam);
  const std::uint8_t* p = img.pixel(static_cast<int>(c.x()), static_cast<int>(c.y()));
  const std::uint8_t* q = img.pixel(W / 2, H / 2 - 40);  // plain top region
  // Highlight = yellow mix: green well above blue at the patch, unlike the plain region colour.
  EXPECT_GT(p[1], p[2] + 60);
  EXPECT_LT(q[1], q[2] + 20);
  pr::DrawOptions opt;
  opt.device_position = Eigen::Vector3d(0.06, 0.0, 0.0);
  opt.marker_radius = 0.004;
  opt.contact = true;
  const pr::Image m = draw(r, cam, opt);
  const Eigen::Vector2d mc = r.matrices(cam, W, H).project(*opt.device_position);
  const std::uint8_t* mp = m.pixel(static_cast<int>(mc.x()), static_cast<int>(mc.y()));
  EXPECT_GT(mp[0], 150);  // magenta marker
  EXPECT_LT(mp[1], 60);
}

TEST(Png, RoundTrip) {
  pr::Image img;
  img.width = 3;
  img.height = 2;
  for (int i = 0; i < 24; ++i) img.rgba.push_back(static_cast<std::uint8_t>(i * 10));
  const auto path = std::filesystem::temp_directory_path() / "palplab_png_roundtrip.png";
  pr::write_png(path.string(), img);
  const pr::Image back = pr::read_png(path.string());
  EXPECT_EQ(back.width, 3);
  EXPECT_EQ(back.height, 2);
  EXPECT_EQ(back.rgba, img.rgba);
  std::filesystem::remove(path);
  EXPECT_THROW(pr::read_png(path.string()), palplab::InputError);
}

}  // namespace
