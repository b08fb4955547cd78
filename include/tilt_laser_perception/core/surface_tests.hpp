/**
 * @file surface_tests.hpp
 * @brief The grouping's noise model (GroupingParams: range noise, each
 *        line's pose error, one significance level) and the decisions it
 *        takes from it about surfaces: whether a segment lies on a plane,
 *        whether a plane's lines fix its normal, how uncertain that normal is,
 *        whether two planes are one surface. ScanLineGrouper (grouping.hpp)
 *        is the region-growing engine that applies them: which segments are
 *        neighbours, in what order they are judged, what is done with the
 *        answer. ROS-free; [m], [rad].
 */
#pragma once

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tilt_laser_perception/core/plane.hpp"

namespace tilt_laser_perception {
namespace core {

/// A straight segment of one scan line, in 3D.
struct Segment3 {
  int line = 0;               ///< scan line index in the sweep
  int first = 0, last = 0;    ///< beam indices (inclusive)
  Eigen::Vector3d start = Eigen::Vector3d::Zero(), end = Eigen::Vector3d::Zero();  ///< end points [m]
  Moments3 moments;           ///< of its points in 3D
  double range = 0.0;         ///< mean range of its points [m]
  /// Where the sensor saw it from (NaN: unknown). Range noise moves a point
  /// along its ray, so a polygon corner is put where the ray meets the plane.
  Eigen::Vector3d origin = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double length() const { return (end - start).norm(); }
};

/// A segment of the points pts[first..last] (NaN points skipped) with their
/// ranges: moments, mean range, and end points on the points' own line.
/// False when fewer than two points are valid. For Vector3d points with
/// double ranges, and Vector3f points with float ranges (a scan's own).
template <class Point, class Range>
bool makeSegment3(const std::vector<Point>& pts, const std::vector<Range>& ranges, int line, int first, int last,
                  Segment3& out);

/// The grouping's settings: its noise model (the distance tolerances, the
/// line term, the significance) and the engine's topology (seed gap, line
/// gap, beam slack, sizes).
struct GroupingParams {
  double dist_min = 0.03;         ///< plane distance threshold floor [m]
  double dist_ratio = 0.015;      ///< threshold growth with range [1]
  double centroid_min = 0.012;    ///< a segment's centroid must lie this close to the plane [m] ...
  double centroid_ratio = 0.005;  ///< ... plus this much of its range [1] (a fitted line is far less noisy than its points)
  double angle_deg = 12.0;        ///< a segment may leave its plane by this much [deg]
  double merge_angle_deg = 15.0;  ///< the most two planes' normals may differ by and merge, however uncertain (within it the noise model judges them, and their union must fit each); a crease cut's new plane differs by more [deg]
  double seed_gap = 0.25;         ///< largest distance between the segments that seed a plane [m] (+ 5 % of range)
  int beam_slack = 8;             ///< beam index slack for overlap between adjacent lines
  int max_line_gap = 2;           ///< a plane stays open this many lines without a new segment
  int min_segments = 2;           ///< smaller planes are dropped (a riser may be crossed by two lines only)
  double min_area = 0.01;         ///< [m^2]
  int min_points = 8;             ///< segments with fewer points than this are left out
  double crease_reach = 0.08;     ///< two planes' polygons that both end this close to their common line are carried to it (closeCreases) ... [m]
  double crease_margin = 0.005;   ///< ... up to this far from it; reach <= margin: never [m]
  /// The noise model's line term: each scan line's own pose error (tilt
  /// encoder, backlash, timing), common to all its points, moves a whole line
  /// by about range * line_sigma out of its scan plane [rad, 1 sigma]; 0: the
  /// tolerances above hold alone. A line is taken to be on a plane while it
  /// lies within `significance` of these sigmas of it.
  double line_sigma = 0.0;
  double significance = 3.0;  ///< [sigmas]
  /// The sweep's last line lies beside its first (a spinning head's half or
  /// whole turn ends in the plane it began in): planes that meet across that
  /// seam merge as planes that meet anywhere else.
  bool cyclic_lines = false;
  /// The laser's distance from the axis it turns about [m] (0: unknown). Each
  /// scan plane touches the cylinder of this radius about the axis, so the
  /// points beside the laser, whatever their surface, lie near the scan
  /// planes' common tangent: a plane that passes nearer than this to where
  /// its lines were seen from (root mean square) fixes no normal.
  double arm = 0.0;
  std::string validate() const;
  /// How far a segment's points may lie from its plane [m].
  double threshold(double range) const {
    return std::max({dist_min, dist_ratio * range, significance * line_sigma * range});
  }
  /// How far a segment's centroid may lie from its plane [m]: a fitted line is far less noisy than its
  /// points, but its pose error is its points' too.
  double centroidTolerance(double range) const {
    return std::max({centroid_min, centroid_ratio * range, significance * line_sigma * range});
  }
};

/// What the grouping knows of one surface as it grows: its points, their
/// plane, the lines that saw it and from where. (ScanLineGrouper's regions
/// add their members.)
struct SurfaceEvidence {
  Moments3 moments;  ///< of its points
  int first_line = 0, last_line = 0;  ///< the lines it spans
  int lines = 0;  ///< distinct scan lines among the members
  PlaneFit fit;  ///< the plane of its points (fitPlane(moments))
  /// The scan plane's normal at its first segment (zero: unknown). The
  /// points of one scan line all lie in its scan plane, which they fit
  /// whatever the surface: only their spread out of it, across the lines,
  /// fixes the surface's normal.
  Eigen::Vector3d across = Eigen::Vector3d::Zero();
  /// Its members' rays: the sum over them of points x u u^T, u the unit
  /// ray from a segment's origin to its centroid (SurfaceTests::raysOf()). n^T rays n over
  /// its trace (the points with a known origin) is the mean squared sine at
  /// which they meet a plane of normal n.
  Eigen::Matrix3d rays = Eigen::Matrix3d::Zero();
  /// Where its members were seen from: each origin weighted by its
  /// segment's points (SurfaceTests::originsOf()).
  Moments3 origins;
};

/// The same-surface decisions of the grouping, from its noise model (the
/// parameters) and the sensor's place.
class SurfaceTests {
 public:
  explicit SurfaceTests(const GroupingParams& p = GroupingParams(),
                        const Eigen::Vector3d& sensor = Eigen::Vector3d::Zero())
      : p_(p), sensor_(sensor) {}
  const GroupingParams& params() const { return p_; }
  const Eigen::Vector3d& sensor() const { return sensor_; }

