// Scan line grouping against PCL's OrganizedMultiPlaneSegmentation (with
// integral-image normals) on the same assembled sweep clouds of a scene,
// judged by the same Hoover criteria against the simulator's truth.
//   compare_pcl [--scene stairs] [--sweeps 6] [--seed 1] [--speed 1.0]
// Prints one summary line per method (evaluate's key=value format) and the
// time each takes per sweep. Built only where PCL is installed (libpcl-dev).
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <pcl/features/integral_image_normal.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/organized_multi_plane_segmentation.h>

#include "tilt_laser_perception/sim/scene_eval.hpp"

namespace tlp = tilt_laser_perception;

namespace {
// PCL's settings: those of its organized segmentation example, with the
// thresholds of our own grouping where they mean the same thing.
struct PclSettings {
  float max_depth_change = 0.03f;     // normal estimation: depth discontinuity [m]
  float smoothing = 5.0f;             // normal estimation: window [pixels]
  unsigned min_inliers = 100;         // smallest plane [points]
  double angular_deg = 3.0;           // normals within this of the plane's
  double distance = 0.03;             // points within this of the plane [m]
};

// PCL's organized methods take z as the depth (a camera's frame): the sweep's
// points go to a frame at the tilt axis with z forward, x right, y down.
Eigen::Vector3f toCamera(const Eigen::Vector3f& p, const Eigen::Vector3f& head) {
  const Eigen::Vector3f d = p - head;
  return Eigen::Vector3f(-d.y(), -d.z(), d.x());
}
Eigen::Vector3d fromCamera(const Eigen::Vector3d& v) { return Eigen::Vector3d(v.z(), -v.x(), -v.y()); }

void pclSegment(const PclSettings& ps, const Eigen::Vector3f& head, const tlp::core::SweepResult& sw,
                std::vector<std::vector<int>>& labels, std::vector<tlp::core::Plane>& planes) {
  const std::size_t rows = sw.lines.size(), cols = rows ? sw.lines[0].points.size() : 0;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->width = static_cast<std::uint32_t>(cols);
  cloud->height = static_cast<std::uint32_t>(rows);
  cloud->is_dense = false;
  cloud->points.resize(rows * cols);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < cols && c < sw.lines[r].points.size(); ++c) {
      const Eigen::Vector3f p = toCamera(sw.lines[r].points[c], head);
      cloud->points[r * cols + c] = pcl::PointXYZ(p.x(), p.y(), p.z());  // NaN where no return
    }
  pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
  pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setNormalEstimationMethod(ne.COVARIANCE_MATRIX);
  ne.setMaxDepthChangeFactor(ps.max_depth_change);
  ne.setNormalSmoothingSize(ps.smoothing);
  ne.setInputCloud(cloud);
  ne.compute(*normals);
  pcl::OrganizedMultiPlaneSegmentation<pcl::PointXYZ, pcl::Normal, pcl::Label> mps;
  mps.setMinInliers(ps.min_inliers);
  mps.setAngularThreshold(ps.angular_deg * M_PI / 180.0);
  mps.setDistanceThreshold(ps.distance);
  mps.setInputNormals(normals);
  mps.setInputCloud(cloud);
  std::vector<pcl::ModelCoefficients> coefficients;
  std::vector<pcl::PointIndices> inliers;
  mps.segment(coefficients, inliers);
  for (std::size_t k = 0; k < inliers.size(); ++k) {
    tlp::core::Plane pl;
    pl.id = static_cast<int>(k);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int idx : inliers[k].indices) {
      const pcl::PointXYZ& p = cloud->points[idx];
      sum += Eigen::Vector3d(p.x, p.y, p.z);
      labels[idx / cols][idx % cols] = static_cast<int>(k);
    }
    const auto& v = coefficients[k].values;
    pl.fit.normal = fromCamera(Eigen::Vector3d(v[0], v[1], v[2]).normalized());
    pl.fit.centroid = fromCamera(sum / std::max<std::size_t>(1, inliers[k].indices.size())) + head.cast<double>();
    planes.push_back(pl);
    if (std::getenv("COMPARE_PCL_DEBUG"))
      std::fprintf(stderr, "pcl plane %zu: %zu points, normal %.2f %.2f %.2f, centroid %.2f %.2f %.2f\n", k,
                   inliers[k].indices.size(), pl.fit.normal.x(), pl.fit.normal.y(), pl.fit.normal.z(),
                   pl.fit.centroid.x(), pl.fit.centroid.y(), pl.fit.centroid.z());
  }
}
}  // namespace

