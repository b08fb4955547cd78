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

/// Reads a 3DTK scan (`scanNNN.3d`: ascii, a point a line, x y z in
/// centimetres in 3DTK's left-handed frame, x right, y up, z forward; a point
/// at the origin or beyond 3,276 cm is no return) as an organized cloud in a
/// right-handed frame, x forward, y left, z up, in metres: a row a scan line.
/// A line ends where the beam's angle in the x-z plane falls back; lines of
/// fewer points are padded with NaN. The pose file beside it (`scanNNN.pose`:
/// the position in cm, then the angles), when there, gives the viewpoint;
/// the points stay as the file has them. Throws std::runtime_error naming the
/// file and what is wrong.
OrganizedCloud read3dtk(const std::string& path);

/// Reads `path` by its name: a 3DTK scan for `.3d`, else a PCD file.
OrganizedCloud readCloud(const std::string& path, const TruthField& truth = TruthField());

/// The same cloud with its scan lines in the other order (rows, or columns
/// when `rows` is false): the truth labels move with their points.
OrganizedCloud reversedLines(const OrganizedCloud& c, bool rows);

}  // namespace io
}  // namespace tilt_laser_perception
