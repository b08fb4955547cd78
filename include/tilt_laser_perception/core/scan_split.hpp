/**
 * @file scan_split.hpp
 * @brief Range-adaptive Ramer-Douglas-Peucker split of one 2D scan line into
 *        straight line segments and edge points. ROS-free.
 *
 * Units: ranges and coordinates [m], angles [rad]. Points are in the frame of
 * the scan (x forward at angle 0, y to the left, z = 0).
 */
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace tilt_laser_perception {
namespace core {

/// Point moments of a set of 2D points: count, sums and sums of products.
/// Moments of disjoint sets add up; they give the exact least-squares line
/// (and, lifted to 3D, plane) fit of the union without revisiting points.
struct Moments2 {
  double n = 0.0;    ///< point count
  double sx = 0.0;   ///< sum of x [m]
  double sy = 0.0;   ///< sum of y [m]
  double sxx = 0.0;  ///< sum of x*x [m^2]
  double sxy = 0.0;  ///< sum of x*y [m^2]
  double syy = 0.0;  ///< sum of y*y [m^2]

  void add(double x, double y) {
    n += 1.0; sx += x; sy += y; sxx += x * x; sxy += x * y; syy += y * y;
  }
  Moments2& operator+=(const Moments2& o) {
    n += o.n; sx += o.sx; sy += o.sy; sxx += o.sxx; sxy += o.sxy; syy += o.syy;
    return *this;
  }
};

/// Orthogonal least-squares line through a set of points.
struct LineFit {
  Eigen::Vector2d centroid{0.0, 0.0};   ///< [m]
  Eigen::Vector2d direction{1.0, 0.0};  ///< unit direction
  double rms = 0.0;                     ///< rms orthogonal distance [m]
};

/// Fits a line to moments (n >= 2). The direction's sign is arbitrary.
LineFit fitLine(const Moments2& m);

/// Whether two pieces of a run lie on one line within their fits' noise (the
/// split's merge test of the pieces, in 2D and 3D): the shorter one's mean
/// lies `offset` [m] off the longer one's line, `t` [m] along it from its
/// centroid; the longer has `n_long` points with sum of squares `along`
/// [m^2] along its line, the shorter `n_short`. A line of n points carried t
/// from its centroid is uncertain by sigma^2 (1 / n + t^2 / along), the
/// other's mean by sigma^2 / n_short; `d_t` is the significance level's
/// sigmas of one point (the split's threshold).
inline bool onOneLine(double offset, double t, double n_long, double along, double n_short, double d_t) {
  if (!(along > 0.0)) return true;
  return std::abs(offset) <= d_t * std::sqrt(1.0 / n_long + t * t / along + 1.0 / n_short);
}

/// What makes an edge point.
enum class EdgeKind : std::uint8_t {
  Jump = 1,      ///< near side of a depth jump
  Occluded = 2,  ///< far side of a depth jump (the surface goes on behind)
  Crease = 3,    ///< split point between two segments of one surface run
  Boundary = 4,  ///< next to invalid returns or the end of the scan
  Veil = 5,      ///< a mixed pixel: a return between a near and a far surface, on no surface (one per beam)
};

/// Human-readable name of an edge kind ("jump", "occluded", ..., "veil").
const char* edgeKindName(EdgeKind k);

/// A fitted straight line segment.
struct Segment {
  int first = 0;              ///< first beam index (inclusive)
  int last = 0;               ///< last beam index (inclusive)
  Eigen::Vector2d start;      ///< on the fitted line, where its points begin (beam order) [m]
  Eigen::Vector2d end;        ///< on the fitted line, where its points end: every point projects between [m]
  Eigen::Vector2d direction;  ///< unit vector from start to end
  int count = 0;              ///< valid points fitted
  double rms = 0.0;           ///< rms orthogonal error [m]
  Moments2 moments;           ///< moments of the fitted points
};

/// An edge point of the scan line.
struct EdgePoint {
  int index = 0;                ///< beam index
  EdgeKind kind = EdgeKind::Boundary;
  double angle = 0.0;           ///< crease: angle between adjacent segments [rad]; NaN otherwise
  Eigen::Vector2d point;        ///< position [m]
};

/// Threshold mode of the split.
enum class SplitMode : std::uint8_t {
  Adaptive = 0,  ///< d_T = max(d_min, zeta * R), R the range of the farthest point
  Fixed = 1,     ///< d_T = d_min
};

/// Split settings. Defaults: the paper's zeta = 0.01 with a floor at the
/// data sheet's +-30 mm accuracy.
struct SplitParams {
  SplitMode mode = SplitMode::Adaptive;
  double zeta = 0.01;        ///< adaptive factor [1]
  double d_min = 0.03;       ///< threshold floor; the threshold in fixed mode [m]
  double jump_min = 0.05;    ///< depth jump threshold at zero range [m]
  double jump_ratio = 0.05;  ///< depth jump threshold growth with range [1]
  int min_points = 5;        ///< fewer points than this: no segment
  bool merge = true;         ///< merge neighbouring pieces whose union lies within d_T of its fitted line and that lie on one line (onOneLine)
  /// Mixed pixels: a beam whose neighbours on both sides lie along its own
  /// ray (within this angle), one nearer and one farther, is on no surface
  /// but between two: the veil a depth edge leaves over the footprint's
  /// width. Such beams are marked EdgeKind::Veil and split off. 0: off.
  double veil_angle_deg = 15.0;
  /// A run of such beams longer than this is a surface seen at grazing
  /// incidence, not a veil: a blend lies where the footprint straddles the
  /// edge, over the steps the footprint spans and one more (5 for the
  /// UTM-30LX's 1 degree at 0.25 degree steps). A run that range noise broke
  /// (a step short of the angle by no more than the noise of two ranges) is
  /// judged whole.
  int veil_max_beams = 5;

  /// Empty when valid, else a message naming the bad parameter.
  std::string validate() const;
  /// Split threshold for a point at range r [m].
  double threshold(double r) const {
    if (mode == SplitMode::Fixed) return d_min;
    const double t = zeta * r;
    return t > d_min ? t : d_min;
  }
  /// Depth jump threshold between neighbouring returns, the nearer at range r [m].
  double jumpThreshold(double r) const { return jump_min + jump_ratio * r; }
};

/// One scan line, as in sensor_msgs/LaserScan (not owned).
struct ScanView {
  const float* ranges = nullptr;       ///< [m]
  std::size_t size = 0;
  const float* intensities = nullptr;  ///< optional
  std::size_t intensities_size = 0;    ///< 0 when there are none
  double angle_min = 0.0;              ///< [rad]
  double angle_max = 0.0;              ///< [rad]
  double angle_increment = 0.0;        ///< [rad]
  double range_min = 0.0;              ///< [m]
  double range_max = 0.0;              ///< [m]
  double time_increment = 0.0;         ///< time between beams [s] (0: not given)
  double scan_time = 0.0;              ///< time between scans [s] (0: not given)
};

/// What a scan may be at most: a bound on the memory one scan may take and
/// on its timing, so that one absurd message neither grows the buffers for
/// good nor stalls the lines behind it.
struct ScanLimits {
  std::size_t max_ranges = 10000;  ///< more beams than any 2D lidar gives (the UTM-30LX: 1081 of 1440 per turn)
  double max_duration = 0.5;       ///< (n - 1) * time_increment and scan_time at most [s] (2 Hz scanners)
  /// Empty when valid (max_ranges in [2, 1000000], max_duration in (0, 10] s), else what is wrong.
  std::string validate() const;
};

/// Why a scan is rejected.
enum class ScanError : std::uint8_t {
  None = 0,
  Empty,                 ///< no ranges
  IntensitySize,         ///< intensities present with another size than ranges
  BadIncrement,          ///< angle_increment zero or not finite (negative is fine: an upside-down laser)
  InconsistentAngles,    ///< angle_min + (n-1) * increment more than one increment off angle_max
  BadRangeLimits,        ///< range_min/max not finite or range_max <= range_min
  TooManyRanges,         ///< more ranges than ScanLimits::max_ranges
  BadTimeIncrement,      ///< time_increment or scan_time not finite, negative, or the scan longer than max_duration
};
constexpr int kScanErrorCount = 8;

/// Short name of a scan error ("empty", ...).
const char* scanErrorName(ScanError e);

/// Checks every field of a scan before splitting. Beam i is at angle_min + i * increment (negative
/// increments too); angle_max may be off by up to one increment (drivers round it).
ScanError checkScan(const ScanView& scan, const ScanLimits& limits = ScanLimits());

/// Result of a split; reuse one across scans so that steady state does not allocate.
struct SplitResult {
  std::vector<Segment> segments;
  std::vector<EdgePoint> edges;  ///< in beam order
  int valid_points = 0;  ///< returns inside [range_min, range_max]
  int veil_points = 0;   ///< beams marked EdgeKind::Veil
};

/// How far a segment's own points reach beyond its reported ends, along it
/// [m] (0 when all project between start and end). A scan line crosses a
/// surface in beam order, so its points should not.
double segmentOverhang(const ScanView& scan, const Segment& segment);
/// Angle between a segment and the beam through its middle [rad]: near 0,
/// the segment points at the sensor (a veil of mixed pixels, or a surface at
/// grazing incidence).
double segmentBeamAngle(const Segment& segment);

/// The scan line splitter. Keeps its buffers between scans: after the first
/// scan of a given size it does not allocate. Not thread-safe.
class ScanSplitter {
 public:
  explicit ScanSplitter(const SplitParams& params = SplitParams());

  /// Replaces the settings (must be valid: see SplitParams::validate).
  void setParams(const SplitParams& params);
  const SplitParams& params() const { return params_; }
  void setLimits(const ScanLimits& limits) { limits_ = limits; }
  const ScanLimits& limits() const { return limits_; }

  /// Splits a scan. Returns the check's verdict; on an error `out` is cleared.
  ScanError split(const ScanView& scan, SplitResult& out);

 private:
  struct Run {
    int first, last;              // beam indices of the run's first and last valid return
    EdgeKind start_kind, end_kind;
  };
  void updateTrig(const ScanView& scan);
  void markVeils(int n, SplitResult& out);
  void splitRun(const Run& run, SplitResult& out);
  std::vector<int> veil_before_;  // splitRun's: per kept segment, where a veil before it began (-1: none)
  void fitSegment(int first, int last, Segment& seg) const;
  Moments2 rangeMoments(int first, int last) const;
  bool withinTolerance(int first, int last) const;
  /// Whether the pieces [first, split] and [split + 1, last] lie on one line
  /// within their fits' noise: the shorter one's mean on the longer one's line.
  bool piecesMeet(int first, int split, int last) const;
  bool mergeable(int first, int split, int last) const;  // pieces [first, split] and [split + 1, last]
  double lineDistance(int first, int last, int i) const;
  static Eigen::Vector2d creasePoint(const Segment& p, const Segment& q);  // point i to the line fitted to [first, last]

  SplitParams params_;
  double cos_veil_ = 1.0;  // cos(veil_angle_deg), set with params_
  ScanLimits limits_;
  // per-beam buffers
  std::vector<double> cos_, sin_, x_, y_, r_;
  std::vector<unsigned char> valid_;  // 1: a return; 0: none or a veil point
  std::vector<Moments2> prefix_;  // prefix_[i]: moments of the valid beams before i
  double trig_angle_min_ = 0.0, trig_increment_ = 0.0;
  std::vector<Run> runs_;
  std::vector<std::pair<int, int>> stack_;
  std::vector<std::pair<int, int>> pieces_;
};

}  // namespace core
}  // namespace tilt_laser_perception
