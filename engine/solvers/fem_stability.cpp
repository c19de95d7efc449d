#include "engine/solvers/fem_stability.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "engine/solvers/fem_corotational.hpp"
#include "engine/solvers/fem_element.hpp"

namespace palplab::engine {

LowestModes lowest_modes(const StaticSolver& s, int count, int max_iterations, double tolerance) {
  const SparseMatrixd& K = s.K_ff;
  const long n = K.rows();
  LowestModes out;
  count = static_cast<int>(std::min<long>(count, n));
  if (count <= 0) return out;
  // A few guard vectors beyond `count` speed the convergence of the last wanted one (rate
  // |lambda_count| / |lambda_block|).
  const int block = static_cast<int>(std::min<long>(n, count + 3));
  std::mt19937_64 rng(12);
  std::normal_distribution<double> N01;
  Eigen::MatrixXd X(n, block);
  for (long i = 0; i < n; ++i)
    for (int j = 0; j < block; ++j) X(i, j) = N01(rng);
  const double kmax = std::max(K.diagonal().cwiseAbs().maxCoeff(), 1e-300);
  for (int it = 1; it <= max_iterations; ++it) {
    X = s.solve_free(X);
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(X);
    X = qr.householderQ() * Eigen::MatrixXd::Identity(n, block);
    // Rayleigh-Ritz on the subspace.
    const Eigen::MatrixXd KX = K * X;
    Eigen::MatrixXd H = X.transpose() * KX;
    H = 0.5 * (H + H.transpose()).eval();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(H);
    std::vector<int> order(static_cast<size_t>(block));
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      return std::abs(es.eigenvalues()[a]) < std::abs(es.eigenvalues()[b]);
    });
    Eigen::MatrixXd V(block, block);
    for (int j = 0; j < block; ++j) V.col(j) = es.eigenvectors().col(order[j]);
    X = X * V;
    const Eigen::MatrixXd KXr = KX * V;
    out.values.resize(count);
    double worst = 0;
    for (int j = 0; j < count; ++j) {
      out.values[j] = es.eigenvalues()[order[j]];
      worst = std::max(worst, (KXr.col(j) - out.values[j] * X.col(j)).norm() / kmax);
    }
    out.iterations = it;
    out.residual = worst;
    if (worst <= tolerance) break;
  }
  out.vectors = X.leftCols(count);
  return out;
}

std::vector<double> ellipticity_margin(const FemSystem& sys, const Eigen::VectorXd& x,
                                       CorotMaterial material) {
  std::vector<double> m(static_cast<size_t>(sys.T.rows()), 1.0);
  for (long t = 0; t < sys.T.rows(); ++t) {
    if (!sys.material.rigid.empty() && sys.material.rigid[static_cast<size_t>(t)]) continue;
    Vector12d xe;
    for (int r = 0; r < 4; ++r) xe.segment<3>(3 * r) = x.segment<3>(3 * sys.T(t, r));
    const Eigen::Matrix3d F = deformation_gradient(sys.shape[static_cast<size_t>(t)].grad, xe);
    double mu = 0, lambda = 0;
    lame(sys.material.youngs_modulus[t], sys.material.poisson_ratio[t], mu, lambda);
    m[static_cast<size_t>(t)] = acoustic_tensor_min(material_tangent(material, F, mu, lambda)) / mu;
  }
  return m;
}

ModeShape mode_shape(const FemSystem& sys, const Eigen::VectorXd& phi, const Eigen::VectorXd& f,
                     const Eigen::Vector3d& point, double radius,
                     const std::vector<double>& margin) {
  ModeShape out;
  const double pn = phi.norm(), fn = f.norm();
  if (!(pn > 0)) return out;
  out.load_cosine = fn > 0 ? f.dot(phi) / (fn * pn) : 0.0;
  const long nv = sys.nodes();
  Eigen::VectorXd w(nv);
  for (long i = 0; i < nv; ++i) w[i] = phi.segment<3>(3 * i).squaredNorm();
  const double total = w.sum();
  long imax = 0;
  w.maxCoeff(&imax);
  out.max_node_distance = (sys.X0.row(imax).transpose() - point).norm();
  double near = 0;
  for (long i = 0; i < nv; ++i)
    if ((sys.X0.row(i).transpose() - point).norm() <= 2 * radius) near += w[i];
  out.near_press_fraction = near / total;
  out.participation = total * total / w.squaredNorm();
  std::vector<std::uint8_t> in(static_cast<size_t>(nv), 0);
  for (long t = 0; t < sys.T.rows() && t < static_cast<long>(margin.size()); ++t)
    if (margin[static_cast<size_t>(t)] <= 0)
      for (int r = 0; r < 4; ++r) in[static_cast<size_t>(sys.T(t, r))] = 1;
  double ne = 0;
  for (long i = 0; i < nv; ++i)
    if (in[static_cast<size_t>(i)]) ne += w[i];
  out.non_elliptic_fraction = ne / total;
  return out;
}

}  // namespace palplab::engine
