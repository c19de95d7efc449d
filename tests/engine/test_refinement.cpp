// Adaptive area-based refinement: conforming closed surface, mass conservation through many
// refine/simplify cycles without memory growth, area-based vs conventional subdivision, and the
// parameter identification of Eq 5.16–5.18.
#include <gtest/gtest.h>
#include <malloc.h>

#include <cmath>
#include <functional>
#include <map>

#include "engine/mesh/generate.hpp"
#include "engine/mesh/rings.hpp"
#include "engine/mesh/tet_mesh.hpp"
#include "engine/models/mass_spring_material.hpp"
#include "engine/models/refinement.hpp"

using namespace palplab::engine;

namespace {

// Octahedron; `stretch` moves the +x tip outwards so the four faces around it are larger.
AdaptiveMassSpring octahedron(double stretch, double threshold_mass_noise = 0.0) {
  MassSpringSystem s;
  s.X_rest.resize(6, 3);
  s.X_rest << stretch, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  s.X_rest *= 0.01;  // 1 cm
  RowMatX3i F(8, 3);
  // ccw seen from outside
  F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  s.X = s.X_rest;
  s.mass = Eigen::VectorXd::Constant(6, 0.01);
  for (int i = 0; i < 6; ++i) s.mass[i] += threshold_mass_noise * i;
  s.home_ks = Eigen::VectorXd::Constant(6, 5.0);
  s.home_kd = Eigen::VectorXd::Constant(6, 0.1);
  s.springs = springs_from_edges(s.X_rest, unique_edges(F), 100.0, 0.5);
  const Eigen::VectorXd c = Eigen::VectorXd::Constant(F.rows(), 100.0);  // N/m membrane
  s.springs = membrane_springs(s.X_rest, F, c, 0.005);
  return make_adaptive(std::move(s), F, c, 0.005, 1e-3);
}

// Closed, edge-manifold, consistently oriented: every directed edge exactly once, and its
// reverse exactly once. A T-junction or crack leaves an unmatched half-edge.
bool closed_and_conforming(const RowMatX3i& F, long nodes) {
  std::map<std::pair<int, int>, int> he;
  for (long f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      if (a == b || a < 0 || b < 0 || a >= nodes || b >= nodes) return false;
      if (++he[{a, b}] > 1) return false;
    }
  for (const auto& [e, c] : he)
    if (!he.count({e.second, e.first})) return false;
  return true;
}

double signed_volume(const RowMatX3d& X, const RowMatX3i& F) {
  double v = 0;
  for (long f = 0; f < F.rows(); ++f)
    v += X.row(F(f, 0)).dot(X.row(F(f, 1)).cross(X.row(F(f, 2)))) / 6.0;
  return v;
}

}  // namespace

