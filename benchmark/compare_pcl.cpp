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
// and prints their ratio (segment_cloud with one thread and with two), the
// stages timed apart, and both methods' Hoover
// figures against the image's faces. segment_cloud groups rows no closer
// than --line-spacing-deg (its default; 0: every row).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <pcl/features/integral_image_normal.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/organized_multi_plane_segmentation.h>

#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/sim/evaluation.hpp"
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

int organized(const std::string& scene_name, int n, std::uint64_t seed, const PclSettings& ps, double spacing_deg) {
  const tlp::sim::Scene scene = tlp::sim::loadScene(scene_name);
  const Eigen::Vector3d head = tlp::sim::HeadGeometry::load(tlp::sim::configDirectory() + "/head.yaml").axis_origin;
  // 1 cm range noise: the UTM-30LX's within 10 m.
  std::vector<int> faces;
  const std::vector<Eigen::Vector3f> pts = tlp::sim::rangeImage(scene, head, n, 0.01, seed, &faces);
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
  std::vector<double> ours_s, ours2_s, pcl_s, split_s, add_s, finish_s, between_s, split2_s, add2_s, finish2_s,
      between2_s;
  std::vector<std::uint32_t> labels, labels2, pcl_labels(pts.size(), 0);
  bool same = true;
  std::size_t our_planes = 0, pcl_planes = 0;
  int step = 1;
  for (int run = 0; run < 7; ++run) {
    std::vector<tlp::core::Plane> planes;
    tlp::core::OrganizedTimes times;
    // As segment_cloud runs it: the lines grouped chosen from the cloud, then the split and grouping.
    const auto t0 = now();
    step = tlp::core::organizedLineStep(pts, n, n, true, head, spacing_deg * M_PI / 180.0);
    tlp::core::segmentOrganized(pts, n, n, true, head, tlp::core::SplitParams(), tlp::core::GroupingParams(), planes,
                                labels, step, &times);
    ours_s.push_back(secs(t0, now()));
    split_s.push_back(times.split);
    add_s.push_back(times.add);
    finish_s.push_back(times.finish);
    between_s.push_back(times.between);
    our_planes = planes.size();
    // Again with segment_cloud's second thread (its default on two cores or more).
    std::vector<tlp::core::Plane> planes2;
    const auto t2 = now();
    const int step2 = tlp::core::organizedLineStep(pts, n, n, true, head, spacing_deg * M_PI / 180.0);
    tlp::core::segmentOrganized(pts, n, n, true, head, tlp::core::SplitParams(), tlp::core::GroupingParams(), planes2,
                                labels2, step2, &times, 2);
    ours2_s.push_back(secs(t2, now()));
    split2_s.push_back(times.split);
    add2_s.push_back(times.add);
    finish2_s.push_back(times.finish);
    between2_s.push_back(times.between);
    same = same && labels2 == labels && planes2.size() == planes.size();
    std::vector<pcl::ModelCoefficients> coefficients;
    std::vector<pcl::PointIndices> inliers;
    const auto t1 = now();
    pclPlanes(ps, cloud, coefficients, inliers);
    pcl_s.push_back(secs(t1, now()));
    pcl_planes = inliers.size();
    std::fill(pcl_labels.begin(), pcl_labels.end(), 0);
    for (std::size_t k = 0; k < inliers.size(); ++k)
      for (int idx : inliers[k].indices) pcl_labels[idx] = static_cast<std::uint32_t>(k + 1);
  }
  std::size_t valid = 0;
  for (const auto& p : pts) valid += p.allFinite();
  // Both judged against the image's faces as segment_cloud --truth-field judges (80 %, faces of 100 points or more).
  std::map<int, int> face_points;
  for (int f : faces) ++face_points[f];
  const auto judge = [&](const std::vector<std::uint32_t>& l) {
    std::size_t in_planes = 0;
    for (auto v : l) in_planes += v != 0;
    const tlp::sim::HooverScore h = tlp::sim::hooverScore(tlp::sim::RegionOverlap::ofPlaneLabels(faces, l, pts), 0.8,
                                                          [&](int f) { return face_points[f] >= 100; });
    char buf[160];
    std::snprintf(buf, sizeof buf, "%zu points in planes; of %d faces correct=%d over=%d under=%d missed=%d noise=%d",
                  in_planes, h.expected, h.correct, h.over, h.under, h.missed, h.noise);
    return std::string(buf);
  };
  const double ours = medianMs(ours_s), ours2 = medianMs(ours2_s), theirs = medianMs(pcl_s);
  std::printf("scene %s, a %d x %d range image from the head (%zu returns), medians of 7 runs\n", scene_name.c_str(), n,
              n, valid);
  std::printf("segment_cloud (split + grouping, every %d. row grouped: --line-spacing-deg %.2f), one thread: %.2f ms, "
              "%zu planes, %s\n  timed apart: the split %.2f ms, adding the rows %.2f ms, finish %.2f ms, the rows "
              "between %.2f ms\n",
              step, spacing_deg, ours, our_planes, judge(labels).c_str(), medianMs(split_s), medianMs(add_s),
              medianMs(finish_s), medianMs(between_s));
  std::printf("segment_cloud, two threads (--threads 2, its default on two cores or more): %.2f ms, the same planes and "
              "labels: %s\n  timed apart: the split (second thread) %.2f ms, adding the rows (first, at the same "
              "time) %.2f ms, finish %.2f ms, the rows between (both) %.2f ms\n",
              ours2, same ? "yes" : "NO", medianMs(split2_s), medianMs(add2_s), medianMs(finish2_s),
              medianMs(between2_s));
  std::printf("PCL (integral-image normals + OrganizedMultiPlaneSegmentation): %.2f ms, %zu planes, %s\n", theirs,
              pcl_planes, judge(pcl_labels).c_str());
  std::printf("ratio=%.3f (1/%.1f) one thread; ratio2=%.3f (1/%.1f) two threads (PCL: one)\n", ours / theirs,
              theirs / ours, ours2 / theirs, theirs / ours2);
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  tlp::sim::SceneEvalOptions o;
  o.sweeps = 6;
  PclSettings ps;
  int organized_n = 0;
  double spacing_deg = tlp::core::kOrganizedLineSpacing * 180.0 / M_PI;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--scene") o.scene = argv[i + 1];
    else if (a == "--organized") organized_n = std::atoi(argv[i + 1]);
    else if (a == "--line-spacing-deg") spacing_deg = std::atof(argv[i + 1]);
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
                           "       compare_pcl --organized N [--scene NAME] [--seed S] [--line-spacing-deg D] [--pcl-...]\n");
      return 2;
    }
  }
  if (organized_n >= 2) return organized(o.scene, organized_n, o.seed, ps, spacing_deg);
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
