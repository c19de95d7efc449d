// Why refinement softens a tet model at the body (issue 9): the static response of Model-C
// (prototype C's material, bench/refine_models.hpp) to the probe disc pressed at the body,
// where the coarse surface edges (12.9 mm) are longer than the probe face's radius (1 cm), with
// the surface refined around the pressed node to max_level 1, 2, 3 vs not refined.
//
// The stiffness is linear: K (the springs' tangent at rest, spring_eval's, plus the foundation's
// home springs) u = f, with f the unit disc load spread over the surface by the disc pad's weights
// (engine/models/contact_pad.hpp: the same disc on the coarse and the refined surface), and
// k = 1 / (w . u_n) the load over the pad's weighted normal displacement.
#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cstdio>
#include <string>

#include "bench/refine_models.hpp"
#include "engine/models/contact_pad.hpp"
#include "tests/prototypes/probe_points.hpp"

using namespace palplab;
using namespace palplab::engine;

namespace {

using palplab::engine::testing::kBody;
using palplab::engine::testing::kOvary;

struct Static {
  double k = 0;       // N/m
  double needle = 0;  // mean height / edge of the refined surface leaves' coarse fans
  long nodes = 0, springs = 0;
};

// The disc load's stiffness on m's current system, centred at surface node `node`. rings > 0:
// the disc pad's quadrature with that many rings; 0: a uniform pressure over the disc,
// integrated on every surface triangle (a 30 x 30 barycentric grid per triangle).
Static disc_stiffness(const AdaptiveMassSpring& m, int node, int rings = kPadRings) {
  const MassSpringSystem& s = m.sys;
  const long n = s.nodes();
  PadSurface ps;
  build_pad_surface(m.F, n, ps);
  int start = -1;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (int k = ps.node_start[node]; k < ps.node_start[node + 1]; ++k) {
    const int f = ps.node_faces[k];
    start = f;
    const Eigen::Vector3d a = s.X_rest.row(m.F(f, 0)).transpose(),
                          b = s.X_rest.row(m.F(f, 1)).transpose(),
                          c = s.X_rest.row(m.F(f, 2)).transpose();
    normal += (b - a).cross(c - a);  // area-weighted
  }
  normal.normalize();
  std::vector<PadPoint> pad;
  const Eigen::Vector3d centre = s.X_rest.row(node).transpose();
  if (rings > 0) {
    EXPECT_GE(disc_pad(ps, s.X_rest, centre, normal, 0.01, start, pad, rings), 0);
  } else {
    const int g = 30;
    std::vector<double> load(n, 0.0);
    double total = 0;
    for (long f = 0; f < m.F.rows(); ++f) {
      const Eigen::Vector3d a = s.X_rest.row(m.F(f, 0)).transpose(),
                            b = s.X_rest.row(m.F(f, 1)).transpose(),
                            c = s.X_rest.row(m.F(f, 2)).transpose();
      if ((a - centre).norm() > 0.05) continue;
      const Eigen::Vector3d fn = (b - a).cross(c - a);
      if (fn.dot(normal) <= 0) continue;
      const double w = 0.5 * fn.norm() / (g * g);
      for (int i = 0; i < g; ++i)
        for (int j = 0; i + j < g; ++j)
          for (int up = 0; up < 2; ++up) {
            if (up && i + j + 1 >= g) continue;
            // centroid of a small triangle of the grid
            const double u = (i + (up ? 2.0 : 1.0) / 3.0) / g, v = (j + (up ? 2.0 : 1.0) / 3.0) / g;
            const Eigen::Vector3d x = a + u * (b - a) + v * (c - a);
            const Eigen::Vector3d r = x - centre;
            if ((r - r.dot(normal) * normal).norm() > 0.01) continue;
            load[m.F(f, 0)] += w * (1 - u - v);
            load[m.F(f, 1)] += w * u;
            load[m.F(f, 2)] += w * v;
            total += w;
          }
    }
    for (long i = 0; i < n; ++i)
      if (load[i] > 0) pad.push_back({static_cast<int>(i), load[i] / total, 0.0});
  }
  std::vector<Eigen::Triplet<double>> trip;
  for (long e = 0; e < s.springs.size(); ++e) {
    const int a = s.springs.E(e, 0), b = s.springs.E(e, 1);
    // The integrator's own tangent at rest (spring_eval): k d d^T for a spring at its rest
    // length, k I for the refinement's zero-rest-length dent ties.
    const Eigen::Vector3d xa = s.X_rest.row(a).transpose(), xb = s.X_rest.row(b).transpose();
    Eigen::Vector3d f1;
    Eigen::Matrix3d Kx, Kv;
    spring_eval(xa, xb, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), s.springs.ks[e], 0.0,
                s.springs.rest[e], SpringJacobian::definite, f1, Kx, Kv);
    const Eigen::Matrix3d B = -Kx;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        trip.emplace_back(3 * a + i, 3 * a + j, B(i, j));
        trip.emplace_back(3 * b + i, 3 * b + j, B(i, j));
        trip.emplace_back(3 * a + i, 3 * b + j, -B(i, j));
        trip.emplace_back(3 * b + i, 3 * a + j, -B(i, j));
      }
  }
  for (long i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) trip.emplace_back(3 * i + k, 3 * i + k, s.home_ks[i]);
  Eigen::SparseMatrix<double> K(3 * n, 3 * n);
  K.setFromTriplets(trip.begin(), trip.end());
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n);
  for (const PadPoint& p : pad) f.segment<3>(3 * p.node) -= p.w * normal;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(K);
  EXPECT_EQ(solver.info(), Eigen::Success);
  const Eigen::VectorXd u = solver.solve(f);
  double w_u = 0, w = 0;
  for (const PadPoint& p : pad) {
    w_u -= p.w * normal.dot(u.segment<3>(3 * p.node));
    w += p.w;
  }
  Static r;
  r.k = w * w / w_u;  // the pad's load (w N) over its weighted displacement
  r.nodes = m.new_nodes;
  r.springs = m.new_springs;
  // The coarse tet under each refined surface leaf: the height of its apex over the leaf
  // against the leaf's mean edge (a fan of sub-tets from the leaves to that apex is this
  // slender).
  double sum = 0;
  long count = 0;
  for (const RefineTri& t : m.tris) {
    if (t.child >= 0 || t.depth == 0) continue;
    int apex = -1;
    for (int k = 0; k < 4; ++k) {
      const int v = m.tets(m.face_tet[t.root], k);
      if (v != m.F0(t.root, 0) && v != m.F0(t.root, 1) && v != m.F0(t.root, 2)) apex = v;
    }
    const Eigen::Vector3d a = s.X_rest.row(t.v[0]).transpose(),
                          b = s.X_rest.row(t.v[1]).transpose(),
                          c = s.X_rest.row(t.v[2]).transpose(), p = s.X_rest.row(apex).transpose();
    const Eigen::Vector3d nn = (b - a).cross(c - a).normalized();
    const double edge = ((b - a).norm() + (c - b).norm() + (a - c).norm()) / 3;
    sum += std::abs((p - a).dot(nn)) / edge;
    ++count;
  }
  r.needle = count ? sum / count : 0.0;
  return r;
}

}  // namespace

