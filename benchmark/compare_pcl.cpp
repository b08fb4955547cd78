// Scan line grouping against PCL's OrganizedMultiPlaneSegmentation (with
// integral-image normals) on the same assembled sweep clouds of a scene,
// judged by the same Hoover criteria against the simulator's truth.
//   compare_pcl [--scene stairs] [--sweeps 6] [--seed 1] [--speed 1.0]
// Prints one summary line per method (evaluate's key=value format) and the
// time each takes per sweep. Built only where PCL is installed (libpcl-dev).
//   compare_pcl --organized N [--scene stairs] [--seed 1]
// Times segment_cloud's split and grouping (core::segmentOrganized) and PCL's
// normals and segmentation on one N x N organized cloud of the scene (a range
// image from the head, rows of equal elevation), the median of 7 runs each,
// and prints their ratio, and the split, the adding of rows and the finish
// timed apart.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include <pcl/features/integral_image_normal.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/organized_multi_plane_segmentation.h>

#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/sim/head.hpp"
#include "tilt_laser_perception/sim/lidar_sim.hpp"
#include "tilt_laser_perception/sim/scene.hpp"
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

/// PCL's normals and segmentation of an organized cloud (camera frame).
void pclPlanes(const PclSettings& ps, const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud,
               std::vector<pcl::ModelCoefficients>& coefficients, std::vector<pcl::PointIndices>& inliers) {
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
  mps.segment(coefficients, inliers);
}

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
  std::vector<pcl::ModelCoefficients> coefficients;
  std::vector<pcl::PointIndices> inliers;
  pclPlanes(ps, cloud, coefficients, inliers);
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

double medianMs(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : 1e3 * v[v.size() / 2];
}

int organized(const std::string& scene_name, int n, std::uint64_t seed, const PclSettings& ps) {
  const tlp::sim::Scene scene = tlp::sim::loadScene(scene_name);
  const Eigen::Vector3d head = tlp::sim::HeadGeometry::load(tlp::sim::configDirectory() + "/head.yaml").axis_origin;
  // 1 cm range noise: the UTM-30LX's within 10 m.
  const std::vector<Eigen::Vector3f> pts = tlp::sim::rangeImage(scene, head, n, 0.01, seed);
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->width = cloud->height = static_cast<std::uint32_t>(n);
  cloud->is_dense = false;
  cloud->points.resize(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3f p = toCamera(pts[i], head.cast<float>());
    cloud->points[i] = pcl::PointXYZ(p.x(), p.y(), p.z());
  }
  const auto now = [] { return std::chrono::steady_clock::now(); };
  const auto secs = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::vector<double> ours_s, pcl_s, split_s, add_s, finish_s;
  std::size_t our_planes = 0, pcl_planes = 0, our_pts = 0, pcl_pts = 0;
  for (int run = 0; run < 7; ++run) {
    std::vector<tlp::core::Plane> planes;
    std::vector<std::uint32_t> labels;
    const auto t0 = now();
    tlp::core::segmentOrganized(pts, n, n, true, head, tlp::core::SplitParams(), tlp::core::GroupingParams(), planes,
                                labels);
    ours_s.push_back(secs(t0, now()));
    our_planes = planes.size();
    our_pts = static_cast<std::size_t>(std::count_if(labels.begin(), labels.end(), [](std::uint32_t l) { return l; }));
    std::vector<pcl::ModelCoefficients> coefficients;
    std::vector<pcl::PointIndices> inliers;
    const auto t1 = now();
    pclPlanes(ps, cloud, coefficients, inliers);
    pcl_s.push_back(secs(t1, now()));
    pcl_planes = inliers.size();
    pcl_pts = 0;
    for (const auto& in : inliers) pcl_pts += in.indices.size();
    // Its stages timed apart, row by row as segmentOrganized runs them: the
    // split, the grouping as the rows come (addLine), and its finish.
    tlp::core::ScanLineGrouper g{tlp::core::GroupingParams()};
    g.reset(head);
    std::vector<std::vector<Eigen::Vector3f>> rows(static_cast<std::size_t>(n));
    std::vector<tlp::core::Segment3> segs;
    double split = 0.0, add = 0.0;
    for (int r = 0; r < n; ++r) {
      rows[r].assign(pts.begin() + static_cast<std::ptrdiff_t>(r) * n, pts.begin() + static_cast<std::ptrdiff_t>(r + 1) * n);
      segs.clear();
      const auto t2 = now();
      tlp::core::splitPolyline(rows[r], head, tlp::core::SplitParams(), r, segs);
      const auto t3 = now();
      g.addLine(segs);
      split += secs(t2, t3);
      add += secs(t3, now());
    }
    std::vector<tlp::core::Plane> staged;
    const auto t4 = now();
    g.finish(staged, [&](int line) { return &rows[line]; });
    finish_s.push_back(secs(t4, now()));
    split_s.push_back(split);
    add_s.push_back(add);
  }
  std::size_t valid = 0;
  for (const auto& p : pts) valid += p.allFinite();
  const double ours = medianMs(ours_s), theirs = medianMs(pcl_s);
  std::printf("scene %s, a %d x %d range image from the head (%zu returns), medians of 7 runs\n", scene_name.c_str(), n,
              n, valid);
  std::printf("segment_cloud (split + grouping): %.2f ms, %zu planes, %zu points in planes (timed apart: the split "
              "%.2f ms, adding the rows %.2f ms, finish %.2f ms)\n",
              ours, our_planes, our_pts, medianMs(split_s), medianMs(add_s), medianMs(finish_s));
  std::printf("PCL (integral-image normals + OrganizedMultiPlaneSegmentation): %.2f ms, %zu planes, %zu points in planes\n",
              theirs, pcl_planes, pcl_pts);
  std::printf("ratio=%.3f (1/%.1f)\n", ours / theirs, theirs / ours);
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  tlp::sim::SceneEvalOptions o;
  o.sweeps = 6;
  PclSettings ps;
  int organized_n = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--scene") o.scene = argv[i + 1];
    else if (a == "--organized") organized_n = std::atoi(argv[i + 1]);
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
                           "                   [--pcl-smoothing PX] [--pcl-min-inliers N] [--pcl-angle DEG] [--pcl-distance M]\n"
                           "       compare_pcl --organized N [--scene NAME] [--seed S] [--pcl-...]\n");
      return 2;
    }
  }
  if (organized_n >= 2) return organized(o.scene, organized_n, o.seed, ps);
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
