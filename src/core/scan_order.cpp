#include "tilt_laser_perception/core/scan_order.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tilt_laser_perception {
namespace core {

namespace {
double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }
/// Within this angle of the spin axis a point's side is the plane's, not
/// its own: a laser a little off the axis sees its plane's angle swing there.
constexpr double kAxisZone = 5.0 * M_PI / 180.0;
}  // namespace

ScanLines rebuildScanLines(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin,
                           const Eigen::Vector3d& axis_in) {
  ScanLines out;
  if (!(axis_in.norm() > 0.0) || points.size() < 4) return out;
  const Eigen::Vector3d a = axis_in.normalized();
  const Eigen::Vector3d e1 = a.unitOrthogonal(), e2 = a.cross(e1);
  // Each point's beam angle: its angle from the axis, signed by the side of
  // the axis it lies on relative to its line's plane. The plane turns slowly
  // (a fraction of a degree a line): its angle follows the points, those
  // kAxisZone or more from the axis (nearer, a laser a little off the axis
  // sees the plane's angle swing).
  std::vector<double> beam(points.size(), std::numeric_limits<double>::quiet_NaN());
  double plane = std::numeric_limits<double>::quiet_NaN();  // the spin angle of the current plane's + side
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    const Eigen::Vector3d d = points[i].cast<double>() - origin;
    const double along = d.dot(a);
    const Eigen::Vector3d r = d - along * a;
    const double radial = r.norm();
    const double from_axis = std::atan2(radial, along);
    const double spin = std::atan2(r.dot(e2), r.dot(e1));
    const bool away = from_axis >= kAxisZone && from_axis <= M_PI - kAxisZone;
    if (std::isnan(plane) && away) plane = spin;
    // Near the axis (or before the plane is known): the side the plane says.
    const bool plus = std::isnan(plane) || radial == 0.0 || std::cos(spin - plane) >= 0.0;
    beam[i] = (plus ? 1.0 : -1.0) * from_axis;
    if (away) plane = plus ? spin : wrap(spin + M_PI);
  }
  // The scan's direction and its beam step: the differences of neighbouring
  // points within a line (small ones), the sign most have and the lower
  // quartile of their sizes.
  std::vector<double> steps;
  double prev = std::numeric_limits<double>::quiet_NaN();
  int up = 0, down = 0;
  for (const double b : beam) {
    if (std::isnan(b)) continue;
    if (!std::isnan(prev)) {
      const double d = b - prev;
      if (std::abs(d) > 0.0 && std::abs(d) < 5.0 * M_PI / 180.0) {
        (d > 0.0 ? up : down) += 1;
        steps.push_back(std::abs(d));
      }
    }
    prev = b;
  }
  if (steps.size() < 2) return out;
  const double dir = up >= down ? 1.0 : -1.0;
  // (Most neighbours are adjacent beams, some skip beams with no return.)
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 4, steps.end());
  out.beam_step = steps[steps.size() / 4];
  if (!(out.beam_step > 0.0)) return out;
  // Lines: a new one where the beam angle falls back by more than a beam
  // step, and more than a point near the axis put on the wrong side can.
  std::vector<int> line(points.size(), -1);
  int lines = 0;
  double last = std::numeric_limits<double>::quiet_NaN(), lo = 1e300, hi = -1e300;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (std::isnan(beam[i])) {
      ++out.dropped;
      continue;
    }
    const double b = dir * beam[i];
    if (std::isnan(last) || b < last - std::max(out.beam_step, 2.0 * kAxisZone)) ++lines;
    line[i] = lines - 1;
    last = b;
    lo = std::min(lo, b);
    hi = std::max(hi, b);
  }
  if (lines < 2) return out;
  out.height = lines;
  out.beam_min = lo;
  out.width = static_cast<int>(std::lround((hi - lo) / out.beam_step)) + 1;
  out.points.assign(static_cast<std::size_t>(out.width) * out.height,
                    Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (line[i] < 0) continue;
    const int col = std::clamp(static_cast<int>(std::lround((dir * beam[i] - lo) / out.beam_step)), 0, out.width - 1);
    Eigen::Vector3f& cell = out.points[static_cast<std::size_t>(line[i]) * out.width + col];
    if (cell.allFinite()) ++out.collided;
    else cell = points[i];
  }
  return out;
}

}  // namespace core
}  // namespace tilt_laser_perception
