#include "tilt_laser_perception/core/scan_order.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "tilt_laser_perception/core/noise_model.hpp"
#include "tilt_laser_perception/core/plane.hpp"

namespace tilt_laser_perception {
namespace core {

namespace {
double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }
/// Within this angle of the spin axis a point's side is the plane's, not
/// its own: a laser a little off the axis sees its plane's angle swing there.
constexpr double kAxisZone = 5.0 * M_PI / 180.0;

/// A stretch is a run of points each within this many median spacings of
/// the one before (a gap or a jump in depth ends it); it needs kStretchPoints.
constexpr double kStretchJump = 8.0;
constexpr std::size_t kStretchPoints = 20;

/// The beams' spacing seen from `o` over the neighbouring pairs `pairs`
/// (index of the first): its median, and its interquartile range over the
/// median, of the pairs less than 1.5 medians apart (the rest skip beams).
std::pair<double, double> beamSteps(const std::vector<Eigen::Vector3f>& pts, const std::vector<std::size_t>& pairs,
                                    const Eigen::Vector3d& o, std::vector<double>& buf) {
  buf.clear();
  for (const std::size_t i : pairs) {
    const Eigen::Vector3d u = pts[i].cast<double>() - o, v = pts[i + 1].cast<double>() - o;
    buf.push_back(std::atan2(u.cross(v).norm(), u.dot(v)));
  }
  if (buf.size() < 8) return {0.0, 1e9};
  std::nth_element(buf.begin(), buf.begin() + buf.size() / 2, buf.end());
  const double med = buf[buf.size() / 2];
  buf.erase(std::remove_if(buf.begin(), buf.end(), [&](double x) { return !(x < 1.5 * med); }), buf.end());
  if (buf.size() < 8 || !(med > 0.0)) return {0.0, 1e9};
  const auto quantile = [&](std::size_t k) {
    std::nth_element(buf.begin(), buf.begin() + k, buf.end());
    return buf[k];
  };
  const double q1 = quantile(buf.size() / 4), q2 = quantile(buf.size() / 2), q3 = quantile(3 * buf.size() / 4);
  return {q2, (q3 - q1) / q2};
}
}  // namespace

SpinGeometry estimateSpinGeometry(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3d& origin_in,
                                  const Eigen::Vector3d& axis_in) {
  SpinGeometry g;
  // Stretches: split at a point not finite and where the spacing jumps.
  std::vector<double> gaps;
  for (std::size_t i = 1; i < points.size(); ++i)
    if (points[i].allFinite() && points[i - 1].allFinite()) gaps.push_back((points[i] - points[i - 1]).norm());
  if (gaps.size() < kStretchPoints) {
    g.why = "too few points";
    return g;
  }
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  const double jump = kStretchJump * gaps[gaps.size() / 2];
  // A stretch's plane is the line's when its points lie within the range
  // noise of it and spread across it by five times that (not one straight
  // run of ground, whose plane is any through it).
  const double noise = NoiseModel().range_sigma;
  struct Stretch {
    Eigen::Vector3d n;
    double d, w;
  };
  std::vector<Stretch> planes;
  std::vector<std::size_t> pairs;  // neighbours within a stretch
  std::size_t start = 0;
  for (std::size_t i = 1; i <= points.size(); ++i) {
    const bool cut = i == points.size() || !points[i].allFinite() || !points[i - 1].allFinite() ||
                     (points[i] - points[i - 1]).norm() > jump;
    if (!cut) continue;
    if (i - start >= kStretchPoints) {
      Moments3 m;
      for (std::size_t k = start; k < i; ++k) m.add(points[k].cast<double>());
      const PlaneFit f = fitPlane(m);
      if (f.rms <= noise && f.spread(1) >= 5.0 * noise) planes.push_back({f.normal, f.offset, m.n});
      for (std::size_t k = start; k + 1 < i; ++k) pairs.push_back(k);
    }
    start = i;
  }
  g.stretches = static_cast<int>(planes.size());
  if (planes.size() < 3) {
    g.why = "fewer than three stretches of points that fix their line's plane (lines over nothing but flat ground?)";
    return g;
  }
  // The axis: the direction every plane contains (their normals' least
  // direction); refitted once without the planes that miss it by far.
  Eigen::Vector3d a = axis_in;
  Eigen::Vector3d o = origin_in;  // a point of the axis
  const bool find_axis = !(a.allFinite() && a.norm() > 0.0);
  std::vector<char> use(planes.size(), 1);
  for (int pass = 0; pass < 2; ++pass) {
    if (find_axis) {
      Eigen::Matrix3d nn = Eigen::Matrix3d::Zero();
      for (std::size_t k = 0; k < planes.size(); ++k)
        if (use[k]) nn += planes[k].w * planes[k].n * planes[k].n.transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(nn);
      // A pencil of planes: their normals spread across the axis ten times
      // (in sigma) more than along the least direction.
      if (!(es.eigenvalues()(1) > 100.0 * std::max(es.eigenvalues()(0), 0.0))) {
        g.why = "the stretches' planes do not turn about one axis";
        return g;
      }
      a = es.eigenvectors().col(0);
    }
    a.normalize();
    // A point of the axis: the one that all planes pass nearest (a least
    // squares in the two directions across the axis).
    const Eigen::Vector3d e1 = a.unitOrthogonal(), e2 = a.cross(e1);
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (std::size_t k = 0; k < planes.size(); ++k) {
      if (!use[k]) continue;
      const Eigen::Vector2d n2(planes[k].n.dot(e1), planes[k].n.dot(e2));
      A += planes[k].w * n2 * n2.transpose();
      b += planes[k].w * planes[k].d * n2;
    }
    const Eigen::Vector2d x = A.ldlt().solve(b);
    const Eigen::Vector3d on_axis = origin_in.allFinite() ? origin_in : Eigen::Vector3d(x(0) * e1 + x(1) * e2);
    std::vector<double> miss;
    double ss = 0.0, sw = 0.0;
    for (std::size_t k = 0; k < planes.size(); ++k) {
      const double r = planes[k].n.dot(on_axis) - planes[k].d;
      miss.push_back(std::abs(r));
      if (use[k]) {
        ss += planes[k].w * r * r;
        sw += planes[k].w;
      }
    }
    g.plane_rms = std::sqrt(ss / sw);
    std::vector<double> sorted = miss;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = 3.0 * std::max(sorted[sorted.size() / 2] * 1.4826, noise);  // 3 robust sigmas
    for (std::size_t k = 0; k < planes.size(); ++k) use[k] = miss[k] <= limit;
    o = on_axis;
  }
  // The axis points towards the points.
  double towards = 0.0;
  for (const Eigen::Vector3f& p : points)
    if (p.allFinite()) towards += (p.cast<double>() - o).dot(a);
  if (towards < 0.0) a = -a;
  g.axis = a;
  // Along the axis: where the beams lie most evenly apart. Searched over the
  // points' own extent along it and 2 m beyond, in 5 cm steps, then in 2 mm.
  std::vector<double> buf;
  if (origin_in.allFinite()) {
    g.origin = origin_in;
  } else {
    // (Every so many pairs: 2,000 for the coarse search, 20,000 for the fine.)
    const auto every = [&](std::size_t n) {
      std::vector<std::size_t> some;
      const std::size_t step = std::max<std::size_t>(1, pairs.size() / n);
      for (std::size_t k = 0; k < pairs.size(); k += step) some.push_back(pairs[k]);
      return some;
    };
    double lo = 1e300, hi = -1e300;
    for (const Eigen::Vector3f& p : points)
      if (p.allFinite()) {
        lo = std::min(lo, (p.cast<double>() - o).dot(a));
        hi = std::max(hi, (p.cast<double>() - o).dot(a));
      }
    const auto best = [&](double from, double to, double step, const std::vector<std::size_t>& some) {
      double t_best = from, c_best = 1e300;
      for (double t = from; t <= to + 1e-9; t += step) {
        const double c = beamSteps(points, some, o + t * a, buf).second;
        if (c < c_best) {
          c_best = c;
          t_best = t;
        }
      }
      return t_best;
    };
    double t = best(lo - 2.0, hi + 2.0, 0.05, every(2000));
    t = best(t - 0.05, t + 0.05, 0.002, every(20000));
    g.origin = o + t * a;
  }
  const auto steps = beamSteps(points, pairs, g.origin, buf);
  g.beam_step = steps.first;
  g.step_spread = steps.second;
  g.ok = true;
  return g;
}

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
