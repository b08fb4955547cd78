// Runs the whole pipeline offline over a recording (split, sweep assembly,
// grouping, height map), as replay.launch does in real time, and prints each
// sweep's planes. For recordings of other rigs after import_tilt_bag.py.
//   group_bag BAG --urdf FILE [--frame base_footprint] [--joint head_tilt_joint] [--laser laser]
//             [--calibration FILE] [--dump PREFIX] [--room] [--floor-z Z]
// --calibration applies calibrate's output (joint offset, time offset, the mount).
// --dump writes each sweep's points with their plane (PREFIX_sweepK.pcd, ascii x y z label, 0: none),
// organized: a row a scan line, NaN where a beam has no return, VIEWPOINT the laser's mean place over
// the sweep (segment_cloud reads it).
// --room judges each sweep as a room: the floor (the lowest level that holds
// 2 % of the points, or the level that --floor-z Z [m] names, +-5 cm) and the
// largest wall (the vertical surface with the most points within 5 cm, found
// by a Hough vote of the points in vertical planes), each by the share of its
// points that the largest plane on it holds.
// The recording's end closes the sweep in progress; a run without a sweep says why.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "bag_pipeline.hpp"
#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/io/pcd.hpp"

using namespace tilt_laser_perception;

namespace {
void usage() {
  std::fprintf(stderr,
               "usage: group_bag BAG --urdf FILE [--frame F] [--joint J] [--laser L] [--calibration FILE] [--dump PREFIX]\n"
               "                 [--reverse] [--room] [--floor-z Z] [--spin-span RAD]\n"
               "  --spin-span RAD: a spinning head's recording (make_scene_bag --spin, hrp4.launch spin:=): a sweep each\n"
               "                   RAD of the joint (pi: a half turn); with --joint head_spin_joint and its URDF\n");
}

struct Share {
  int points = 0;     // points of the surface
  int best = 0;       // of them in the plane that holds most
  int plane = -1;
  double fraction() const { return points ? static_cast<double>(best) / points : 0.0; }
};

/// The share of the points `on` selects (by place and plane label, -1 none) that the plane holding most of them holds.
Share share(const core::SweepResult& sw, const std::vector<std::vector<int>>& label,
            const std::function<bool(const Eigen::Vector3f&, int)>& on) {
  Share s;
  std::map<int, int> by_plane;
  for (std::size_t li = 0; li < sw.lines.size(); ++li)
    for (std::size_t i = 0; i < sw.lines[li].points.size(); ++i) {
      const Eigen::Vector3f& p = sw.lines[li].points[i];
      if (!p.allFinite() || !on(p, label[li][i])) continue;
      ++s.points;
      if (label[li][i] >= 0) ++by_plane[label[li][i]];
    }
  for (const auto& [pl, n] : by_plane)
    if (n > s.best) {
      s.best = n;
      s.plane = pl;
    }
  return s;
}

void judgeRoom(const core::SweepResult& sw, const std::vector<std::vector<int>>& label, double floor_at) {
  std::vector<Eigen::Vector3f> pts;
  for (const auto& l : sw.lines)
    for (const auto& p : l.points)
      if (p.allFinite()) pts.push_back(p);
  if (pts.size() < 100) {
    std::printf("  room: %zu points, too few to judge\n", pts.size());
    return;
  }
  // The floor: the level given, else the lowest 1 cm level holding 2 % of the
  // points (the surface the rig stands on, which need not be the room's floor).
  double floor_z = floor_at;
  if (std::isnan(floor_z)) {
    std::map<int, int> zbins;
    for (const auto& p : pts) ++zbins[static_cast<int>(std::floor(p.z() / 0.01))];
    for (const auto& [b, n] : zbins)
      if (n >= 0.02 * pts.size()) {
        floor_z = (b + 0.5) * 0.01;
        break;
      }
  }
  const Share floor =
      share(sw, label, [&](const Eigen::Vector3f& p, int) { return std::abs(p.z() - floor_z) < 0.05; });
  // The largest wall: a Hough vote over vertical planes x cos(a) + y sin(a) = d
  // (1 degree, 2 cm) by the points above the floor that lie in vertical planes
  // (normals within 10 degrees of level). A dense table top crosses every
  // vertical slab and must not vote.
  std::vector<char> vertical(sw.planes.empty() ? 0 : 1 + std::max_element(sw.planes.begin(), sw.planes.end(),
      [](const core::Plane& a, const core::Plane& b) { return a.id < b.id; })->id, 0);
  std::vector<char> level(vertical.size(), 0);
  for (const auto& pl : sw.planes) {
    vertical[pl.id] = std::abs(pl.fit.normal.z()) < std::sin(10.0 * M_PI / 180.0);
    level[pl.id] = std::abs(pl.fit.normal.z()) > std::cos(10.0 * M_PI / 180.0);
  }
  const auto inVertical = [&](int l) { return l >= 0 && l < static_cast<int>(vertical.size()) && vertical[l]; };
  std::map<std::pair<int, int>, int> votes;
  for (std::size_t li = 0; li < sw.lines.size(); ++li)
    for (std::size_t i = 0; i < sw.lines[li].points.size(); ++i) {
      const Eigen::Vector3f& p = sw.lines[li].points[i];
      if (!p.allFinite() || !(p.z() > floor_z + 0.1) || !inVertical(label[li][i])) continue;
      for (int a = 0; a < 180; ++a) {
        const double t = a * M_PI / 180.0;
        ++votes[{a, static_cast<int>(std::floor((p.x() * std::cos(t) + p.y() * std::sin(t)) / 0.02))}];
      }
    }
  std::pair<int, int> best{0, 0};
  int most = 0;
  for (const auto& [k, n] : votes)
    if (n > most) {
      most = n;
      best = k;
    }
  if (most == 0) {
    std::printf("  room: floor at z=%.3f m: %d points, %.1f %% in plane %d; no vertical plane above it\n", floor_z,
                floor.points, 100.0 * floor.fraction(), floor.plane);
    return;
  }
  const double t = best.first * M_PI / 180.0, d = (best.second + 0.5) * 0.02;
  // The wall's points: above the floor, within 5 cm of it, in no level plane
  // (a table top or a floor crossing its slab). A point of the wall that a
  // tilted plane took is the wall's all the same: left out, it would make
  // the wall look whole the more of it went astray.
  const Share wall = share(sw, label, [&](const Eigen::Vector3f& p, int l) {
    if (l >= 0 && l < static_cast<int>(level.size()) && level[l]) return false;
    return p.z() > floor_z + 0.1 && std::abs(p.x() * std::cos(t) + p.y() * std::sin(t) - d) < 0.05;
  });
  std::printf("  room: floor at z=%.3f m: %d points, %.1f %% in plane %d; largest wall (normal %.0f deg, %.2f m): %d points, "
              "%.1f %% in plane %d\n",
              floor_z, floor.points, 100.0 * floor.fraction(), floor.plane, best.first * 1.0, d, wall.points,
              100.0 * wall.fraction(), wall.plane);
}
}  // namespace

