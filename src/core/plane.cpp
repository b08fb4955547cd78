#include "tilt_laser_perception/core/plane.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace tilt_laser_perception {
namespace core {

PlaneFit fitPlane(const Moments3& m) {
  PlaneFit f;
  if (m.n < 1.0) return f;
  f.centroid = m.mean();
  const Eigen::Matrix3d cov = m.ss / m.n - f.centroid * f.centroid.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(cov);
  const Eigen::Vector3d ev = es.eigenvalues();  // ascending
  f.normal = es.eigenvectors().col(0).normalized();
  f.offset = f.normal.dot(f.centroid);
  f.rms = std::sqrt(std::max(0.0, ev(0)));
  f.spread = ev.cwiseMax(0.0).cwiseSqrt();
  return f;
}

}  // namespace core
}  // namespace tilt_laser_perception