  /// How far r's points spread across its lines within its plane [m]
  /// (counted less where the plane lies within 30 degrees of its first scan
  /// plane, where one line's own spread would pass for it; none where the
  /// rays that saw its points graze its plane).
  double spreadAcross(const SurfaceEvidence& r) const;
  /// A segment's share of SurfaceEvidence::rays (zero where its origin is unknown).
  static Eigen::Matrix3d raysOf(const Segment3& s);
  /// A segment's share of SurfaceEvidence::origins (none where its origin is unknown).
  static Moments3 originsOf(const Segment3& s);
  /// Whether r's lines lie far enough apart to fix its normal.
  bool planar(const SurfaceEvidence& r) const { return r.last_line > r.first_line && spreadAcross(r) > kPlanarSpread; }
  /// Points spread this much across their lines, or more, fix a normal [m].
  static constexpr double kPlanarSpread = 0.02;

  /// Three lines or more span a plane (two parallel lines fit any plane
  /// through both), if they lie far enough apart.
  bool confirmed(const SurfaceEvidence& r) const { return r.lines >= 3 && planar(r); }

  /// Whether both ends of s lie within kEndsOn thresholds of r's plane, and
  /// beyond its centroid within what the line term leaves its tilt
  /// uncertain (lineTilt) over the distance: a segment joins a plane only so.
  bool endsOn(const Segment3& s, const SurfaceEvidence& r) const;
  /// A segment's end is one beam, as noisy as any point, where its fit is
  /// not: it may lie 1.5 distance thresholds off (the growth's factor since
  /// its start, set by hand, not yet from the noise model).
  static constexpr double kEndsOn = 1.5;
  /// The tangent of the tilt the line term leaves r's plane uncertain by
  /// (significance sigmas; 0 without a line term).
  double lineTilt(const SurfaceEvidence& r) const;
  /// The covariance of r's normal [rad^2], from the noise model: each of its
  /// lines one measurement of the surface (see the definition).
  Eigen::Matrix3d normalCovariance(const SurfaceEvidence& r) const;
  /// A normal's variance where a region fixes none (one line, no spread).
  static constexpr double kUnknownNormal = 1e6;

  /// Whether a and b are one surface; `score`: the worst part's rms about
  /// their union's plane over the distance threshold (how well it explains them).
  bool planesAgree(const SurfaceEvidence& a, const SurfaceEvidence& b, double* score = nullptr) const;

  /// Whether s lies on r's plane (r must fix its normal: planar()): both
  /// ends (endsOn), its direction within `angle_deg`, its centroid within the
  /// centroid tolerance and the line term's tilt over the distance. `lone`:
  /// a segment no plane took (the late joins), which beyond that tolerance
  /// still fits when r's plane refitted with it takes it within it, turns by
  /// no more than the merge angle and still fits r's own points. `score`:
  /// its farther end's distance over the threshold.
  bool onPlane(const SurfaceEvidence& r, const Segment3& s, bool lone, double& score) const;
  /// A ray meeting a plane at less than this sine of an angle grazes it.
  static constexpr double kMinRayIncidence = 0.1;

 private:
  /// Two planes are one surface when the plane of their union fits each of
  /// them with an rms within this fraction of the distance threshold.
  static constexpr double kUnionRms = 0.75;
  GroupingParams p_;
  Eigen::Vector3d sensor_ = Eigen::Vector3d::Zero();
};

}  // namespace core
}  // namespace tilt_laser_perception
