// The probe face as a disc of quadrature points on the surface (engine/models/contact_pad.hpp):
// the same disc, whatever the mesh under it.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <random>
#include <set>

#include "engine/models/contact_pad.hpp"

using namespace palplab::engine;

namespace {

// A flat square [-a, a]^2 at z = 0 in n x n cells, two faces per cell, ccw seen from +z.
void flat_grid(double a, int n, RowMatX3d& X, RowMatX3i& F) {
  X.resize((n + 1) * (n + 1), 3);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      X.row(j * (n + 1) + i) << -a + 2 * a * i / n, -a + 2 * a * j / n, 0;
  F.resize(2 * n * n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int v = j * (n + 1) + i, f = 2 * (j * n + i);
      F.row(f) << v, v + 1, v + n + 2;
      F.row(f + 1) << v, v + n + 2, v + n + 1;
    }
}

}  // namespace

TEST(ContactPad, DiscWeightAndCentroidDoNotDependOnTheMesh) {
  // The disc pad (radius 1 cm) on a flat 8 cm square meshed with 20 mm cells (wider than the
  // disc) and with 1.25 mm cells (16 across it): total weight 1 and centroid at the disc's
  // centre to rounding (barycentric weights reproduce linear functions, so this holds for any
  // flat mesh); the offsets are 0 (flat: no point stands above or below the plane). With the
  // centre on the square's edge half the disc overhangs: weight 1/2 (the rings are symmetric
  // about the edge and no point lies on it).
  const Eigen::Vector3d c(0.0031, -0.0017, 0.0), n = Eigen::Vector3d::UnitZ();
  for (int cells : {4, 64}) {
    RowMatX3d X;
    RowMatX3i F;
    flat_grid(0.04, cells, X, F);
    PadSurface s;
    build_pad_surface(F, X.rows(), s);
    std::vector<PadPoint> pad;
    ASSERT_GE(disc_pad(s, X, c, n, 0.01, 0, pad), 0) << cells;
    double w = 0;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const PadPoint& p : pad) {
      w += p.w;
      centroid += p.w * X.row(p.node).transpose();
      EXPECT_NEAR(p.offset, 0.0, 1e-15);
    }
    EXPECT_NEAR(w, 1.0, 1e-12) << cells;
    EXPECT_NEAR((centroid - c).norm(), 0.0, 1e-15) << cells;
    // Coarse: the disc lies on a few faces; fine: on dozens of nodes.
    std::set<int> nodes;
    for (const PadPoint& p : pad) nodes.insert(p.node);
    EXPECT_GE(nodes.size(), cells == 4 ? 4u : 40u) << cells;

    const Eigen::Vector3d edge(0.04, 0.0, 0.0);  // on the edge x = a
    ASSERT_GE(disc_pad(s, X, edge, n, 0.01, 0, pad), 0);
    w = 0;
    for (const PadPoint& p : pad) w += p.w;
    EXPECT_NEAR(w, 0.5, 1e-12) << cells;
  }
}

TEST(ContactPad, OffsetsMakeEachPointsPenetrationOnACurvedSurface) {
  // A tent (two planes meeting at a ridge along y, slope 0.2) pressed at the ridge: a point at
  // distance r from the ridge sits 0.2 r below the centre's tangent plane, so sum_i b_i d_i with
  // d_i = (X_i - p).n - o_i (the device p at depth delta below the ridge, no deformation) is
  // delta - 0.2 r; the pad yields to nothing (no point above the centre).
  RowMatX3d X;
  RowMatX3i F;
  flat_grid(0.04, 16, X, F);
  for (long i = 0; i < X.rows(); ++i) X(i, 2) = -0.2 * std::abs(X(i, 0));
  PadSurface s;
  build_pad_surface(F, X.rows(), s);
  std::vector<PadPoint> pad;
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ(), c = Eigen::Vector3d::Zero();
  ASSERT_GE(disc_pad(s, X, c, n, 0.01, 0, pad), 0);
  const double delta = 0.003;
  const Eigen::Vector3d p = c - delta * n;
  // Unclamped, the pad's mean penetration is the disc's mean of delta - 0.2 |x| over its
  // quadrature points.
  double mean = 0, w = 0;
  for (const PadPoint& q : pad) {
    mean += q.w * ((X.row(q.node).transpose() - p).dot(n) - q.offset);
    w += q.w;
  }
  double e_abs_x = 0;  // the quadrature's mean |x|
  for (int j = 0; j < kPadRings; ++j) {
    const int m = 6 * (j + 1);
    const double r = 0.01 * std::sqrt((j + 0.5) / kPadRings);
    for (int q = 0; q < m; ++q) {
      const double t = (j % 2) * std::numbers::pi / m + 2 * std::numbers::pi * q / m;
      e_abs_x += std::abs(r * std::cos(t)) / (kPadRings * m);
    }
  }
  EXPECT_NEAR(w, 1.0, 1e-12);
  EXPECT_NEAR(mean, delta - 0.2 * e_abs_x, 1e-14);
  // The disc's exact mean |x| is 4R / (3 pi); the quadrature's is within 3 % of it.
  EXPECT_NEAR(e_abs_x, 0.04 / (3 * std::numbers::pi), 0.03 * 0.04 / (3 * std::numbers::pi));
}