int main(int argc, char** argv) {
  tlp::sim::SceneEvalOptions o;
  o.sweeps = 6;
  PclSettings ps;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--scene") o.scene = argv[i + 1];
    else if (a == "--pcl-depth-change") ps.max_depth_change = std::atof(argv[i + 1]);
    else if (a == "--pcl-smoothing") ps.smoothing = std::atof(argv[i + 1]);
    else if (a == "--pcl-min-inliers") ps.min_inliers = std::atoi(argv[i + 1]);
    else if (a == "--pcl-angle") ps.angular_deg = std::atof(argv[i + 1]);
    else if (a == "--pcl-distance") ps.distance = std::atof(argv[i + 1]);
    else if (a == "--sweeps") o.sweeps = std::atoi(argv[i + 1]);
    else if (a == "--seed") o.seed = std::strtoull(argv[i + 1], nullptr, 10);
    else if (a == "--speed") o.profile.speed = std::atof(argv[i + 1]);
    else {
      std::fprintf(stderr, "usage: compare_pcl [--scene NAME] [--sweeps N] [--seed S] [--speed RAD_PER_S] [--pcl-depth-change F]\n"
                           "                   [--pcl-smoothing PX] [--pcl-min-inliers N] [--pcl-angle DEG] [--pcl-distance M]\n");
      return 2;
    }
  }
  const auto ours = tlp::sim::evaluateScene(o);
  const Eigen::Vector3f head =
      tlp::sim::HeadGeometry::load(tlp::sim::configDirectory() + "/head.yaml").axis_origin.cast<float>();
  o.segmenter = [&](const tlp::core::SweepResult& sw, std::vector<std::vector<int>>& labels,
                    std::vector<tlp::core::Plane>& planes) { pclSegment(ps, head, sw, labels, planes); };
  const auto pcl = tlp::sim::evaluateScene(o);
  // its Hoover figures only (the rest of the line is still our pipeline's)
  std::string pcl_line = tlp::sim::evalSummary(pcl);
  pcl_line = pcl_line.substr(0, pcl_line.find(" edge_precision"));
  double pcl_planes = 0.0;
  for (const auto& e : pcl) pcl_planes += static_cast<double>(e.planes) / pcl.size();
  double pcl_ms = 0.0, our_ms = 0.0;
  for (const auto& e : pcl) pcl_ms += e.external_ms / pcl.size();
  for (const auto& e : ours) our_ms += (e.split_ms + e.group_ms) / ours.size();
  std::printf("scene %s, %d sweeps (1081 beams x %d lines)\n", o.scene.c_str(), o.sweeps, ours.empty() ? 0 : ours[0].lines);
  std::printf("scan line grouping:   %s\n", tlp::sim::evalSummary(ours).c_str());
  std::printf("  split + grouping per sweep: %.2f ms\n", our_ms);
  std::printf("PCL OrganizedMultiPlaneSegmentation (integral-image normals: depth change %.3f, smoothing %.0f px; "
              "min %u inliers, %.1f deg, %.3f m): %s\n", ps.max_depth_change, ps.smoothing, ps.min_inliers,
              ps.angular_deg, ps.distance, pcl_line.c_str());
  std::printf("  normals + segmentation per sweep: %.2f ms, %.1f planes per sweep\n", pcl_ms, pcl_planes);
  return 0;
}
