/**
 * @file pcd.hpp
 * @brief Organized point clouds from and to PCD files, through PCL's own
 *        reader and writer (pcl::io: ascii, binary and binary_compressed
 *        data; fields in any order, of any type; extra fields ignored).
 *        ROS-free; the only part of the package that links PCL's io.
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace tilt_laser_perception {
namespace io {

struct OrganizedCloud {
  int width = 0, height = 0;              ///< columns and rows
  std::vector<Eigen::Vector3f> points;    ///< row-major; NaN where there is no point
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();  ///< the file's VIEWPOINT (sensor origin)
  /// The truth field asked for, one label per point rounded to an integer;
  /// -1 where it is not finite or equals the "no label" value. Empty when none was asked for.
  std::vector<int> truth;
};

/// How a truth field is read.
struct TruthField {
  std::string name;          ///< empty: none
  bool has_none = false;     ///< a value that means "in no plane"
  double none = 0.0;
};

/// Reads x, y and z (any float or integer type) and, when asked, a truth
/// field; throws std::runtime_error naming the file and what is wrong.
OrganizedCloud readPcd(const std::string& path, const TruthField& truth = TruthField());

/// Writes x y z label (PointXYZL; binary_compressed, or ascii for scripts
/// to read), width, height and the viewpoint kept: a cloud PCL's tools read
/// as they read their own.
void writeLabeledPcd(const std::string& path, const OrganizedCloud& cloud, const std::vector<std::uint32_t>& labels,
                     bool ascii = false);

}  // namespace io
}  // namespace tilt_laser_perception
