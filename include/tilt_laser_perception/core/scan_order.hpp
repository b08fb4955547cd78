/**
 * @file scan_order.hpp
 * @brief A spinning 2D lidar's flat cloud, its points in the order measured,
 *        back into its scan lines: an organized cloud (a row a line, a
 *        column a beam angle). ROS-free; [m], [rad].
 *
 * A rig that spins its laser about an axis through the laser, the scan
 * plane containing the axis (the MultiSense SL's UTM-30LX), saves each sweep
 * as one flat list: line after line, each line's beams in the order scanned,
 * points with no return left out. Each point's beam angle is its direction
 * within its line's plane, measured from the spin axis (signed: which side
 * of the axis). Within a line it grows beam by beam; where it falls back, a
 * new line begins.
 */
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace tilt_laser_perception {
namespace core {

struct ScanLines {
  int width = 0, height = 0;            ///< beams (columns) and lines (rows)
  std::vector<Eigen::Vector3f> points;  ///< row-major, NaN where a beam has no point
  double beam_step = 0.0;               ///< the angle between neighbouring beams, from the data [rad]
  double beam_min = 0.0;                ///< column 0's beam angle [rad]
  int collided = 0;                     ///< points left out: a second point on a line's beam
  int dropped = 0;                      ///< points left out: not finite
};

/// Where a spinning laser is and the axis it spins about, found from its
/// flat cloud alone: each line lies in a plane through the laser containing
/// the axis, so the planes of stretches of points that are planar but not
/// straight (a line over a crease or a block) all contain the axis; along
/// the axis, the laser is where its beams lie evenly apart.
struct SpinGeometry {
  bool ok = false;
  std::string why;                                   ///< when not ok: what the cloud lacks
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< on the axis [m]
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();   ///< unit, towards the points
  int stretches = 0;         ///< planar, not straight stretches of points used
  double plane_rms = 0.0;    ///< their planes' distance from the axis line [m]
  double beam_step = 0.0;    ///< the beams' spacing seen from `origin` [rad]
  double step_spread = 0.0;  ///< its interquartile range, relative: how evenly they lie
};

/// Estimates what `points` (in the order measured) leave unknown: the axis
/// when `axis` is zero or not finite, the origin when `origin` is not finite.
SpinGeometry estimateSpinGeometry(const std::vector<Eigen::Vector3f>& points,
                                  const Eigen::Vector3d& origin = Eigen::Vector3d::Constant(std::nan("")),
                                  const Eigen::Vector3d& axis = Eigen::Vector3d::Zero());

/// Rebuilds the lines of `points` (in the order measured), seen from
/// `origin`, the laser spinning about `axis` (any length but zero). Empty
/// (width 0) when fewer than two lines or no beam step can be found.
ScanLines rebuildScanLines(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin,
                           const Eigen::Vector3d& axis);

}  // namespace core
}  // namespace tilt_laser_perception
