// Split and scan line grouping on any organized point cloud whose rows (or
// columns) are scan lines: a multi-beam lidar's rings, a range image, or a
// sweep_cloud of this package. Prints the planes and the time; writes the
// cloud back with a label per point (0: no plane).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/sim/pcd.hpp"

using namespace tilt_laser_perception;

static void usage() {
  std::fprintf(stderr,
               "usage: segment_cloud CLOUD.pcd [--scan-lines rows|columns] [--out LABELS.pcd] [--zeta Z] [--dmin D]\n"
               "  the cloud must be organized (HEIGHT > 1); its VIEWPOINT is the sensor's position\n");
}

int main(int argc, char** argv) {
  std::string in, out;
  bool rows = true;
  core::SplitParams split;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    if (a == "--scan-lines" && v) {
      const std::string m = argv[++i];
      if (m != "rows" && m != "columns") { usage(); return 2; }
      rows = m == "rows";
    } else if (a == "--out" && v) out = argv[++i];
    else if (a == "--zeta" && v) split.zeta = std::atof(argv[++i]);
    else if (a == "--dmin" && v) split.d_min = std::atof(argv[++i]);
    else if (a[0] != '-' && in.empty()) in = a;
    else { usage(); return a == "-h" || a == "--help" ? 0 : 2; }
  }
  if (in.empty()) { usage(); return 2; }
  try {
    const sim::OrganizedCloud c = sim::readPcd(in);
    if (c.height < 2 || c.width < 2) throw std::runtime_error(in + " is not organized (HEIGHT and WIDTH must be > 1)");
    std::vector<core::Plane> planes;
    std::vector<std::uint32_t> labels;
    const auto t0 = std::chrono::steady_clock::now();
    core::segmentOrganized(c.points, c.width, c.height, rows, c.viewpoint, split, core::GroupingParams(), planes, labels);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::size_t labeled = 0;
    for (auto l : labels) labeled += l != 0;
    std::printf("%s: %d x %d points, scan lines are %s; %zu planes, %zu points in planes; %.2f ms\n", in.c_str(),
                c.width, c.height, rows ? "rows" : "columns", planes.size(), labeled, ms);
    std::printf("id,points,segments,area_m2,nx,ny,nz,offset_m,cx,cy,cz,rms_m\n");
    for (const auto& p : planes)
      std::printf("%d,%d,%d,%.3f,%.4f,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f,%.4f\n", p.id + 1, p.points, p.segments, p.area,
                  p.fit.normal.x(), p.fit.normal.y(), p.fit.normal.z(), p.fit.offset, p.fit.centroid.x(),
                  p.fit.centroid.y(), p.fit.centroid.z(), p.fit.rms);
    if (!out.empty()) {
      sim::writeLabeledPcd(out, c, labels);
      std::printf("labels written to %s\n", out.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "segment_cloud: %s\n", e.what());
    return 1;
  }
  return 0;
}
