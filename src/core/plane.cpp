#include "tilt_laser_perception/core/plane.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace tilt_laser_perception {
namespace core {

namespace {
/// The eigenvalues of a symmetric 3 x 3 matrix `a` (scaled to unit size),
/// ascending, when the smallest lies well apart from the next (a plane, not
/// a line or a blob); false otherwise. The smallest is the first root of
/// the characteristic polynomial, which Newton's method reaches from 0
/// without overshooting (the polynomial rises and bends down up to it), in
/// a few steps when it is well apart; the other two then solve a quadratic.
bool planeEigenvalues(const Eigen::Matrix3d& a, Eigen::Vector3d& e) {
  const double tr = a.trace();
  const double c1 = a(0, 0) * a(1, 1) - a(0, 1) * a(0, 1) + a(0, 0) * a(2, 2) - a(0, 2) * a(0, 2) +
                    a(1, 1) * a(2, 2) - a(1, 2) * a(1, 2);
  const double det = a.determinant();
  double x = 0.0;
  bool converged = false;
  for (int it = 0; it < 8 && !converged; ++it) {
    const double fx = ((x - tr) * x + c1) * x - det;
    const double dfx = (3.0 * x - 2.0 * tr) * x + c1;
    if (!(dfx > 0.0)) return false;
    const double dx = fx / dfx;
    x -= dx;
    converged = std::abs(dx) <= 1e-15 * tr;
  }
  if (!converged) return false;
  // The other two: their sum and product.
  const double sum = tr - x, prod = c1 - x * sum;
  const double hi = 0.5 * sum + std::sqrt(std::max(0.0, 0.25 * sum * sum - prod));
  const double mid = hi > 0.0 ? prod / hi : 0.0;
  if (!(mid - x > 1e-6 * hi)) return false;
  e << x, mid, hi;
  return true;
}
}  // namespace

PlaneFit fitPlane(const Moments3& m) {
  PlaneFit f;
  if (m.n < 1.0) return f;
  f.centroid = m.mean();
  const Eigen::Matrix3d cov = m.ss / m.n - f.centroid * f.centroid.transpose();
  // Scaled to unit size (Newton's tolerance is relative to it); a zero
  // matrix has no normal.
  const double scale = cov.cwiseAbs().maxCoeff();
  Eigen::Vector3d ev = Eigen::Vector3d::Zero();
  bool done = false;
  if (scale > 0.0 && std::isfinite(scale)) {
    const Eigen::Matrix3d a = cov / scale;
    Eigen::Vector3d e;
    if (planeEigenvalues(a, e)) {
      // The normal, the smallest eigenvalue's eigenvector: the cross product
      // of two rows of a - e0 I, the largest of the three for accuracy.
      Eigen::Matrix3d k = a;
      k.diagonal().array() -= e(0);
      const Eigen::Vector3d c[3] = {k.row(0).cross(k.row(1)), k.row(0).cross(k.row(2)), k.row(1).cross(k.row(2))};
      const double n2[3] = {c[0].squaredNorm(), c[1].squaredNorm(), c[2].squaredNorm()};
      const int i = n2[0] >= n2[1] ? (n2[0] >= n2[2] ? 0 : 2) : (n2[1] >= n2[2] ? 1 : 2);
      if (n2[i] > 0.0) {
        f.normal = c[i] / std::sqrt(n2[i]);
        ev = e * scale;
        done = true;
      }
    }
  }
  if (!done) {
    // Near-degenerate (two smallest eigenvalues alike, or none finite):
    // Eigen's solver, which orders the eigenvectors of equal eigenvalues.
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(cov);
    ev = es.eigenvalues();  // ascending
    f.normal = es.eigenvectors().col(0).normalized();
  }
  f.offset = f.normal.dot(f.centroid);
  f.rms = std::sqrt(std::max(0.0, ev(0)));
  f.spread = ev.cwiseMax(0.0).cwiseSqrt();
  return f;
}

double rmsAbout(const Moments3& m, const PlaneFit& f) {
  if (!(m.n > 0.0)) return 0.0;
  const Eigen::Vector3d& n = f.normal;
  const double e = n.dot(m.ss * n) / m.n - 2.0 * f.offset * n.dot(m.s) / m.n + f.offset * f.offset;
  return std::sqrt(std::max(0.0, e));
}

}  // namespace core
}  // namespace tilt_laser_perception
