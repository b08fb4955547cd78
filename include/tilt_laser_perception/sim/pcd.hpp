/**
 * @file pcd.hpp
 * @brief Reading and writing organized point clouds in the PCD format (x y z
 *        fields, ASCII or binary data). ROS-free and PCL-free.
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace tilt_laser_perception {
namespace sim {

struct OrganizedCloud {
  int width = 0, height = 0;              ///< columns and rows
  std::vector<Eigen::Vector3f> points;    ///< row-major; NaN where there is no point
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
};

/// Reads x, y and z of a PCD file (other fields skipped); throws std::runtime_error.
OrganizedCloud readPcd(const std::string& path);
/// Writes x y z label (binary).
void writeLabeledPcd(const std::string& path, const OrganizedCloud& cloud, const std::vector<std::uint32_t>& labels);

}  // namespace sim
}  // namespace tilt_laser_perception
