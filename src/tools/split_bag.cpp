// Runs the split over every LaserScan in a bag and prints counts and the
// split time per scan. Works on any recording (urg_node's: 721 or 1081 beams).
#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <vector>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>

#include "tilt_laser_perception/ros/conversions.hpp"

using namespace tilt_laser_perception;

// Points, segments and edge points of one scan, for plotting.
static bool dumpScan(const std::string& path, const core::ScanView& scan, const core::SplitResult& r) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "split_bag: cannot write %s\n", path.c_str());
    return false;
  }
  std::fprintf(f, "type,index,kind,x0,y0,x1,y1\n");
  for (std::size_t i = 0; i < scan.size; ++i) {
    const double rg = scan.ranges[i], a = scan.angle_min + i * scan.angle_increment;
    if (std::isfinite(rg) && rg >= scan.range_min && rg <= scan.range_max)
      std::fprintf(f, "point,%zu,,%.4f,%.4f,,\n", i, rg * std::cos(a), rg * std::sin(a));
  }
  for (const auto& s : r.segments)
    std::fprintf(f, "segment,%d,%d,%.4f,%.4f,%.4f,%.4f\n", s.first, s.last, s.start.x(), s.start.y(), s.end.x(),
                 s.end.y());
  for (const auto& e : r.edges)
    std::fprintf(f, "edge,%d,%s,%.4f,%.4f,,\n", e.index, core::edgeKindName(e.kind), e.point.x(), e.point.y());
  std::fclose(f);
  return true;
}

static void usage() {
  std::fprintf(stderr,
               "usage: split_bag BAG [--topic T] [--zeta Z] [--dmin D] [--fixed D] [--veil-angle A] [--dump-scan K CSV]\n"
               "  --topic T  LaserScan topic (default: every LaserScan topic in the bag)\n"
               "  --zeta Z   adaptive factor (default 0.01)\n"
               "  --dmin D   adaptive threshold floor [m] (default 0.03)\n"
               "  --fixed D  fixed threshold d_T = D [m] instead of the adaptive one\n"
               "  --veil-angle A  mixed-pixel test angle [deg] (default 15; 0: off)\n"
               "  --dump-scan K CSV  write the points, segments and edge points of scan K (0-based) to CSV\n");
}

int main(int argc, char** argv) {
  std::string bag_path, topic, dump_path;
  long dump_index = -1;
  core::SplitParams params;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    if (a == "--topic" && v) topic = argv[++i];
    else if (a == "--zeta" && v) params.zeta = std::atof(argv[++i]);
    else if (a == "--dmin" && v) params.d_min = std::atof(argv[++i]);
    else if (a == "--fixed" && v) { params.mode = core::SplitMode::Fixed; params.d_min = std::atof(argv[++i]); }
    else if (a == "--veil-angle" && v) params.veil_angle_deg = std::atof(argv[++i]);
    else if (a == "--dump-scan" && i + 2 < argc) { dump_index = std::atol(argv[++i]); dump_path = argv[++i]; }
    else if (a == "-h" || a == "--help") { usage(); return 0; }
    else if (a[0] != '-' && bag_path.empty()) bag_path = a;
    else { usage(); return 2; }
  }
  if (bag_path.empty()) { usage(); return 2; }
  const std::string problem = params.validate();
  if (!problem.empty()) { std::fprintf(stderr, "split_bag: %s\n", problem.c_str()); return 2; }

  rosbag::Bag bag;
  try {
    bag.open(bag_path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    std::fprintf(stderr, "split_bag: cannot open %s: %s\n", bag_path.c_str(), e.what());
    return 1;
  }
  std::unique_ptr<rosbag::View> view;
  if (topic.empty()) view = std::make_unique<rosbag::View>(bag, rosbag::TypeQuery("sensor_msgs/LaserScan"));
  else view = std::make_unique<rosbag::View>(bag, rosbag::TopicQuery(topic));

  core::ScanSplitter splitter(params);
  core::SplitResult result;
  std::vector<double> times_us;
  std::set<std::string> topics;
  std::set<std::size_t> sizes;
  unsigned long scans = 0, dropped = 0, segments = 0, edges = 0, veil_points = 0, toward_beam = 0, overhanging = 0;
  double worst_overhang = 0.0;
  for (const rosbag::MessageInstance& m : *view) {
    const sensor_msgs::LaserScanConstPtr scan = m.instantiate<sensor_msgs::LaserScan>();
    if (!scan) continue;
    topics.insert(m.getTopic());
    const core::ScanView sv = toScanView(*scan);
    const auto t0 = std::chrono::steady_clock::now();
    const core::ScanError err = splitter.split(sv, result);
    const auto t1 = std::chrono::steady_clock::now();
    ++scans;
    if (err != core::ScanError::None) {
      ++dropped;
      if (dropped <= 5) std::fprintf(stderr, "split_bag: scan %lu dropped: %s\n", scans, core::scanErrorName(err));
      continue;
    }
    sizes.insert(scan->ranges.size());
    if (static_cast<long>(scans) - 1 == dump_index && !dumpScan(dump_path, sv, result)) return 1;
    times_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    segments += result.segments.size();
    edges += result.edges.size();
    veil_points += result.veil_points;
    for (const auto& s : result.segments) {
      toward_beam += core::segmentBeamAngle(s) < 15.0 * M_PI / 180.0;
      const double over = core::segmentOverhang(sv, s);
      overhanging += over > 0.01;
      worst_overhang = std::max(worst_overhang, over);
    }
  }
  if (scans == 0) {
    std::fprintf(stderr, "split_bag: no LaserScan messages%s%s in %s\n", topic.empty() ? "" : " on ",
                 topic.c_str(), bag_path.c_str());
    return 1;
  }
  std::string topic_list, size_list;
  for (const auto& t : topics) topic_list += (topic_list.empty() ? "" : ", ") + t;
  for (const auto s : sizes) size_list += (size_list.empty() ? "" : ", ") + std::to_string(s);
  const unsigned long good = scans - dropped;
  std::printf("bag: %s\n", bag_path.c_str());
  std::printf("topics: %s\n", topic_list.c_str());
  std::printf("split: %s, zeta %.4f, d_min %.3f m\n", params.mode == core::SplitMode::Fixed ? "fixed" : "adaptive",
              params.zeta, params.d_min);
  std::printf("scans: %lu (beams per scan: %s; dropped as malformed: %lu)\n", scans, size_list.c_str(), dropped);
  std::printf("segments: %lu (%.1f per scan)\n", segments, good ? double(segments) / good : 0.0);
  std::printf("edge points: %lu (%.1f per scan), of them veil points (mixed pixels): %lu (%.2f per scan)\n", edges,
              good ? double(edges) / good : 0.0, veil_points, good ? double(veil_points) / good : 0.0);
  std::printf("segments within 15 deg of their own beam: %lu (%.3f per scan)\n", toward_beam,
              good ? double(toward_beam) / good : 0.0);
  std::printf("segments with own points more than 1 cm beyond their ends: %lu (farthest %.3f m)\n", overhanging,
              worst_overhang);
  if (!times_us.empty()) {
    std::sort(times_us.begin(), times_us.end());
    std::printf("split time per scan [us]: median %.1f, max %.1f\n", times_us[times_us.size() / 2], times_us.back());
  }
  return 0;
}
