/**
 * @file noise_model.hpp
 * @brief The rig's noise model and the tests the grouping is to take from it.
 *        ROS-free; [m], [rad].
 *
 * Two terms:
 * - range noise sigma_r(R), independent from beam to beam (the data sheet's
 *   repeatability: the UTM-30LX's 10 mm up to 10 m);
 * - each scan line's own pose error sigma_theta (tilt encoder, backlash,
 *   timing), common to all the points of a line: it moves a whole line out of
 *   its scan plane by about R sigma_theta at range R and turns it by about
 *   sigma_theta.
 *
 * (The grouping does not take these tests yet: tried in its place they
 * lost on real rigs whose lines share their errors; doc/notes/noise_model.md.)
 *
 * A straight segment of a line tells two things about the surface it lies
 * on: where it is (its centroid, known to within sigma_r^2 / N + (R
 * sigma_theta)^2 of variance across the surface) and which way it runs (its
 * direction, whose slope out of the surface is known to within
 * sigma_r^2 / (N var_along) + sigma_theta^2). A plane's chi-square over its
 * segments is a quadratic form in (normal, offset) whose parts add
 * (PlaneEvidence): the evidence of two sets of segments is the sum of theirs.
 * Every decision is then a likelihood-ratio test at one significance level:
 *
 * - a segment joins a plane when refitting the plane with it raises the
 *   plane's chi-square by no more than the chi-square quantile of 2 degrees
 *   of freedom (its offset and its slope);
 * - two segments of two lines seed a plane when one plane explains both
 *   (1 degree of freedom: two lines fix a plane and one more number);
 * - two planes are one when the plane of their union explains their segments
 *   as well as the two apart (3 degrees of freedom: one plane fewer).
 *
 * The plane's own uncertainty is in the test: a plane fixed by a few close
 * lines turns to take a segment that fits it turned, one fixed by many does
 * not.
 */
#pragma once

#include <algorithm>
#include <string>

#include <Eigen/Core>

#include "tilt_laser_perception/core/plane.hpp"

namespace tilt_laser_perception {
namespace core {

struct NoiseModel {
  /// Range noise [m, 1 sigma] up to range_sigma / range_sigma_ratio, beyond
  /// that range_sigma_ratio * R: the UTM-30LX data sheet's repeatability
  /// (sigma < 10 mm within 10 m, < 30 mm beyond: 0.3 % of 10 m carries on).
  double range_sigma = 0.01;
  double range_sigma_ratio = 0.001;
  /// Each line's pose error [rad, 1 sigma]: the MX-64's encoder step (0.088
  /// degrees, a uniform error of 0.025 degrees sigma) is the least a tilting
  /// rig has; estimated from the data where it can be (estimateLineSigma).
  double line_sigma = kEncoderStepSigma;
  /// The one significance level, in sigmas of a normal (3: 0.27 % of the
  /// decisions wrong by chance); the chi-square tests take the same tail.
  double significance = 3.0;

  /// A uniform error over one step of 0.088 degrees: step / sqrt(12) [rad].
  static constexpr double kEncoderStepSigma = 0.088 * 3.14159265358979323846 / 180.0 / 3.4641016151377544;

  double rangeSigma(double range) const;
  /// The chi-square quantile of `dof` degrees of freedom (1-3) whose tail is
  /// that of `significance` sigmas of a normal on both sides.
  double chi2Limit(int dof) const;
  /// The sigmas within which all of `tests` independent values of a normal
  /// lie but with the significance level's tail (a two-sided quantile at
  /// that tail over `tests`): where a decision is taken for each of many
  /// points, the level at which any of them is wrong by chance.
  double familySigmas(std::size_t tests) const;
  std::string validate() const;
};

/// The chi-square quantile: x with P(chi2_dof > x) = tail (dof >= 1, 0 < tail < 1).
double chi2Quantile(int dof, double tail);

/// What a set of straight segments says about the plane they lie on:
/// chi2(n, d) = n' A n - 2 d n' s + d^2 w over unit normals n and offsets d
/// (the points x on the plane: n' x = d).
struct PlaneEvidence {
  double w = 0.0;
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();

  /// A segment's: its points' moments (a straight run of one scan line) and
  /// its mean range [m]. Segments of fewer than two points add nothing.
  static PlaneEvidence ofSegment(const Moments3& points, double range, const NoiseModel& model);
  PlaneEvidence& operator+=(const PlaneEvidence& o) {
    w += o.w;
    s += o.s;
    a += o.a;
    return *this;
  }
  PlaneEvidence operator+(const PlaneEvidence& o) const {
    PlaneEvidence e = *this;
    e += o;
    return e;
  }
  /// The least chi-square of any plane (0 when no plane is fixed yet).
  double chi2() const;
  /// The chi-square of the plane n' x = d.
  double chi2(const Eigen::Vector3d& n, double d) const { return n.dot(a * n) - 2.0 * d * n.dot(s) + d * d * w; }
};

/// How much worse one plane explains the union of a and b than the best
/// plane of each apart: a chi-square of 3 degrees of freedom when both fix a
/// plane, 2 when b is one segment, 1 when both are.
inline double chi2Increase(const PlaneEvidence& a, const PlaneEvidence& b) {
  return std::max(0.0, (a + b).chi2() - a.chi2() - b.chi2());
}

}  // namespace core
}  // namespace tilt_laser_perception