TEST(RefinementDepth, AtTheBodyTheSofteningIsNotTheAdaptiveClosureNorThePadsQuadrature) {
  // Refinement softens Model-C at the body (static, uniform pressure; measured -18.5 / -36.1 /
  // -44.9 % at max_level 1 / 2 / 3, the fans' apex height over the leaf edge 1.2 / 2.1 / 4.1;
  // 12 / 66 / 264 new nodes, 76 / 345 / 1248 new springs). What this test pins down:
  //  - refining the whole model (uniform, no adaptive interface) softens as much as the
  //    adaptive refinement (level 1: -19.3 vs -18.5 %; level 2, 24 030 nodes, too slow to run
  //    here: -37.0 vs -36.1 %), so the adaptive closure is not the cause;
  //  - the disc pad's quadrature matches an exactly integrated uniform pressure on the coarse
  //    mesh (4 rings) and on every level with 8 rings (within 0.4 %); with its 4 rings on the
  //    max_level 3 patch the points (about 2.3 mm apart) load single nodes of 1.6 mm leaves,
  //    each on its fan of needles: 716.5 vs 884.1 N/m (-19 %), the one case where the pad adds
  //    to the softening.
  // Finer base meshes of the organ (docs/ARCHITECTURE.md) show the rest: the unrefined body
  // stiffness falls with the resolution (its 12.9 mm faces lock a 1 cm dent) and the refined
  // one rises faster; they meet between, the refined side from further away.
  AdaptiveMassSpring m = bench::tet_model_c();
  int node = -1;  // the pressed node: the surface node nearest the body point
  double best = INFINITY;
  for (long f = 0; f < m.F0.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const double d = (m.coarse.X_rest.row(m.F0(f, k)).transpose() - kBody).norm();
      if (d < best) {
        best = d;
        node = m.F0(f, k);
      }
    }
  const Static off = disc_stiffness(m, node), off_p = disc_stiffness(m, node, 0);
  std::printf("static stiffness at the body, coarse: disc pad %.1f, pressure %.1f N/m\n", off.k,
              off_p.k);
  EXPECT_NEAR(off.k, off_p.k, 0.01 * off_p.k);
  const double mass = m.sys.mass.sum();
  double adaptive_1 = 0;
  for (int level = 1; level <= 3; ++level) {
    RefineParams p;  // prototype C's refinement
    p.threshold_area = 4e-6;
    p.max_level = level;
    ASSERT_TRUE(refine_around(m, node, p));
    const Static on = disc_stiffness(m, node), on_p = disc_stiffness(m, node, 0),
                 on_8 = disc_stiffness(m, node, 8);
    std::printf(
        "  max_level %d: pressure %.1f (%+.1f %%), disc pad %.1f (%+.1f %%), 8 rings %.1f; %ld new "
        "nodes, %ld new springs; coarse fans' height/edge %.1f\n",
        level, on_p.k, 100 * (on_p.k - off_p.k) / off_p.k, on.k, 100 * (on.k - off.k) / off.k,
        on_8.k, on.nodes, on.springs, on.needle);
    EXPECT_NEAR(on_8.k, on_p.k, 0.01 * on_p.k) << "max_level " << level;
    if (level < 3) {
      EXPECT_NEAR(on.k, on_p.k, 0.01 * on_p.k) << "max_level " << level;
    }
    EXPECT_NEAR(m.sys.mass.sum(), mass, 1e-12 * mass);
    if (level == 1) adaptive_1 = on_p.k;
    simplify(m);
  }
  refine_whole(m, 1);
  const Static whole = disc_stiffness(m, node, 0);
  std::printf("  whole model level 1: pressure %.1f (%+.1f %%), %ld new nodes\n", whole.k,
              100 * (whole.k - off_p.k) / off_p.k, whole.nodes);
  EXPECT_NEAR(whole.k, adaptive_1, 0.07 * adaptive_1);
}

