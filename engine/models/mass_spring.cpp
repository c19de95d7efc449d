#include "engine/models/mass_spring.hpp"

#include <algorithm>
#include <cmath>

namespace palplab::engine {

Eigen::Vector3d spring_force(const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                             const Eigen::Vector3d& v1, const Eigen::Vector3d& v2, double ks,
                             double kd, double rest) {
  const Eigen::Vector3d du = x1 - x2;
  const double len = du.norm();
  if (len <= 0.0) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d dir = du / len;
  const double mag = ks * (len - rest) + kd * (v1 - v2).dot(dir);
  return -mag * dir;
}

void spring_tangent(const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, const Eigen::Vector3d& v1,
                    const Eigen::Vector3d& v2, double ks, double kd, double rest,
                    SpringJacobian jac, SpringTangent& t) {
  const Eigen::Vector3d du = x1 - x2;
  const double len = du.norm();
  if (len <= 0.0) {
    t.f1.setZero();
    t.d.setZero();
    t.axial = t.lateral = t.kd = 0.0;
    return;
  }
  t.d = du / len;
  t.f1 = -(ks * (len - rest) + kd * (v1 - v2).dot(t.d)) * t.d;
  t.axial = ks;
  t.lateral = spring_lateral(ks, rest, rest / len, jac);
  t.kd = kd;
}

void spring_eval(const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, const Eigen::Vector3d& v1,
                 const Eigen::Vector3d& v2, double ks, double kd, double rest, SpringJacobian jac,
                 Eigen::Vector3d& f1, Eigen::Matrix3d& Kx, Eigen::Matrix3d& Kv) {
  SpringTangent t;
  spring_tangent(x1, x2, v1, v2, ks, kd, rest, jac, t);
  f1 = t.f1;
  if (t.d.isZero()) {  // zero length
    Kx.setZero();
    Kv.setZero();
    return;
  }
  const Eigen::Matrix3d P = t.d * t.d.transpose();
  Kx = -(t.axial * P + t.lateral * (Eigen::Matrix3d::Identity() - P));
  Kv = -t.kd * P;
}

void build_adjacency(MassSpringSystem& sys) {
  const long n = sys.nodes();
  const auto& E = sys.springs.E;
  sys.adj_start.assign(n + 1, 0);
  for (long s = 0; s < E.rows(); ++s) {
    ++sys.adj_start[E(s, 0) + 1];
    ++sys.adj_start[E(s, 1) + 1];
  }
  for (long i = 0; i < n; ++i) sys.adj_start[i + 1] += sys.adj_start[i];
  sys.adj_spring.resize(sys.adj_start[n]);
  std::vector<int> fill(sys.adj_start.begin(), sys.adj_start.end() - 1);
  for (long s = 0; s < E.rows(); ++s) {
    sys.adj_spring[fill[E(s, 0)]++] = static_cast<int>(s);
    sys.adj_spring[fill[E(s, 1)]++] = static_cast<int>(s);
  }
}

namespace {
inline void add_node_terms(const MassSpringSystem& sys, const RowMatX3d& X, const RowMatX3d& V,
                           RowMatX3d& F, long i) {
  F.row(i) = sys.F_ext.row(i);
  const double kh = sys.home_ks[i], dh = sys.home_kd[i];
  if (kh != 0.0 || dh != 0.0) F.row(i) += kh * (sys.X_rest.row(i) - X.row(i)) - dh * V.row(i);
}
inline void add_spring(const MassSpringSystem& sys, const RowMatX3d& X, const RowMatX3d& V,
                       RowMatX3d& F, long s) {
  const int a = sys.springs.E(s, 0), b = sys.springs.E(s, 1);
  const Eigen::Vector3d f =
      spring_force(X.row(a).transpose(), X.row(b).transpose(), V.row(a).transpose(),
                   V.row(b).transpose(), sys.springs.ks[s], sys.springs.kd[s], sys.springs.rest[s]);
  F.row(a) += f.transpose();
  F.row(b) -= f.transpose();
}
}  // namespace

void compute_forces(const MassSpringSystem& sys, const RowMatX3d& X, const RowMatX3d& V,
                    RowMatX3d& F, const std::vector<int>* nodes, const std::vector<int>* springs) {
  if (F.rows() != X.rows()) F.setZero(X.rows(), 3);
  if (nodes) {
    for (int i : *nodes) add_node_terms(sys, X, V, F, i);
  } else {
    for (long i = 0; i < X.rows(); ++i) add_node_terms(sys, X, V, F, i);
  }
  // The probe's penalty on the patch (rows outside `nodes` are written into, and ignored).
  if (sys.contact_node >= 0)
    for (size_t k = 0; k < sys.contact_nodes.size(); ++k) {
      const double d = contact_node_penetration(sys, X, k);
      if (d > 0.0)
        F.row(sys.contact_nodes[k]) -=
            (sys.contact_k * sys.contact_weights[k] * d) * sys.contact_normal.transpose();
    }
  // Forces on endpoints outside `nodes` are written too (into rows the caller ignores).
  if (springs) {
    for (int s : *springs) add_spring(sys, X, V, F, s);
  } else {
    for (long s = 0; s < sys.springs.size(); ++s) add_spring(sys, X, V, F, s);
  }
}

Springs springs_from_edges(const RowMatX3d& X, const RowMatX2i& edges, double ks, double kd) {
  Springs s;
  s.E = edges;
  s.rest.resize(edges.rows());
  for (long e = 0; e < edges.rows(); ++e)
    s.rest[e] = (X.row(edges(e, 0)) - X.row(edges(e, 1))).norm();
  s.ks = Eigen::VectorXd::Constant(edges.rows(), ks);
  s.kd = Eigen::VectorXd::Constant(edges.rows(), kd);
  return s;
}

double total_mass(const MassSpringSystem& sys) {
  return sys.mass.sum();
}

}  // namespace palplab::engine

namespace palplab::engine {

double contact_node_penetration(const MassSpringSystem& sys, const RowMatX3d& X, size_t k) {
  const int i = sys.contact_nodes[k];
  const Eigen::Vector3d& n = sys.contact_normal;
  const double flat = (X.row(i).transpose() - sys.contact_point).dot(n);
  if (!sys.contact_offsets.empty()) return std::max(0.0, flat - sys.contact_offsets[k]);
  // Rest height of the node above its pad centre's tangent plane: the pad yields to it.
  const int c = sys.contact_refs.empty() ? sys.contact_node : sys.contact_refs[k];
  const double above = (sys.X_rest.row(i) - sys.X_rest.row(c)).dot(n.transpose());
  return std::max(0.0, flat - std::max(0.0, above));
}

double contact_penetration(const MassSpringSystem& sys, const RowMatX3d& X) {
  if (sys.contact_node < 0) return 0.0;
  double d = 0.0;
  for (size_t k = 0; k < sys.contact_nodes.size(); ++k)
    d += sys.contact_weights[k] * contact_node_penetration(sys, X, k);
  return d;
}

}  // namespace palplab::engine
