// Split and scan line grouping on any organized point cloud whose rows (or
// columns) are scan lines: a multi-beam lidar's rings, a range image, or a
// sweep_cloud of this package, any PCD file PCL reads. Prints the planes and
// the time; with --truth-field, Hoover et al.'s figures against a label field
// of the cloud; writes the cloud back with a label per point (0: no plane).
#include <algorithm>
#include <chrono>
#include <map>
#include <numeric>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <thread>

#include <Eigen/Geometry>

#include "tilt_laser_perception/core/plane.hpp"
#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/core/scan_order.hpp"
#include "tilt_laser_perception/io/pcd.hpp"
#include "tilt_laser_perception/sim/evaluation.hpp"

using namespace tilt_laser_perception;

namespace {
struct Surface {
  std::string name;
  Eigen::AlignedBox3d box;
};

bool parseSurface(const std::string& spec, Surface& s) {
  const auto colon = spec.find(':');
  if (colon == std::string::npos || colon == 0) return false;
  s.name = spec.substr(0, colon);
  double v[6];
  const char* p = spec.c_str() + colon + 1;
  for (int i = 0; i < 6; ++i) {
    char* end = nullptr;
    v[i] = std::strtod(p, &end);
    if (end == p || (i < 5 && *end != ',') || (i == 5 && *end != '\0')) return false;
    p = end + 1;
  }
  s.box = Eigen::AlignedBox3d(Eigen::Vector3d(v[0], v[2], v[4]), Eigen::Vector3d(v[1], v[3], v[5]));
  return !s.box.isEmpty();
}

/// The surface's points (in the box, near the plane fitted to the box's points), and how the planes hold them.
void judgeSurface(const Surface& sf, const std::vector<Eigen::Vector3f>& pts, const std::vector<std::uint32_t>& labels) {
  std::vector<std::size_t> in;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (pts[i].allFinite() && sf.box.contains(pts[i].cast<double>())) in.push_back(i);
  if (in.size() < 10) {
    std::printf("surface %s: %zu points in its box, too few\n", sf.name.c_str(), in.size());
    return;
  }
  core::PlaneFit f;
  double band = 1e9;
  for (int pass = 0; pass < 3; ++pass) {
    core::Moments3 m;
    for (std::size_t i : in) {
      const Eigen::Vector3d p = pts[i].cast<double>();
      if (pass == 0 || std::abs(f.normal.dot(p) - f.offset) < band) m.add(p);
    }
    if (m.n < 3) break;
    f = core::fitPlane(m);
    band = std::max(3.0 * f.rms, 0.03);
  }
  std::map<std::uint32_t, int> by_plane;
  int n = 0;
  for (std::size_t i : in)
    if (std::abs(f.normal.dot(pts[i].cast<double>()) - f.offset) < band) {
      ++n;
      if (labels[i] != 0) ++by_plane[labels[i]];
    }
  std::vector<int> counts;
  int largest = -1, most = 0;  // the label holding most, and how many
  for (const auto& [l, c] : by_plane) {
    if (c > most) {
      most = c;
      largest = static_cast<int>(l);
    }
    counts.push_back(c);
  }
  std::sort(counts.rbegin(), counts.rend());
  int to80 = 0, sum = 0;
  while (to80 < static_cast<int>(counts.size()) && sum < 0.8 * n) sum += counts[to80++];
  const int in_planes = std::accumulate(counts.begin(), counts.end(), 0);
  std::printf("surface %s: %d points within %.1f cm of its plane (normal %.3f %.3f %.3f, rms %.1f cm); largest plane "
              "%.1f %% (plane %d), in planes %.1f %%, planes for 80 %%: %s\n",
              sf.name.c_str(), n, 100.0 * band, f.normal.x(), f.normal.y(), f.normal.z(), 100.0 * f.rms,
              n ? 100.0 * (counts.empty() ? 0 : counts[0]) / n : 0.0, largest,
              n ? 100.0 * in_planes / n : 0.0, sum >= 0.8 * n ? std::to_string(to80).c_str() : "never");
}
}  // namespace