TEST(ContactPad, EveryPointLandsOnTheFaceUnderIt) {
  // A jittered, bumpy height field z = h(x, y) (16 x 16 cells over 8 cm, nodes moved by up to
  // 20 % of a cell per axis, so faces of many shapes, none flipped: a node moves at most
  // 0.28 of a cell, its face's opposite edge at most as much, and they lie 0.71 of a cell apart):
  // above a height field each quadrature point has exactly one face under it. disc_pad walks there
  // (from the last point's face); the reference here tests every face. For 100 centres the pads
  // must load the same nodes with the same weights and offsets (to rounding).
  const int cells = 16;
  const double a = 0.04, h = 2 * a / cells;
  RowMatX3d X;
  RowMatX3i F;
  flat_grid(a, cells, X, F);
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  auto uniform = [&] { return unit(rng); };
  for (long i = 0; i < X.rows(); ++i) {
    const bool border =
        std::abs(std::abs(X(i, 0)) - a) < 1e-12 || std::abs(std::abs(X(i, 1)) - a) < 1e-12;
    if (!border) X(i, 0) += 0.2 * h * uniform(), X(i, 1) += 0.2 * h * uniform();
    X(i, 2) = 0.004 * std::sin(60 * X(i, 0)) * std::cos(45 * X(i, 1));
  }
  PadSurface s;
  build_pad_surface(F, X.rows(), s);
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  std::vector<PadPoint> pad;
  // The reference: the face whose projection holds (u, v), by testing every face.
  auto face_under = [&](double u, double v, Eigen::Vector3d& b) {
    for (long f = 0; f < F.rows(); ++f) {
      double l[3];
      for (int k = 0; k < 3; ++k) {
        const auto p = X.row(F(f, (k + 1) % 3)), q = X.row(F(f, (k + 2) % 3));
        l[k] = (p(0) - u) * (q(1) - v) - (q(0) - u) * (p(1) - v);
      }
      if (l[0] >= 0 && l[1] >= 0 && l[2] >= 0) {
        b = Eigen::Vector3d(l[0], l[1], l[2]) / (l[0] + l[1] + l[2]);
        return static_cast<int>(f);
      }
    }
    return -1;
  };
  for (int trial = 0; trial < 100; ++trial) {
    const double cx = 0.025 * uniform(), cy = 0.025 * uniform();
    Eigen::Vector3d b;
    const int fc = face_under(cx, cy, b);
    ASSERT_GE(fc, 0);
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) c += b[k] * X.row(F(fc, k)).transpose();
    ASSERT_EQ(disc_pad(s, X, c, n, 0.01, 0, pad), fc) << trial;
    // The reference pad, node by node: weight and weight-summed offset.
    std::map<int, std::pair<double, double>> want, got;
    for (int j = 0; j < kPadRings; ++j) {
      const int m = 6 * (j + 1);
      const double r = 0.01 * std::sqrt((j + 0.5) / kPadRings);
      for (int q = 0; q < m; ++q) {
        const double t = (j % 2) * std::numbers::pi / m + 2 * std::numbers::pi * q / m;
        const int f = face_under(c.x() + r * std::cos(t), c.y() + r * std::sin(t), b);
        ASSERT_GE(f, 0);
        Eigen::Vector3d y = Eigen::Vector3d::Zero();
        for (int k = 0; k < 3; ++k) y += b[k] * X.row(F(f, k)).transpose();
        const double yield = std::max(0.0, (y - c).dot(n));
        for (int k = 0; k < 3; ++k) {
          const int i = F(f, k);
          const double w = b[k] / (kPadRings * m);
          want[i].first += w;
          want[i].second += w * ((X.row(i).transpose() - y).dot(n) + yield);
        }
      }
    }
    for (const PadPoint& p : pad) {
      got[p.node].first += p.w;
      got[p.node].second += p.w * p.offset;
    }
    for (const auto& [i, ws] : want) {
      if (ws.first < 1e-14) continue;  // a point on an edge: its third node carries nothing
      ASSERT_TRUE(got.count(i)) << "trial " << trial << ": node " << i << " not loaded";
      EXPECT_NEAR(got[i].first, ws.first, 1e-12) << "trial " << trial << ", node " << i;
      EXPECT_NEAR(got[i].second, ws.second, 1e-14) << "trial " << trial << ", node " << i;
    }
    for (const auto& [i, ws] : got)
      EXPECT_TRUE(want.count(i)) << "trial " << trial << ", node " << i;
  }
}
