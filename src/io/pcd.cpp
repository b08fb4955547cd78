#include "tilt_laser_perception/io/pcd.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

namespace tilt_laser_perception {
namespace io {

namespace {
// The value of one field of one point, whatever its PCL datatype.
double fieldValue(const pcl::PCLPointCloud2& c, const pcl::PCLPointField& f, std::size_t point) {
  const std::uint8_t* p = c.data.data() + point * c.point_step + f.offset;
  const auto get = [p](auto v) {
    std::memcpy(&v, p, sizeof(v));
    return static_cast<double>(v);
  };
  switch (f.datatype) {
    case pcl::PCLPointField::INT8: return get(std::int8_t());
    case pcl::PCLPointField::UINT8: return get(std::uint8_t());
    case pcl::PCLPointField::INT16: return get(std::int16_t());
    case pcl::PCLPointField::UINT16: return get(std::uint16_t());
    case pcl::PCLPointField::INT32: return get(std::int32_t());
    case pcl::PCLPointField::UINT32: return get(std::uint32_t());
    case pcl::PCLPointField::FLOAT32: return get(float());
    case pcl::PCLPointField::FLOAT64: return get(double());
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

const pcl::PCLPointField& field(const pcl::PCLPointCloud2& c, const std::string& name, const std::string& path) {
  for (const auto& f : c.fields)
    if (f.name == name) return f;
  std::string have;
  for (const auto& f : c.fields) have += (have.empty() ? "" : " ") + f.name;
  throw std::runtime_error(path + ": no field '" + name + "' (fields: " + have + ")");
}
}  // namespace

OrganizedCloud readPcd(const std::string& path, const TruthField& truth) {
  pcl::PCLPointCloud2 c;
  Eigen::Vector4f origin = Eigen::Vector4f::Zero();
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
  pcl::PCDReader reader;
  int version = 0, data_type = 0;
  unsigned int data_index = 0;
  // PCL's read() crashes on a header without fields or points (a file that
  // is no PCD at all): its header is checked first.
  if (reader.readHeader(path, c, origin, orientation, version, data_type, data_index) < 0 || c.fields.empty() ||
      c.width == 0 || c.height == 0 || c.point_step == 0)
    throw std::runtime_error("cannot read " + path + " as PCD (no valid header)");
  if (reader.read(path, c, origin, orientation, version) < 0) throw std::runtime_error("cannot read " + path + " as PCD");
  OrganizedCloud out;
  out.width = static_cast<int>(c.width);
  out.height = static_cast<int>(c.height);
  out.viewpoint = origin.head<3>().cast<double>();
  const std::size_t n = static_cast<std::size_t>(c.width) * c.height;
  if (c.data.size() < n * c.point_step) throw std::runtime_error(path + ": fewer data than WIDTH x HEIGHT points");
  const pcl::PCLPointField &fx = field(c, "x", path), &fy = field(c, "y", path), &fz = field(c, "z", path);
  out.points.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    out.points[i] = Eigen::Vector3d(fieldValue(c, fx, i), fieldValue(c, fy, i), fieldValue(c, fz, i)).cast<float>();
  if (!truth.name.empty()) {
    const pcl::PCLPointField& ft = field(c, truth.name, path);
    out.truth.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double v = fieldValue(c, ft, i);
      const bool none = !std::isfinite(v) || (truth.has_none && v == truth.none) ||
                        std::abs(v) > static_cast<double>(std::numeric_limits<int>::max());
      out.truth[i] = none ? -1 : static_cast<int>(std::lround(v));
    }
  }
  return out;
}

void writeLabeledPcd(const std::string& path, const OrganizedCloud& c, const std::vector<std::uint32_t>& labels,
                     bool ascii) {
  pcl::PointCloud<pcl::PointXYZL> cloud;
  cloud.width = static_cast<std::uint32_t>(c.width);
  cloud.height = static_cast<std::uint32_t>(c.height);
  cloud.is_dense = false;
  cloud.points.resize(c.points.size());
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    pcl::PointXYZL& p = cloud.points[i];
    p.x = c.points[i].x();
    p.y = c.points[i].y();
    p.z = c.points[i].z();
    p.label = i < labels.size() ? labels[i] : 0;
  }
  cloud.sensor_origin_ = Eigen::Vector4f(static_cast<float>(c.viewpoint.x()), static_cast<float>(c.viewpoint.y()),
                                         static_cast<float>(c.viewpoint.z()), 0.0f);
  if ((ascii ? pcl::io::savePCDFileASCII(path, cloud) : pcl::io::savePCDFileBinaryCompressed(path, cloud)) < 0) throw std::runtime_error("cannot write " + path);
}

}  // namespace io
}  // namespace tilt_laser_perception
