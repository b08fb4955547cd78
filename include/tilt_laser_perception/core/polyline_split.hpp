/**
 * @file polyline_split.hpp
 * @brief The range-adaptive split for scan lines given as 3D points (a row or
 *        column of an organized cloud: a multi-beam lidar's ring, a range
 *        image), for grouping beyond the tilting head. ROS-free; [m].
 */
#pragma once

#include <cstdint>
#include <vector>

#include "tilt_laser_perception/core/grouping.hpp"
#include "tilt_laser_perception/core/scan_split.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

namespace tilt_laser_perception {
namespace core {

/// Splits one line of 3D points (NaN: no return) seen from `origin` into
/// straight segments: breaks at invalid points and depth jumps, then the
/// farthest-point split against d_T = max(d_min, zeta * R) (SplitParams, the
/// same as for 2D scans), neighbouring pieces merged again as the 2D split
/// merges them (SplitParams::merge: the union within d_T of its line, the
/// shorter piece on the longer one's line within their fits' noise), keeping
/// pieces of at least min_points points.
/// Appends Segment3 with `line` set to `line`.
void splitPolyline(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin,
                   const SplitParams& params, int line, std::vector<Segment3>& out);

}  // namespace core
}  // namespace tilt_laser_perception

namespace tilt_laser_perception {
namespace core {

/// segmentOrganized's stages [s]: the split, addLine, finish, the lines between.
struct OrganizedTimes {
  double split = 0.0, add = 0.0, finish = 0.0, between = 0.0;
};

/// Split and scan line grouping of an organized cloud (row-major, width x
/// height) whose rows (or columns) are scan lines seen from `origin`. Fills
/// the planes and a label per point (0: no plane, else plane id + 1).
/// `line_step` k > 1 groups every k-th line (and the last) only; a point of
/// a line between two grouped ones joins the plane of the grouped point
/// before or after it in its column that it lies within the grouping's
/// distance threshold of (the nearer of two). The planes' fits and polygons
/// are the grouped lines'; their `points` count every labelled point.
/// `times`, when given, receives the stages' durations. `threads` 2 or more
/// uses a second thread: it splits the lines while this one adds them to
/// the grouping (then `times` holds each thread's time: the split's and the
/// adding's, which overlap), it takes half of the finish's crease votes and
/// polygons (ScanLineGrouper::setThreads) and half of the lines between. The
/// planes and labels are the same as with one.
void segmentOrganized(const std::vector<Eigen::Vector3f>& points, int width, int height, bool lines_are_rows,
                      const Eigen::Vector3d& origin, const SplitParams& split, const GroupingParams& grouping,
                      std::vector<Plane>& planes, std::vector<std::uint32_t>& labels, int line_step = 1,
                      OrganizedTimes* times = nullptr, int threads = 1);

/// The lines grouped apart no closer than `line_spacing` [rad]: the step k
/// for segmentOrganized, from the median angle between neighbouring points
/// across the lines (1 when they are farther apart, when fewer than 100
/// pairs are valid, or line_spacing <= 0; at most half the lines).
int organizedLineStep(const std::vector<Eigen::Vector3f>& points, int width, int height, bool lines_are_rows,
                      const Eigen::Vector3d& origin, double line_spacing);

/// The spacing of the lines segment_cloud groups by default [rad]: 0.5
/// degrees, about three times the density of the tilting head's sweeps of 36
/// lines over 50 degrees, on which the grouping is judged (evaluate). On the
/// clouds doc/notes/real_rigs.md lists it kept or bettered every figure of every line
/// grouped; 0.6 and 1 degree lost faces of SynPEB's cloud.
constexpr double kOrganizedLineSpacing = 0.5 * 3.14159265358979323846 / 180.0;

/// What an organized cloud's own points say about its sensor.
struct CloudNoise {
  /// The range noise [m]: each point's range against the mean of its two
  /// neighbours' (a second difference: 1.5 sigma^2 of variance on a smooth
  /// surface), along the rows and along the columns, sigma from the median
  /// of their sizes (depth edges are few, and a median does not see them);
  /// the larger of the two. Across the scan lines it holds what differs from
  /// line to line too (a tilting rig's offsets between its lines).
  double sigma = 0.0;
  /// The same along the scan lines alone: the range noise without what
  /// differs from line to line [m].
  double along = 0.0;
  double step = 0.0;  ///< the median angle between neighbouring beams along the scan lines [rad]
};
/// Zeros when fewer than 100 neighbours are valid.
CloudNoise estimateCloudNoise(const std::vector<Eigen::Vector3f>& points, int width, int height, bool lines_are_rows,
                              const Eigen::Vector3d& origin);

/// The noise model's line term, estimated from an organized cloud: each
/// line's offset from the plane of the lines before it (the `step`-th
/// lines, as grouped: three of them and nine beams), relative to its range,
/// on about 300 patches that are planar (rms under 3 cm, spread across the
/// lines over 1 cm); a robust sigma (1.4826 x the median), less what range
/// noise leaves in such an offset (measured by the difference of the odd and
/// even beams' offsets, in which the line's own pose cancels). The
/// grouping's GroupingParams::line_sigma [rad]; 0 when fewer than 100
/// patches qualify. Measured: 0.07 deg on a sweep of the simulator's ideal
/// head, 0.10-0.16 with --realistic, 0.33 on the nodding SICK scan of
/// ../shared/data (3dtk); 0.16-0.18 on range images with 1 cm of range noise
/// and no line error (a bias: doc/notes/noise_model.md).
double estimateLineSigma(const std::vector<Eigen::Vector3f>& points, int width, int height, bool lines_are_rows,
                         const Eigen::Vector3d& origin, int step = 1);

/// The noise model as a finished sweep shows it: its lines the rows of an
/// organized cloud (every line as long as the longest, NaN where a beam saw
/// nothing), seen from the laser's mean place.
struct SweepNoiseEstimate {
  CloudNoise range;         ///< estimateCloudNoise's (its `along`: the rig's range noise alone)
  double line_sigma = 0.0;  ///< estimateLineSigma's [rad] (0 with fewer than 4 lines)
};
SweepNoiseEstimate estimateSweepNoise(const SweepResult& sweep);

/// The noise the default tolerances are made for: they hold with the
/// UTM-30LX's 1 cm on the tilting rig, whose lines are offset from each other
/// by a few centimetres, and 6 sigma of a 5 mm noise is their 3 cm [m].
constexpr double kDefaultToleranceNoise = 0.005;

/// Scales every distance tolerance of the split (d_min, zeta) and of the
/// grouping (dist_*, centroid_*) by k = sigma / kDefaultToleranceNoise,
/// within [0.2, 1]: a cloud less noisy than 5 mm is judged by its own noise,
/// a noisier one by the defaults. The split must also hold a line's own bend
/// between its points (a row of equal elevation crosses a plane along a
/// curve, not a line): its zeta stays at least half the angle between
/// neighbouring beams (its threshold half their spacing), the grouping's
/// growth with range (dist_ratio) no less than that zeta (a segment's points
/// lie up to zeta x range off its chord), and no tolerance falls under a
/// fifth of its default (6 mm). Without these two, noise-free
/// range images of the simulator's scenes lost faces (scripts/bench/noise_table.sh;
/// doc/other_rigs.md). sigma <= 0: unchanged. Returns k.
double scaleTolerancesToNoise(const CloudNoise& noise, SplitParams& split, GroupingParams& grouping);

}  // namespace core
}  // namespace tilt_laser_perception
