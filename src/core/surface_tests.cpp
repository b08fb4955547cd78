#include "tilt_laser_perception/core/surface_tests.hpp"

#include <cmath>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

namespace tilt_laser_perception {
namespace core {

namespace {
constexpr double kDeg = M_PI / 180.0;
}  // namespace

std::string GroupingParams::validate() const {
  std::ostringstream s;
  if (!(dist_min > 0.0)) s << "dist_min must be > 0";
  else if (!(dist_ratio >= 0.0)) s << "dist_ratio must be >= 0";
  else if (!(angle_deg > 0.0 && angle_deg < 90.0)) s << "angle_deg must be in (0, 90)";
  else if (!(merge_angle_deg > 0.0 && merge_angle_deg < 90.0)) s << "merge_angle_deg must be in (0, 90)";
  else if (max_line_gap < 1) s << "max_line_gap must be >= 1";
  else if (min_segments < 1) s << "min_segments must be >= 1";
  else if (!(crease_reach >= 0.0 && crease_reach < 1.0)) s << "crease_reach must be in [0, 1)";
  else if (!(crease_margin >= 0.0 && crease_margin < 1.0)) s << "crease_margin must be in [0, 1)";
  else if (!(line_sigma >= 0.0 && line_sigma < 0.1)) s << "line_sigma must be in [0, 0.1) rad";
  else if (!(significance > 0.0 && significance <= 10.0)) s << "significance must be in (0, 10]";
  return s.str();
}

double SurfaceTests::lineTilt(const SurfaceEvidence& r) const {
  // The line term moves each of its lines by about R line_sigma, common to
  // the line's points; over `lines` lines spread by spread(1) across them
  // that tilts the fit by that over spread(1) sqrt(lines) (one sigma).
  if (p_.line_sigma <= 0.0) return 0.0;
  return p_.significance * p_.line_sigma * (r.fit.centroid - sensor_).norm() /
         (std::max(r.fit.spread(1), 1e-9) * std::sqrt(static_cast<double>(std::max(r.lines, 1))));
}

Eigen::Matrix3d SurfaceTests::normalCovariance(const SurfaceEvidence& r) const {
  // A plane fitted to n independent measurements of sigma, spread by s_k
  // along its in-plane axes e_k, has a normal uncertain by sigma / (s_k
  // sqrt(n)) towards e_k. What is independent on a rig is a line (the line
  // term moves all its points together), and lines closer to each other
  // than one sigma across count as one (a slow sweep repeats a servo reading;
  // no fit can tell them apart): at most 1 + width / sigma of them.
  const double spread = r.fit.spread(1);
  if (!(spread > 0.0) || r.lines < 2) return Eigen::Matrix3d::Identity() * kUnknownNormal;
  const double range = (r.fit.centroid - sensor_).norm();
  // Each line's place: the range noise (the threshold's floor is
  // `significance` sigmas of it) and the line term, or what the plane's own
  // points show where that is more (a surface that is not quite flat).
  const double sigma = std::max(
      std::hypot(std::max(p_.dist_min, p_.dist_ratio * range) / p_.significance, p_.line_sigma * range), r.fit.rms);
  const double lines = std::min(static_cast<double>(r.lines), 1.0 + std::sqrt(12.0) * spread / sigma);
  const Eigen::Vector3d c = r.moments.mean();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(r.moments.ss / r.moments.n - c * c.transpose());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int k = 1; k < 3; ++k) {
    const Eigen::Vector3d e = es.eigenvectors().col(k);
    cov += e * e.transpose() * (sigma * sigma / (lines * std::max(es.eigenvalues()(k), 1e-12)));
  }
  return cov;
}

bool SurfaceTests::endsOn(const Segment3& s, const SurfaceEvidence& r) const {
  const double tilt = lineTilt(r);
  const double thr = kEndsOn * p_.threshold(s.range);
  for (const Eigen::Vector3d& e : {s.start, s.end})
    if (std::abs(r.fit.normal.dot(e) - r.fit.offset) > thr + tilt * (e - r.fit.centroid).norm()) return false;
  return true;
}

bool SurfaceTests::planesAgree(const SurfaceEvidence& a, const SurfaceEvidence& b, double* score) const {
  // One surface when their normals agree, each one's plane reaches the
  // other's centroid within what its width leaves uncertain, and the plane
  // of their union explains each of them (every part's rms about it within
  // the tolerance). A plane fitted to a narrow strip of lines has an
  // uncertain normal (a real rig's lines are offset from each other by
  // encoder steps, backlash, timing: a strip of width w whose lines lie
  // within +-thr of one surface may tilt by atan(2 thr / w)), so it is
  // judged by its fit with the other, not by extrapolating it.
  const double thr = p_.threshold(std::min((a.fit.centroid - sensor_).norm(), (b.fit.centroid - sensor_).norm()));
  // Two strips of lines too close together to fix a normal fit one plane
  // whatever they saw (the scan plane): one of them must fix it (or be a
  // piece of one line, which joins a strip as it would join by itself).
  if (!planar(a) && !planar(b) && a.lines > 1 && b.lines > 1) return false;
  if (std::abs(a.fit.normal.dot(b.fit.normal)) < std::cos(p_.merge_angle_deg * kDeg)) return false;
  // Within that, their normals must agree within both fits' uncertainty
  // (normalCovariance): chi-square of 2 degrees of freedom, whose quantile
  // at tail p is -2 ln p, at the significance level.
  const Eigen::Vector3d nb = a.fit.normal.dot(b.fit.normal) < 0.0 ? Eigen::Vector3d(-b.fit.normal) : b.fit.normal;
  const Eigen::Vector3d mid = (a.fit.normal + nb).normalized();
  Eigen::Matrix<double, 3, 2> across;
  across.col(0) = mid.unitOrthogonal();
  across.col(1) = mid.cross(across.col(0));
  const Eigen::Vector2d d = across.transpose() * (nb - a.fit.normal);
  const Eigen::Matrix2d cov = across.transpose() * (normalCovariance(a) + normalCovariance(b)) * across;
  if (d.dot(cov.ldlt().solve(d)) > -2.0 * std::log(std::erfc(p_.significance / std::sqrt(2.0)))) return false;
  const auto slack = [&](const SurfaceEvidence& r) {
    const double width = std::sqrt(12.0) * r.fit.spread(1);  // across its lines, for points spread evenly
    return width > 0.0 ? 2.0 * thr / width : 1e3;             // tan of the tilt it leaves uncertain
  };
  const double apart = (a.fit.centroid - b.fit.centroid).norm();
  if (std::abs(a.fit.normal.dot(b.fit.centroid) - a.fit.offset) > thr + apart * slack(a)) return false;
  if (std::abs(b.fit.normal.dot(a.fit.centroid) - b.fit.offset) > thr + apart * slack(b)) return false;
  Moments3 m = a.moments;
  m += b.moments;
  const PlaneFit f = fitPlane(m);
  const double worst = std::max(rmsAbout(a.moments, f), rmsAbout(b.moments, f));
  if (score) *score = worst / thr;
  return worst < kUnionRms * thr;
}

namespace {
constexpr double kSinNearScanPlane = 0.5;  // sin 30 degrees
}  // namespace

Eigen::Matrix3d SurfaceTests::raysOf(const Segment3& s) {
  if (!s.origin.allFinite()) return Eigen::Matrix3d::Zero();
  const Eigen::Vector3d u = (s.moments.mean() - s.origin).normalized();
  return s.moments.n * u * u.transpose();
}

Moments3 SurfaceTests::originsOf(const Segment3& s) {
  Moments3 m;
  if (!s.origin.allFinite()) return m;
  m.n = s.moments.n;
  m.s = m.n * s.origin;
  m.ss = m.n * s.origin * s.origin.transpose();
  return m;
}

double SurfaceTests::spreadAcross(const SurfaceEvidence& r) const {
  // A plane that the rays which saw its points graze is one they cannot
  // see: the envelope of their scan planes (where the lines of a laser on an
  // arm meet beside it, or a nodding head's lines meet where its axis
  // pierces a wall), which points there fit whatever their surface. Its
  // lines fix no normal: the rays meet it at a mean squared sine under a
  // grazing ray's. (The trace of `rays` is their points' number.)
  const double with_rays = r.rays.trace();
  if (with_rays > 0.0 && r.fit.normal.dot(r.rays * r.fit.normal) < kMinRayIncidence * kMinRayIncidence * with_rays)
    return 0.0;
  // Nearer the laser than its arm: the scan planes' common tangent (above).
  if (p_.arm > 0.0 && r.origins.n > 0.0 && rmsAbout(r.origins, r.fit) < p_.arm) return 0.0;
  if (r.across.isZero() || r.moments.n < 1.0) return r.fit.spread(1);
  // Within the plane, across the lines: the scan plane's normal projected on
  // it. Where the plane lies near the scan plane, one line's own spread
  // within it (two pieces of a line at an angle) would pass for a spread
  // across lines: counted less, in proportion.
  // (|v| is the sine of the angle between the planes; the spread along v,
  // divided by |v|, is the spread along the unit direction.)
  const Eigen::Vector3d v = r.across - r.across.dot(r.fit.normal) * r.fit.normal;
  const Eigen::Vector3d c = r.moments.mean();
  const Eigen::Matrix3d cov = r.moments.ss / r.moments.n - c * c.transpose();
  const double along = std::sqrt(std::max(0.0, v.dot(cov * v))) / std::max(v.norm(), kSinNearScanPlane);
  return std::min(r.fit.spread(1), along);
}


bool SurfaceTests::onPlane(const SurfaceEvidence& r, const Segment3& s, bool lone, double& score) const {
  const double thr = p_.threshold(s.range);
  const double d1 = std::abs(r.fit.normal.dot(s.start) - r.fit.offset);
  const double d2 = std::abs(r.fit.normal.dot(s.end) - r.fit.offset);
  const double dc = std::abs(r.fit.normal.dot(s.moments.mean()) - r.fit.offset);
  if (!endsOn(s, r)) return false;
  if (s.length() > 0.15 && std::abs((s.end - s.start).normalized().dot(r.fit.normal)) > std::sin(p_.angle_deg * kDeg))
    return false;
  const double tol = p_.centroidTolerance(s.range) + lineTilt(r) * (s.moments.mean() - r.fit.centroid).norm();
  if (dc > tol) {
    // Beyond the lines that fixed it a plane's place is as uncertain as its
    // tilt (a face seen by three lines, its fourth a backlash off): a
    // segment that no plane took fits if the plane refitted with it takes
    // it within the tolerance, without turning by more than the merge
    // angle, and still fits the plane's own points.
    if (!lone) return false;
    Moments3 m = r.moments;
    m += s.moments;
    const PlaneFit f = fitPlane(m);
    if (std::abs(f.normal.dot(s.moments.mean()) - f.offset) > tol ||
        std::abs(f.normal.dot(r.fit.normal)) < std::cos(p_.merge_angle_deg * kDeg) ||
        rmsAbout(r.moments, f) > 0.5 * thr)
      return false;
  }
  score = std::max(d1, d2) / thr;
  return true;
}

}  // namespace core
}  // namespace tilt_laser_perception