int main(int argc, char** argv) {
  tools::BagPipelineOptions o;
  o.sweep.max_lines = 5000;  // a slow stand sweeps with many lines
  std::string dump;
  bool room = false;
  double floor_z = NAN;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    try {
      if (tools::parseBagOption(argc, argv, i, o)) continue;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "group_bag: %s\n", e.what());
      return 2;
    }
    if (a == "--dump" && i + 1 < argc) dump = argv[++i];
    else if (a == "--room") room = true;
    else if (a == "--floor-z" && i + 1 < argc) {
      room = true;
      char* end = nullptr;
      floor_z = std::strtod(argv[++i], &end);
      if (end == argv[i] || *end != '\0' || !std::isfinite(floor_z)) {
        std::fprintf(stderr, "group_bag: --floor-z wants a height in metres, not '%s'\n", argv[i]);
        return 2;
      }
    }
    else if (a[0] != '-' && o.bag.empty()) o.bag = a;
    else { usage(); return a == "-h" || a == "--help" ? 0 : 2; }
  }
  if (o.bag.empty() || o.urdf.empty()) { usage(); return 2; }
  core::HeightMapGrid grid;
  int sweeps = 0;
  const auto report = [&](const core::SweepResult& sw) {
    core::buildHeightMap(sw, core::HeightMapParams(), grid);
    std::vector<std::vector<int>> label(sw.lines.size());
    for (std::size_t li = 0; li < sw.lines.size(); ++li) label[li].assign(sw.lines[li].points.size(), -1);
    for (std::size_t si = 0; si < sw.segments.size(); ++si)
      for (int i = sw.segments[si].first; i <= sw.segments[si].last; ++i)
        label[sw.segments[si].line][i] = sw.segment_plane[si];
    std::vector<core::Plane> planes = sw.planes;
    std::sort(planes.begin(), planes.end(), [](const core::Plane& a, const core::Plane& b) { return a.points > b.points; });
    std::printf("sweep %d: %zu lines, %zu planes; finish %.2f ms\n", sweeps, sw.lines.size(), sw.planes.size(),
                sw.finish_seconds * 1e3);
    const core::SweepNoiseEstimate noise = core::estimateSweepNoise(sw);
    std::printf("  noise model, estimated from the sweep: range noise %.1f mm along its lines, line pose error "
                "%.3f deg (0: too few patches to tell)\n",
                noise.range.along * 1e3, noise.line_sigma * 180.0 / M_PI);
    for (std::size_t k = 0; k < planes.size() && k < 6; ++k) {
      const core::Plane& p = planes[k];
      std::printf("  plane %d: %d points, %.2f m^2, normal (%.3f %.3f %.3f), offset %.3f m, rms %.4f m\n", p.id,
                  p.points, p.area, p.fit.normal.x(), p.fit.normal.y(), p.fit.normal.z(), p.fit.offset, p.fit.rms);
    }
    if (room) judgeRoom(sw, label, floor_z);
    if (!dump.empty()) {
      // Organized, a row a scan line (NaN: no return), seen from the laser's
      // mean place over the sweep: a cloud segment_cloud reads as it is.
      io::OrganizedCloud c;
      std::size_t beams = 0;
      for (const auto& line : sw.lines) beams = std::max(beams, line.points.size());
      c.width = static_cast<int>(beams);
      c.height = static_cast<int>(sw.lines.size());
      c.viewpoint = core::meanOrigin(sw);
      c.points.assign(beams * sw.lines.size(), Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
      std::vector<std::uint32_t> labels(c.points.size(), 0);
      for (std::size_t li = 0; li < sw.lines.size(); ++li)
        for (std::size_t i = 0; i < sw.lines[li].points.size(); ++i) {
          c.points[li * beams + i] = sw.lines[li].points[i];
          labels[li * beams + i] = static_cast<std::uint32_t>(label[li][i] + 1);
        }
      const std::string path = dump + "_sweep" + std::to_string(sweeps) + ".pcd";
      io::writeLabeledPcd(path, c, labels, true);
      std::printf("  points with their planes: %s\n", path.c_str());
    }
    ++sweeps;
  };
  tools::BagPipelineResult r;
  std::string error;
  if (!tools::runBagPipeline(o, nullptr, report, r, error)) {
    std::fprintf(stderr, "group_bag: %s\n", error.c_str());
    return 1;
  }
  const core::SweepCounters& c = r.counters;
  if (r.closed_by_end)
    std::printf("the recording's end closed sweep %d (no tilt reversal after it)\n", sweeps - 1);
  const std::string why = tools::noSweepReason(o, r);
  if (!why.empty()) std::printf("no sweep: %s\n", why.c_str());
  std::printf("%d scans, %d sweeps; lines %lu, without joint states %lu, out of order %lu, without pose %lu, bad %lu, "
              "joints out of order %lu; sweeps dropped %lu; %s\n",
              r.scans, sweeps, c.lines, c.lines_no_joint, c.lines_out_of_order, c.lines_no_pose, c.lines_bad,
              c.joints_out_of_order, c.sweeps_dropped,
              r.last_warning.empty() ? "no warnings" : ("last warning: " + r.last_warning).c_str());
  return 0;
}