namespace {

// Model-C with C's material on `vertices` surface vertices (bench::tet_model_c).
AdaptiveMassSpring model_c_at(int vertices) {
  return bench::tet_model_c(vertices);
}

int nearest_surface_node(const AdaptiveMassSpring& m, const Eigen::Vector3d& x) {
  int node = -1;
  double best = INFINITY;
  for (long f = 0; f < m.F0.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const double d = (m.coarse.X_rest.row(m.F0(f, k)).transpose() - x).norm();
      if (d < best) {
        best = d;
        node = m.F0(f, k);
      }
    }
  return node;
}

}  // namespace

TEST(RefinementDepth, OnOffOverResolutions) {
  // Issue 9's measures on Model-C (C's material and springs) at three base resolutions: the
  // static stiffness under a uniform 1 cm disc pressure, refinement off and on (max_level 2),
  // at the body and at the ovary. Measured, with the dent ties (refinement.hpp):
  //   nodes   body off / on (N/m)       ovary off / on (N/m)
  //   2426    1604.3 / 1375.1 (-14.3 %)  851.1 / 849.6 (-0.2 %)
  //   4565    1533.9 / 1330.0 (-13.3 %)  839.3 / 828.3 (-1.3 %)
  //   9160    1478.8 / 1387.2 (-6.2 %)   654.3 / 654.3 (no face above the area threshold)
  // Without the ties the refined body was 1024.6 / 1018.2 / 1250.6 (-36.1 / -33.6 / -15.4 %):
  // the sub-tets' dent modes had no stiffness of their own. Now the refined press is the same on
  // every base mesh (within 2.5 % of its mean) and lies where the unrefined press converges as
  // the base mesh is refined (1604 / 1534 / 1479 / 1442 N/m at 2426 / 4565 / 9160 / 17601 nodes,
  // extrapolated 1290-1374 for an order 1-2): the body's on/off gap is the coarse mesh's own
  // discretisation error there (its 12.9 mm faces lock a 1 cm dent), which no correct refinement
  // can keep below 7 %. The springs' limit is not linear elasticity's: the FEM reference at this
  // body (D = Model-C's mesh, E 100 kPa, nu 0.45, the same foundation; docs/ARCHITECTURE.md "D
  // against the trusted references") is 1162 N/m, the refined springs +18 % (a spring network
  // cannot represent nu = 0.45), the unrefined +38 %.
  // Asserted: on/off within the Weber fraction (7 %) at the ovary; the unrefined and the refined
  // body each within 7 % of its mean over the three resolutions; the patch's mass conserved; the
  // body's on/off gap pinned to the measured values (2 points).
  const int res[3] = {1600, 2440, 4000};
  const double body_gap[3] = {-14.3, -13.3, -6.2};  // % (measured, see above)
  double body_off[3], body_on[3];
  for (int r = 0; r < 3; ++r) {
    AdaptiveMassSpring m = model_c_at(res[r]);
    const double mass = m.sys.mass.sum();
    for (const auto& [where, point] : {std::pair{"body", kBody}, std::pair{"ovary", kOvary}}) {
      const int node = nearest_surface_node(m, point);
      const double off = disc_stiffness(m, node, 0).k;
      RefineParams p;  // prototype C's refinement, two levels
      p.threshold_area = 4e-6;
      p.max_level = 2;
      const bool refined = refine_around(m, node, p);
      const Static on = disc_stiffness(m, node, 0);
      EXPECT_NEAR(m.sys.mass.sum(), mass, 1e-12 * mass);
      simplify(m);
      const double gap = 100 * (on.k - off) / off;
      std::printf(
          "%d surface vertices (%ld nodes), %s: off %.1f, on (max_level 2) %.1f N/m (%+.1f %%), "
          "%ld new nodes\n",
          res[r], m.coarse_nodes(), where, off, on.k, gap, on.nodes);
      if (std::string(where) == "body") {
        EXPECT_TRUE(refined);
        body_off[r] = off;
        body_on[r] = on.k;
        EXPECT_NEAR(gap, body_gap[r], 2.0) << res[r];
      } else {
        EXPECT_NEAR(on.k, off, 0.07 * off) << res[r];
      }
    }
  }
  const double mean = (body_off[0] + body_off[1] + body_off[2]) / 3;
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(body_off[r], mean, 0.07 * mean) << res[r];
  const double mean_on = (body_on[0] + body_on[1] + body_on[2]) / 3;
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(body_on[r], mean_on, 0.07 * mean_on) << res[r];
}

