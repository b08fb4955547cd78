#include "tilt_laser_perception/core/noise_model.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>

namespace tilt_laser_perception {
namespace core {

double NoiseModel::rangeSigma(double range) const { return std::max(range_sigma, range_sigma_ratio * range); }

double NoiseModel::chi2Limit(int dof) const { return chi2Quantile(dof, std::erfc(significance / std::sqrt(2.0))); }

double NoiseModel::familySigmas(std::size_t tests) const {
  if (tests <= 1) return significance;
  return std::sqrt(chi2Quantile(1, std::erfc(significance / std::sqrt(2.0)) / static_cast<double>(tests)));
}

std::string NoiseModel::validate() const {
  if (!(range_sigma > 0.0) || !(range_sigma_ratio >= 0.0)) return "range noise must be > 0";
  if (!(line_sigma >= 0.0) || !(line_sigma < 0.5)) return "line pose error must be in [0, 0.5) rad";
  if (!(significance > 0.0) || !(significance <= 10.0)) return "significance must be in (0, 10] sigmas";
  return "";
}

namespace {
/// The regularized lower incomplete gamma function P(a, x), by its series.
double gammaP(double a, double x) {
  if (x <= 0.0) return 0.0;
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 1000; ++n) {
    term *= x / (a + n);
    sum += term;
    if (term < sum * 1e-15) break;
  }
  return std::min(1.0, sum * std::exp(-x + a * std::log(x) - std::lgamma(a)));
}
}  // namespace

double chi2Quantile(int dof, double tail) {
  // P(chi2_k <= x) = P(k / 2, x / 2) grows with x: bisection.
  double lo = 0.0, hi = 1.0;
  while (1.0 - gammaP(0.5 * dof, 0.5 * hi) > tail && hi < 1e4) hi *= 2.0;
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    (1.0 - gammaP(0.5 * dof, 0.5 * mid) > tail ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

PlaneEvidence PlaneEvidence::ofSegment(const Moments3& m, double range, const NoiseModel& model) {
  PlaneEvidence e;
  if (!(m.n >= 2.0)) return e;
  const Eigen::Vector3d c = m.mean();
  const Eigen::Matrix3d cov = m.ss / m.n - c * c.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(cov);
  const Eigen::Vector3d u = es.eigenvectors().col(2);  // along the segment
  const double along = std::max(es.eigenvalues()(2), 1e-12);
  const double sr2 = std::pow(model.rangeSigma(range), 2);
  const double st2 = model.line_sigma * model.line_sigma;
  // Where it lies: its centroid, off by the range noise averaged over its
  // points and by its line's displacement, common to all of them.
  e.w = 1.0 / (sr2 / m.n + range * range * st2);
  e.s = e.w * c;
  // Which way it runs: its slope out of the plane, off by the noise over its
  // length and by its line's turn.
  e.a = e.w * c * c.transpose() + u * u.transpose() / (sr2 / (m.n * along) + st2);
  return e;
}

double PlaneEvidence::chi2() const {
  if (!(w > 0.0)) return 0.0;
  const Eigen::Matrix3d c = a - s * s.transpose() / w;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(c, Eigen::EigenvaluesOnly);
  return std::max(0.0, es.eigenvalues()(0));
}

}  // namespace core
}  // namespace tilt_laser_perception