static void usage() {
  std::fprintf(stderr,
               "usage: segment_cloud CLOUD.pcd|SCAN.3d [--scan-lines rows|columns] [--reverse] [--out LABELS.pcd] [--zeta Z]\n"
               "                     [--dmin D]\n"
               "                     [--noise auto|off|SIGMA] [--line-spacing-deg D] [--threads 1|2]\n"
               "                     [--truth-field NAME [--truth-none V] [--overlap T]]\n"
               "  the cloud must be organized (HEIGHT > 1); its VIEWPOINT is the sensor's position;\n"
               "  PCD data ascii, binary or binary_compressed, fields in any order (PCL's reader)\n"
               "  a .3d file is a 3DTK scan (x y z in cm, left-handed, y up; a row a scan line), taken to metres, z up\n"
               "  --reverse           the scan lines in the other order (the result should not depend on it)\n"
               "  --origin X,Y,Z --axis X,Y,Z  a flat cloud (HEIGHT 1) of a spinning laser, its points in the order\n"
               "                      measured: where the laser is and the axis it spins about [m]; its scan lines\n"
               "                      are rebuilt (a new one where the beam angle falls back) into rows; either\n"
               "                      not given is estimated (each line lies in a plane containing the axis; the\n"
               "                      laser is where its beams lie evenly apart) and printed\n"
               "  --surface NAME:X0,X1,Y0,Y1,Z0,Z1  judge one surface (a floor, a ceiling, a wall): the points in the box\n"
               "                      [m] within 3 rms (at least 3 cm) of the plane fitted to them (refitted twice on\n"
               "                      those), the share of them the largest plane holds and how many planes hold 80 %%\n"
               "                      (repeatable)\n"
               "  --truth-field NAME  judge the planes against the labels in field NAME (Hoover et al., 80 %%)\n"
               "  --truth-none V      the label value that means no plane (default: every value is a plane)\n"
               "  --out FILE          x y z label (PointXYZL, binary_compressed; --ascii: ascii, for scripts)\n"
               "  --noise             the range noise: auto (default: estimated from the cloud's own second\n"
               "                      differences along its rows and its columns), SIGMA [m] given, or off (the\n"
               "                      tolerances of the UTM-30LX on the tilting head); a cloud less noisy than 5 mm\n"
               "                      is judged by its own noise, the tolerances scaled down to a fifth at most, the\n"
               "                      split's zeta to half the angle between beams (the grouping's growth with range\n"
               "                      no less than it)\n"
               "  --line-sigma-deg D|auto  the noise model's line term: each scan line's own pose error (a tilting\n"
               "                      rig's encoder, backlash, timing), which moves a whole line by range x D out of\n"
               "                      its scan plane; auto (default): estimated from the cloud (each line against the\n"
               "                      plane of the lines before it); 0: the tolerances alone\n"
               "  --line-spacing-deg D  group scan lines no closer than D degrees (default 0.5; 0: every line): of\n"
               "                      lines closer than that, every k-th is split and grouped, and a point of a\n"
               "                      line between joins the plane of the grouped point before or after it in its\n"
               "                      column that it lies within the grouping's distance of\n"
               "  --threads 1|2       1: one thread; 2 (default where the machine has two cores or more): a second\n"
               "                      thread splits the lines while the first groups them, and takes half the lines\n"
               "                      between (the same planes and labels)\n");
}