TEST(RefinementDepth, DeeperRefinementConvergesAtTheBody) {
  // C's own mesh at the body, refined around the node to max_level 1, 2, 3: with the dent ties
  // the static stiffness falls by shrinking steps (1469 / 1375 / 1325 N/m measured), towards the
  // limit of the unrefined press on ever finer base meshes (see above); without them it fell
  // by growing ones (1307 / 1025 / 884: each level's new dent modes softer than the last).
  AdaptiveMassSpring m = model_c_at(1600);
  const int node = nearest_surface_node(m, kBody);
  double k[4];
  k[0] = disc_stiffness(m, node, 0).k;
  for (int level = 1; level <= 3; ++level) {
    RefineParams p;
    p.threshold_area = 4e-6;
    p.max_level = level;
    ASSERT_TRUE(refine_around(m, node, p));
    k[level] = disc_stiffness(m, node, 0).k;
    simplify(m);
    std::printf("max_level %d: %.1f N/m (off %.1f)\n", level, k[level], k[0]);
  }
  EXPECT_NEAR(k[1], 1469.2, 2.0);
  EXPECT_NEAR(k[2], 1375.1, 2.0);
  EXPECT_NEAR(k[3], 1325.3, 2.0);
  EXPECT_LT(k[3], k[2]);
  EXPECT_LT(k[2], k[1]);
  EXPECT_LT(k[2] - k[3], 0.7 * (k[1] - k[2]));  // converging
  EXPECT_NEAR(k[3], k[2], 0.07 * k[2]);         // the last level changes it by < 7 %
}