TEST(Refinement, AreaBasedStaysClosedAndConforming) {
  AdaptiveMassSpring m = octahedron(3.0);
  const double vol0 = signed_volume(m.sys.X_rest, m.F);
  RefineParams p;
  p.threshold_area = 2e-5;  // faces near +x (~4.7e-4 m^2... at 1 cm scale) split several times
  p.max_level = 4;
  ASSERT_TRUE(refine_around(m, 0, p));
  EXPECT_GT(m.new_nodes, 0);
  EXPECT_GE(m.level, 2);
  EXPECT_TRUE(closed_and_conforming(m.F, m.sys.nodes()));
  // Midpoints lie on the coarse faces: the rest volume is unchanged.
  EXPECT_NEAR(signed_volume(m.sys.X_rest, m.F), vol0, 1e-15);
  // Refining around a midpoint node deepens further and stays conforming.
  const int mid = static_cast<int>(m.sys.nodes()) - 1;
  p.threshold_area = 2e-6;
  p.max_level = 5;
  refine_around(m, mid, p);
  EXPECT_TRUE(closed_and_conforming(m.F, m.sys.nodes()));
  EXPECT_EQ(m.sys.nodes(), m.sys.X.rows());
  EXPECT_EQ(m.sys.mass.size(), m.sys.nodes());
  // Every node is used by a face.
  std::vector<int> used(m.sys.nodes(), 0);
  for (long f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[m.F(f, k)] = 1;
  for (int u : used) EXPECT_EQ(u, 1);
}

TEST(Refinement, MassConservedThroughThousandCyclesWithoutMemoryGrowth) {
  AdaptiveMassSpring m = octahedron(2.5, 0.003);  // non-uniform masses
  const double M0 = m.coarse.mass.sum();
  const Eigen::VectorXd coarse_mass = m.coarse.mass;
  RefineParams p;
  p.threshold_area = 5e-6;
  p.max_level = 4;
  size_t heap_at_100 = 0;
  for (int cycle = 0; cycle < 1000; ++cycle) {
    const int node = cycle % 6;
    // Deform a little so refinement carries a non-rest state.
    m.sys.X.row(node) += Eigen::RowVector3d(1e-4, 0, 0);
    ASSERT_TRUE(refine_around(m, node, p));
    const double M = m.sys.mass.sum();
    ASSERT_NEAR(M, M0, 1e-12 * M0) << "cycle " << cycle;
    ASSERT_TRUE((m.sys.mass.array() > 0).all());
    ASSERT_TRUE(simplify(m));
    ASSERT_EQ(m.sys.nodes(), 6);
    ASSERT_EQ(m.sys.springs.size(), 12);
    ASSERT_EQ(m.F.rows(), 8);
    ASSERT_TRUE((m.sys.mass.array() == coarse_mass.array()).all());  // bit for bit
    ASSERT_EQ(m.h, 1e-3);
    if (cycle == 99) heap_at_100 = mallinfo2().uordblks;
  }
  const size_t heap_at_1000 = mallinfo2().uordblks;
  EXPECT_LE(heap_at_1000, heap_at_100 + 1024) << "heap grew from " << heap_at_100;
}

TEST(Refinement, AreaBasedCreatesFewerNodesThanConventionalOnVariedAreas) {
  RefineParams area;
  // Around node 2 two faces touch the stretched +x tip (2.2e-4 m^2) and two do not (8.7e-5
  // m^2): with A_t = 3e-5 the large faces need two levels, the small ones one.
  area.threshold_area = 3e-5;
  area.max_level = 6;
  AdaptiveMassSpring a = octahedron(3.0);
  refine_around(a, 2, area);
  ASSERT_GE(a.level, 2);
  RefineParams conv;
  conv.policy = RefinePolicy::conventional;
  conv.level = a.level;  // the same finest level as area-based reached
  AdaptiveMassSpring c = octahedron(3.0);
  refine_around(c, 2, conv);
  EXPECT_EQ(c.level, a.level);
  EXPECT_LT(a.new_nodes, c.new_nodes);
  EXPECT_LT(a.new_springs, c.new_springs);
  EXPECT_TRUE(closed_and_conforming(c.F, c.sys.nodes()));
  // Whole-model refinement creates the most.
  AdaptiveMassSpring w = octahedron(3.0);
  refine_whole(w, a.level);
  EXPECT_GT(w.new_nodes, c.new_nodes);
  EXPECT_TRUE(closed_and_conforming(w.F, w.sys.nodes()));
  std::printf(
      "varied areas: area-based %ld nodes %ld springs, conventional %ld / %ld, whole %ld / %ld\n",
      a.new_nodes, a.new_springs, c.new_nodes, c.new_springs, w.new_nodes, w.new_springs);
}

TEST(Refinement, AreaBasedEqualsConventionalWhenAllAreasEqual) {
  RefineParams area;
  area.threshold_area = 2e-5;  // regular octahedron face 8.7e-5 m^2: two levels
  area.max_level = 6;
  AdaptiveMassSpring a = octahedron(1.0);
  refine_around(a, 0, area);
  EXPECT_EQ(a.level, 2);
  RefineParams conv;
  conv.policy = RefinePolicy::conventional;
  conv.level = 2;
  AdaptiveMassSpring c = octahedron(1.0);
  refine_around(c, 0, conv);
  EXPECT_EQ(a.new_nodes, c.new_nodes);
  EXPECT_EQ(a.new_springs, c.new_springs);
  EXPECT_TRUE((a.F.array() == c.F.array()).all());
}

// Strain energy of the springs under the uniform small strain eps: sum 1/2 ks (l e.eps.e)^2.
double uniform_strain_energy(const MassSpringSystem& s, const Eigen::Matrix3d& eps) {
  double w = 0.0;
  for (long k = 0; k < s.springs.size(); ++k) {
    const Eigen::Vector3d d =
        (s.X_rest.row(s.springs.E(k, 0)) - s.X_rest.row(s.springs.E(k, 1))).transpose();
    const double stretch = d.dot(eps * d) / d.norm();
    w += 0.5 * s.springs.ks[k] * stretch * stretch;
  }
  return w;
}

TEST(Refinement, ParameterIdentification) {
  AdaptiveMassSpring m = octahedron(1.0);
  const double ks0 = m.sys.springs.ks[0];
  ASSERT_TRUE(refine_whole(m, 1));  // every face once: N = 6, N' = 6 + 12 = 18
  EXPECT_EQ(m.new_nodes, 12);
  EXPECT_EQ(m.sys.springs.size(), 48);  // 8 faces -> 32 faces, E = 3F/2; no coarse edge left
  EXPECT_EQ(m.new_springs, 48);
  EXPECT_DOUBLE_EQ(m.h, 0.5e-3);  // Eq 5.18, l = 1
  int l = -1, slod = -1;
  level_and_slod(m, 0, &l, &slod);
  EXPECT_EQ(l, 1);
  EXPECT_EQ(slod, 4);
  // Masses by area lumping of each face's share: a face gathers 4 x 0.01/4... = 0.0075 kg and
  // gives each of its 4 children's corners 0.0075/12: a coarse corner is in 4 faces (one child
  // each), a midpoint in 2 faces (three children each).
  for (long i = 0; i < 6; ++i) EXPECT_NEAR(m.sys.mass[i], 0.0025, 1e-15);
  for (long i = 6; i < 18; ++i) EXPECT_NEAR(m.sys.mass[i], 0.00375, 1e-15);
  EXPECT_NEAR(m.sys.mass.sum(), 0.06, 1e-15);
  // van Gelder on the children (area/4, edge/2): every spring keeps the coarse stiffness, and
  // damping stays stiffness-proportional.
  for (long k = 0; k < m.sys.springs.size(); ++k) {
    EXPECT_NEAR(m.sys.springs.ks[k], ks0, 1e-9 * ks0);
    EXPECT_NEAR(m.sys.springs.kd[k], 0.005 * m.sys.springs.ks[k], 1e-12);
    const int a = m.sys.springs.E(k, 0), b = m.sys.springs.E(k, 1);
    EXPECT_NEAR(m.sys.springs.rest[k], (m.sys.X_rest.row(a) - m.sys.X_rest.row(b)).norm(), 1e-15);
  }
  // The support (home springs) is conserved like the mass.
  EXPECT_NEAR(m.sys.home_ks.sum(), 30.0, 1e-12);
}

TEST(Refinement, StrainEnergyAndPatchMassConservedOnIrregularMesh) {
  // A stretched octahedron with uneven masses: red splits keep the strain energy of every
  // uniform strain exactly; green closures (partial refinement) to first order; the mass is
  // conserved exactly and restored bit for bit by simplify.
  Eigen::Matrix3d eps;
  eps << 0.010, 0.003, -0.002, 0.003, -0.004, 0.005, -0.002, 0.005, 0.007;
  AdaptiveMassSpring m = octahedron(1.7, 0.001);
  const double w0 = uniform_strain_energy(m.sys, eps);
  const Eigen::VectorXd mass0 = m.sys.mass;
  ASSERT_TRUE(refine_whole(m, 2));
  EXPECT_NEAR(uniform_strain_energy(m.sys, eps), w0, 1e-12 * w0);
  EXPECT_NEAR(m.sys.mass.sum(), mass0.sum(), 1e-15);
  simplify(m);
  EXPECT_TRUE((m.sys.mass.array() == mass0.array()).all());
  RefineParams p;
  p.policy = RefinePolicy::conventional;
  p.level = 2;
  ASSERT_TRUE(refine_around(m, 0, p));  // the four faces at the tip, green closures around them
  EXPECT_NEAR(uniform_strain_energy(m.sys, eps), w0, 0.05 * w0);
  EXPECT_NEAR(m.sys.mass.sum(), mass0.sum(), 1e-15);
  for (long i = 0; i < m.sys.nodes(); ++i) EXPECT_GT(m.sys.mass[i], 0.0) << i;
}

TEST(Refinement, PartialRefinementLevels) {
  // Partial refinement of a root gives a SLoD between 1 and 3: after a whole level 1, refine
  // around one coarse corner of root 0 to level 2 — only the children at that corner split.
  AdaptiveMassSpring q = octahedron(1.0);
  refine_whole(q, 1);
  RefineParams p;
  p.policy = RefinePolicy::conventional;
  p.level = 2;
  const int corner = q.F0(0, 0);
  ASSERT_TRUE(refine_around(q, corner, p));
  int l = -1, slod = -1;
  level_and_slod(q, 0, &l, &slod);
  EXPECT_EQ(l, 1);
  EXPECT_GE(slod, 1);
  EXPECT_LE(slod, 3);
  EXPECT_EQ(q.level, 2);
  EXPECT_DOUBLE_EQ(q.h, 0.25e-3);
  EXPECT_TRUE(closed_and_conforming(q.F, q.sys.nodes()));
  EXPECT_NEAR(q.sys.mass.sum(), 0.06, 1e-15);
}

TEST(Refinement, ModelCSurfaceStaysClosedUnderEveryPolicy) {
  // The real tetrahedral Model-C: only its boundary faces refine; the refined surface must stay
  // closed and conforming wherever and however it is refined, and simplify must restore it.
  const palplab::mesh::TetMesh tm = palplab::mesh::generate_model_c(0, 2489);
  const palplab::mesh::BoundaryFaces bf = palplab::mesh::boundary_faces(tm);
  MassSpringSystem s;
  s.X_rest = tm.V;
  s.X = tm.V;
  s.mass = Eigen::VectorXd::Constant(tm.V.rows(), 0.8 / tm.V.rows());
  const Eigen::VectorXd E = Eigen::VectorXd::Constant(tm.T.rows(), 1e5);
  s.springs = tet_springs(tm.V, tm.T, E, 0.002);
  AdaptiveMassSpring m = make_adaptive(std::move(s), bf.F,
                                       boundary_membrane(tm.V, tm.T, bf.F, bf.tet, E), 0.002, 1e-3);
  ASSERT_TRUE(closed_and_conforming(m.F, m.sys.nodes()));
  const RowMatX3i F0 = m.F;
  const long S0 = m.sys.springs.size();
  for (RefinePolicy pol : {RefinePolicy::area_based, RefinePolicy::conventional}) {
    RefineParams p;
    p.policy = pol;
    p.threshold_area = 2e-6;
    p.max_level = 3;
    p.level = 2;
    // Accumulate refinements around several nodes (a sliding press), then check.
    for (int v = 0; v < static_cast<int>(F0.rows()); v += 397) refine_around(m, F0(v, 0), p);
    EXPECT_GT(m.new_nodes, 0);
    EXPECT_TRUE(closed_and_conforming(m.F, m.sys.nodes()));
    // Interior (tet) springs are untouched: every coarse spring not on a split edge survives.
    EXPECT_GE(m.sys.springs.size(), S0);
    EXPECT_NEAR(m.sys.mass.sum(), 0.8, 1e-12);
    simplify(m);
    EXPECT_TRUE((m.F.array() == F0.array()).all());
    EXPECT_EQ(m.sys.springs.size(), S0);
  }
}

TEST(Refinement, TetsUnderTheRefinedSurfaceAreReDivided) {
  // Model-C with its tets given: refining re-divides the tets under the refined surface (fans
  // over refined faces, bisection at split edges) and applies van Gelder's rule to the parts.
  // Their volumes sum to the tet's, so sum_e k_e |e|^2 (= 6 sum_t E_t V_t for van Gelder
  // springs) is conserved exactly, and every new node has springs into the volume (at an angle
  // out of the surface), not only membrane springs in it.
  const palplab::mesh::TetMesh tm = palplab::mesh::generate_model_c(0, 2489);
  const palplab::mesh::BoundaryFaces bf = palplab::mesh::boundary_faces(tm);
  MassSpringSystem s;
  s.X_rest = tm.V;
  s.X = tm.V;
  s.mass = Eigen::VectorXd::Constant(tm.V.rows(), 0.8 / tm.V.rows());
  Eigen::VectorXd E = Eigen::VectorXd::Constant(tm.T.rows(), 1e5);
  for (long t = 0; t < E.size(); t += 3) E[t] = 3e5;  // uneven moduli
  s.springs = tet_springs(tm.V, tm.T, E, 0.002);
  auto trace = [](const MassSpringSystem& q) {
    return (q.springs.ks.array() * q.springs.rest.array().square()).sum();
  };
  const double tr0 = trace(s);
  AdaptiveMassSpring m =
      make_adaptive(std::move(s), bf.F, boundary_membrane(tm.V, tm.T, bf.F, bf.tet, E), 0.002, 1e-3,
                    CoarseTets{tm.T, E, bf.tet, Eigen::VectorXd::Constant(tm.T.rows(), 0.45)});
  RefineParams p;
  p.threshold_area = 2e-6;
  p.max_level = 3;
  for (int v = 0; v < static_cast<int>(bf.F.rows()); v += 397) refine_around(m, bf.F(v, 0), p);
  ASSERT_GT(m.new_nodes, 0);
  EXPECT_NEAR(trace(m.sys), tr0, 1e-12 * tr0);
  EXPECT_NEAR(m.sys.mass.sum(), 0.8, 1e-12);
  // Springs with a rest length are positive; the rest are the dent ties, three per new node
  // m = mid(a, b): (m, a) and (m, b) with k/2, (a, b) with -k/4, k = 0.5546 E l / (1 - nu^2),
  // l = |m a| (refinement.hpp), so that their energy is (k/2) |x_m - (x_a + x_b)/2|^2.
  long ties = 0;
  for (long k = 0; k < m.sys.springs.size(); ++k) {
    if (m.sys.springs.rest[k] > 0.0) {
      EXPECT_GT(m.sys.springs.ks[k], 0.0) << k;
      continue;
    }
    ASSERT_LE(k + 2, m.sys.springs.size() - 1);
    const int mi = m.sys.springs.E(k, 0), a = m.sys.springs.E(k, 1);
    ASSERT_GE(mi, m.coarse_nodes());
    const auto& pr = m.midpoint_parents[mi - m.coarse_nodes()];
    const double l = (m.sys.X_rest.row(mi) - m.sys.X_rest.row(a)).norm();
    const double E_root = E[m.face_tet[m.midpoint_root[mi - m.coarse_nodes()]]];
    const double kt = kConeDentStiffness * E_root * l / (1 - 0.45 * 0.45);
    EXPECT_EQ(a, pr[0]);
    EXPECT_EQ(m.sys.springs.E(k + 1, 1), pr[1]);
    EXPECT_EQ(m.sys.springs.E(k + 2, 0), pr[0]);
    EXPECT_EQ(m.sys.springs.E(k + 2, 1), pr[1]);
    EXPECT_NEAR(m.sys.springs.ks[k], kt / 2, 1e-12 * kt);
    EXPECT_NEAR(m.sys.springs.ks[k + 1], kt / 2, 1e-12 * kt);
    EXPECT_NEAR(m.sys.springs.ks[k + 2], -kt / 4, 1e-12 * kt);
    // Zero energy for a displacement linear in space (uniform strain plus rigid motion), the
    // quadratic form otherwise: m moved off its parents' mean by 1 mm.
    const Eigen::Matrix3d G = Eigen::Matrix3d::Random();
    auto energy = [&](const Eigen::Vector3d& dm) {
      double e = 0;
      for (int t = 0; t < 3; ++t) {
        const int p = m.sys.springs.E(k + t, 0), q = m.sys.springs.E(k + t, 1);
        const Eigen::Vector3d xp = G * m.sys.X_rest.row(p).transpose() +
                                   (p == mi ? dm : Eigen::Vector3d::Zero()),
                              xq = G * m.sys.X_rest.row(q).transpose();
        e += 0.5 * m.sys.springs.ks[k + t] * (xp - xq).squaredNorm();
      }
      return e;
    };
    EXPECT_NEAR(energy(Eigen::Vector3d::Zero()), 0.0, 1e-9 * kt * l * l);
    EXPECT_NEAR(energy(Eigen::Vector3d(0, 0, 1e-3)), 0.5 * kt * 1e-6, 1e-9 * kt * 1e-6);
    ++ties;
    k += 2;
  }
  EXPECT_EQ(ties, m.new_nodes);
  // Into the volume: a spring at a large angle (> 11.5 deg) to the surface at the node.
  const long N = m.coarse_nodes();
  const MassSpringSystem& q = m.sys;
  std::vector<std::uint8_t> into_volume(q.nodes(), 0);
  for (long f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d x0 = q.X_rest.row(m.F(f, 0)).transpose(),
                          n = (Eigen::Vector3d(q.X_rest.row(m.F(f, 1)).transpose()) - x0)
                                  .cross(Eigen::Vector3d(q.X_rest.row(m.F(f, 2)).transpose()) - x0)
                                  .normalized();
    for (int c = 0; c < 3; ++c) {
      const int i = m.F(f, c);
      if (i < N) continue;
      for (int k = q.adj_start[i]; k < q.adj_start[i + 1]; ++k) {
        const int e = q.adj_spring[k];
        const Eigen::Vector3d d =
            (q.X_rest.row(q.springs.E(e, 0)) - q.X_rest.row(q.springs.E(e, 1)))
                .transpose()
                .normalized();
        if (std::abs(d.dot(n)) > 0.2) into_volume[i] = 1;
      }
    }
  }
  long without = 0;
  for (long i = N; i < q.nodes(); ++i) without += !into_volume[i];
  EXPECT_EQ(without, 0) << "of " << m.new_nodes << " new nodes";
  simplify(m);
  EXPECT_EQ(trace(m.sys), tr0);
}

// The dent ties' constant (refinement.hpp): the stiffness k = c E* l of a cone-shaped surface
// displacement w(r) = 1 - r/l (r < l) of a half-space, from the Boussinesq kernel in Fourier
// space, p^(q) = E* |q| w^(q) / 2: k = 2 energy = (E* / 4 pi) int_0^inf q^2 W(q)^2 dq with W the
// Hankel transform 2 pi int_0^l w(r) J0(q r) r dr. The same quadrature gives the closed form
// k = pi sqrt(2 pi) / 8 E* s of a Gaussian w = exp(-r^2 / s^2), W = pi s^2 exp(-q^2 s^2 / 4).
namespace {
double simpson(const std::function<double(double)>& f, double a, double b, int n) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4.0 : 2.0) * f(a + i * h);
  return s * h / 3.0;
}
double dent_stiffness(const std::function<double(double)>& w, double rmax, double qmax) {
  auto W = [&](double q) {
    const int n = 2 * std::max(50, static_cast<int>(2 * q * rmax));
    return 2 * M_PI *
           simpson([&](double r) { return w(r) * std::cyl_bessel_j(0.0, q * r) * r; }, 0.0, rmax,
                   n);
  };
  const int nq = 2 * static_cast<int>(8 * qmax);
  return simpson([&](double q) { return q * q * W(q) * W(q); }, 0.0, qmax, nq) / (4 * M_PI);
}
}  // namespace

TEST(Refinement, DentTieConstantIsTheConesHalfSpaceStiffness) {
  const double gauss = dent_stiffness([](double r) { return std::exp(-r * r); }, 7.0, 14.0);
  EXPECT_NEAR(gauss, M_PI * std::sqrt(2 * M_PI) / 8, 1e-4);  // the quadrature: 2e-5
  // The cone's transform decays as q^-3: the tail beyond q = 150 adds < 1e-5.
  const double cone = dent_stiffness([](double r) { return 1.0 - r; }, 1.0, 150.0);
  std::printf("cone %.6f, Gaussian %.8f\n", cone, gauss);
  EXPECT_NEAR(cone, kConeDentStiffness, 2e-4);
}