int main(int argc, char** argv) {
  std::string in, out;
  bool rows = true, reverse = false, ascii = false;
  std::string line_sigma = "auto";
  std::vector<Surface> surfaces;
  core::SplitParams split;
  io::TruthField truth;
  double overlap = 0.8;
  std::string noise = "auto";
  double spacing_deg = core::kOrganizedLineSpacing * 180.0 / M_PI;
  int threads = std::thread::hardware_concurrency() >= 2 ? 2 : 1;
  Eigen::Vector3d spin_origin = Eigen::Vector3d::Constant(std::nan("")), spin_axis = spin_origin;
  const auto parseVector = [](const char* text, Eigen::Vector3d& v) {
    return std::sscanf(text, "%lf,%lf,%lf", &v.x(), &v.y(), &v.z()) == 3 && v.allFinite();
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    if (a == "--scan-lines" && v) {
      const std::string m = argv[++i];
      if (m != "rows" && m != "columns") { usage(); return 2; }
      rows = m == "rows";
    } else if (a == "--reverse") reverse = true;
    else if ((a == "--origin" || a == "--axis") && v) {
      if (!parseVector(argv[++i], a == "--origin" ? spin_origin : spin_axis)) { usage(); return 2; }
    }
    else if (a == "--ascii") ascii = true;
    else if (a == "--out" && v) out = argv[++i];
    else if (a == "--zeta" && v) split.zeta = std::atof(argv[++i]);
    else if (a == "--dmin" && v) split.d_min = std::atof(argv[++i]);
    else if (a == "--truth-field" && v) truth.name = argv[++i];
    else if (a == "--surface" && v) {
      Surface sf;
      if (!parseSurface(argv[++i], sf)) { usage(); return 2; }
      surfaces.push_back(sf);
    }
    else if (a == "--truth-none" && v) { truth.has_none = true; truth.none = std::atof(argv[++i]); }
    else if (a == "--overlap" && v) overlap = std::atof(argv[++i]);
    else if (a == "--noise" && v) noise = argv[++i];
    else if (a == "--line-spacing-deg" && v) spacing_deg = std::atof(argv[++i]);
    else if (a == "--line-sigma-deg" && v) line_sigma = argv[++i];
    else if (a == "--threads" && v) threads = std::atoi(argv[++i]);
    else if (a[0] != '-' && in.empty()) in = a;
    else { usage(); return a == "-h" || a == "--help" ? 0 : 2; }
  }
  char* sigma_end = nullptr;
  const double line_sigma_given = std::strtod(line_sigma.c_str(), &sigma_end);
  if (line_sigma != "auto" && (sigma_end == line_sigma.c_str() || *sigma_end != '\0' || !(line_sigma_given >= 0.0))) {
    usage();
    return 2;
  }
  char* noise_end = nullptr;
  const double noise_sigma = std::strtod(noise.c_str(), &noise_end);
  const bool noise_given = noise_end != noise.c_str() && *noise_end == '\0' && noise_sigma > 0.0;
  if (in.empty() || !(spacing_deg >= 0.0) || (threads != 1 && threads != 2) || !(overlap > 0.5 && overlap <= 1.0) || (noise != "auto" && noise != "off" && !noise_given)) {
    usage();
    return 2;
  }
  try {
    io::OrganizedCloud c = io::readCloud(in, truth);
    if (c.height == 1 && c.width > 1) {
      // A spinning laser's flat cloud in scan order: its lines rebuilt.
      if (!spin_origin.allFinite() || !spin_axis.allFinite() || !(spin_axis.norm() > 0.0)) {
        const auto t_est = std::chrono::steady_clock::now();
        const core::SpinGeometry g = core::estimateSpinGeometry(c.points, spin_origin, spin_axis);
        const double est_ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_est).count();
        if (!g.ok)
          throw std::runtime_error(in + " is a flat cloud (HEIGHT 1) whose spin axis could not be found (" + g.why +
                                   "): if its points are a spinning laser's in the order measured, give --origin "
                                   "X,Y,Z and --axis X,Y,Z");
        std::printf("spin axis estimated from %d stretches of points (their planes %.1f mm from it): origin %.4f,%.4f,"
                    "%.4f axis %.5f,%.5f,%.5f; beams %.4f deg apart from there (spread %.1f %%); %.0f ms\n",
                    g.stretches, 1e3 * g.plane_rms, g.origin.x(), g.origin.y(), g.origin.z(), g.axis.x(), g.axis.y(),
                    g.axis.z(), g.beam_step * 180.0 / M_PI, 100.0 * g.step_spread, est_ms);
        spin_origin = g.origin;
        spin_axis = g.axis;
      }
      if (!c.truth.empty()) throw std::runtime_error(in + ": a flat cloud's truth field is not read");
      core::ScanLines sl = core::rebuildScanLines(c.points, spin_origin, spin_axis);
      if (sl.width == 0) throw std::runtime_error(in + ": no scan lines found in the order of its points");
      std::printf("%s: %d scan lines of up to %d beams %.3f deg apart rebuilt from the order measured (%d points on "
                  "a beam already taken, %d not finite: left out)\n",
                  in.c_str(), sl.height, sl.width, sl.beam_step * 180.0 / M_PI, sl.collided, sl.dropped);
      c.points = std::move(sl.points);
      c.width = sl.width;
      c.height = sl.height;
      c.viewpoint = spin_origin;
      rows = true;
    }
    if (reverse) c = io::reversedLines(c, rows);
    if (c.height < 2 || c.width < 2) throw std::runtime_error(in + " is not organized (HEIGHT and WIDTH must be > 1)");
    std::vector<core::Plane> planes;
    std::vector<std::uint32_t> labels;
    const auto t0 = std::chrono::steady_clock::now();
    core::GroupingParams grouping;
    core::CloudNoise cn;
    double k = 1.0;
    if (noise != "off") {
      cn = core::estimateCloudNoise(c.points, c.width, c.height, rows, c.viewpoint);
      if (noise_given) cn.sigma = noise_sigma;
      k = core::scaleTolerancesToNoise(cn, split, grouping);
    }
    const int step = core::organizedLineStep(c.points, c.width, c.height, rows, c.viewpoint, spacing_deg * M_PI / 180.0);
    // The noise model's line term: each line's own pose error, estimated from the lines as grouped, or given.
    grouping.line_sigma = line_sigma == "auto"
                              ? core::estimateLineSigma(c.points, c.width, c.height, rows, c.viewpoint, step)
                              : line_sigma_given * M_PI / 180.0;
    core::segmentOrganized(c.points, c.width, c.height, rows, c.viewpoint, split, grouping, planes, labels, step,
                           nullptr, threads);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::size_t labeled = 0;
    for (auto l : labels) labeled += l != 0;
    std::printf("%s: %d x %d points, scan lines are %s%s; %zu planes, %zu points in planes; %.2f ms (%d thread%s)\n",
                in.c_str(), c.width, c.height, rows ? "rows" : "columns", reverse ? " (reversed)" : "", planes.size(),
                labeled, ms, threads, threads > 1 ? "s" : "");
    if (step > 1)
      std::printf("scan lines closer than %.2f deg: every %d. grouped, the points of the lines between joined to planes\n",
                  spacing_deg, step);
    std::printf("line pose error %.3f deg (%s): a line within %.1f sigma of its plane (%.1f cm at 5 m)\n",
                grouping.line_sigma * 180.0 / M_PI, line_sigma == "auto" ? "estimated" : "given", grouping.significance,
                100.0 * grouping.significance * grouping.line_sigma * 5.0);
    if (noise != "off")
      std::printf("range noise %.1f mm (%s), beams %.3f deg apart: tolerances x %.2f (split d_min %.1f mm, zeta %.4f;"
                  " plane distance %.1f mm)\n",
                  1e3 * cn.sigma, noise_given ? "given" : "estimated", cn.step * 180.0 / M_PI, k, 1e3 * split.d_min,
                  split.zeta, 1e3 * grouping.dist_min);
    std::printf("id,points,segments,area_m2,nx,ny,nz,offset_m,cx,cy,cz,rms_m\n");
    for (const auto& p : planes)
      std::printf("%d,%d,%d,%.3f,%.4f,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f,%.4f\n", p.id + 1, p.points, p.segments, p.area,
                  p.fit.normal.x(), p.fit.normal.y(), p.fit.normal.z(), p.fit.offset, p.fit.centroid.x(),
                  p.fit.centroid.y(), p.fit.centroid.z(), p.fit.rms);
    if (!truth.name.empty()) {
      const sim::HooverScore h =
          sim::hooverScore(sim::RegionOverlap::ofPlaneLabels(c.truth, labels, c.points), overlap, [](int) { return true; });
      std::printf("truth '%s': %d planes; at %.0f %% overlap: correct=%d over=%d under=%d missed=%d noise=%d\n",
                  truth.name.c_str(), h.expected, overlap * 100.0, h.correct, h.over, h.under, h.missed, h.noise);
    }
    for (const Surface& sf : surfaces) judgeSurface(sf, c.points, labels);
    if (!out.empty()) {
      io::writeLabeledPcd(out, c, labels, ascii);
      std::printf("labels written to %s\n", out.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "segment_cloud: %s\n", e.what());
    return 1;
  }
  return 0;
}
