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

namespace tilt_laser_perception {
namespace core {

/// Splits one line of 3D points (NaN: no return) seen from `origin` into
/// straight segments: breaks at invalid points and depth jumps, then the
/// farthest-point split against d_T = max(d_min, zeta * R) (SplitParams, the
/// same as for 2D scans), keeping pieces of at least min_points points.
/// Appends Segment3 with `line` set to `line`.
void splitPolyline(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin,
                   const SplitParams& params, int line, std::vector<Segment3>& out);

}  // namespace core
}  // namespace tilt_laser_perception

namespace tilt_laser_perception {
namespace core {

/// Split and scan line grouping of an organized cloud (row-major, width x
/// height) whose rows (or columns) are scan lines seen from `origin`. Fills
/// the planes and a label per point (0: no plane, else plane id + 1).
void segmentOrganized(const std::vector<Eigen::Vector3f>& points, int width, int height, bool lines_are_rows,
                      const Eigen::Vector3d& origin, const SplitParams& split, const GroupingParams& grouping,
                      std::vector<Plane>& planes, std::vector<std::uint32_t>& labels);

}  // namespace core
}  // namespace tilt_laser_perception
