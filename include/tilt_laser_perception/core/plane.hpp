/**
 * @file plane.hpp
 * @brief 3D point moments and exact least-squares plane fits from them. ROS-free.
 */
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace tilt_laser_perception {
namespace core {

/// Count, sum and sum of outer products of 3D points. Moments of disjoint sets
/// add; a rigid transform maps them exactly (see transformed()).
struct Moments3 {
  double n = 0.0;
  Eigen::Vector3d s = Eigen::Vector3d::Zero();   ///< [m]
  Eigen::Matrix3d ss = Eigen::Matrix3d::Zero();  ///< [m^2]

  void add(const Eigen::Vector3d& p) {
    n += 1.0;
    s += p;
    ss += p * p.transpose();
  }
  Moments3& operator+=(const Moments3& o) {
    n += o.n;
    s += o.s;
    ss += o.ss;
    return *this;
  }
  Moments3& operator-=(const Moments3& o) {
    n -= o.n;
    s -= o.s;
    ss -= o.ss;
    return *this;
  }
  Eigen::Vector3d mean() const { return n > 0 ? Eigen::Vector3d(s / n) : Eigen::Vector3d::Zero(); }
  /// Moments of the same points after p -> T p.
  Moments3 transformed(const Eigen::Isometry3d& T) const {
    Moments3 m;
    m.n = n;
    const Eigen::Matrix3d R = T.linear();
    const Eigen::Vector3d t = T.translation();
    m.s = R * s + n * t;
    m.ss = R * ss * R.transpose() + (R * s) * t.transpose() + t * (R * s).transpose() + n * t * t.transpose();
    return m;
  }
};

/// A least-squares plane: normal . p = offset.
struct PlaneFit {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero(); ///< [m]
  double offset = 0.0;                                ///< [m]
  double rms = 0.0;                                   ///< rms distance of the points to the plane [m]
  Eigen::Vector3d spread = Eigen::Vector3d::Zero();   ///< standard deviations along the principal axes, ascending [m]
};

/// Fits a plane to moments (n >= 3). The normal's sign is arbitrary.
PlaneFit fitPlane(const Moments3& m);

/// Rms distance of the points of m to the plane f [m] (0 for no points).
double rmsAbout(const Moments3& m, const PlaneFit& f);

}  // namespace core
}  // namespace tilt_laser_perception
