#include "tilt_laser_perception/core/scan_split.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace tilt_laser_perception {
namespace core {

LineFit fitLine(const Moments2& m) {
  LineFit f;
  if (m.n <= 0.0) return f;
  const double mx = m.sx / m.n, my = m.sy / m.n;
  f.centroid = Eigen::Vector2d(mx, my);
  const double cxx = m.sxx / m.n - mx * mx;
  const double cyy = m.syy / m.n - my * my;
  const double cxy = m.sxy / m.n - mx * my;
  const double phi = 0.5 * std::atan2(2.0 * cxy, cxx - cyy);
  f.direction = Eigen::Vector2d(std::cos(phi), std::sin(phi));
  const double half_tr = 0.5 * (cxx + cyy);
  const double disc = std::sqrt(0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy);
  f.rms = std::sqrt(std::max(0.0, half_tr - disc));
  return f;
}

const char* edgeKindName(EdgeKind k) {
  switch (k) {
    case EdgeKind::Jump: return "jump";
    case EdgeKind::Occluded: return "occluded";
    case EdgeKind::Crease: return "crease";
    case EdgeKind::Boundary: return "boundary";
    case EdgeKind::Veil: return "veil";
  }
  return "unknown";
}

const char* scanErrorName(ScanError e) {
  switch (e) {
    case ScanError::None: return "none";
    case ScanError::Empty: return "empty scan";
    case ScanError::IntensitySize: return "intensities and ranges differ in size";
    case ScanError::BadIncrement: return "angle_increment zero or not finite";
    case ScanError::InconsistentAngles: return "angle_min + (n-1)*angle_increment more than an increment off angle_max";
    case ScanError::BadRangeLimits: return "range_min/range_max invalid";
    case ScanError::TooManyRanges: return "more ranges than max_ranges";
    case ScanError::BadTimeIncrement: return "time_increment/scan_time not finite, negative or too long";
  }
  return "unknown";
}

std::string SplitParams::validate() const {
  std::ostringstream s;
  if (!(std::isfinite(zeta) && zeta >= 0.0 && zeta < 1.0))
    s << "zeta must be in [0, 1), got " << zeta;
  else if (!(std::isfinite(d_min) && d_min >= 0.0 && d_min < 10.0))
    s << "d_min must be in [0, 10) m, got " << d_min;
  else if (mode == SplitMode::Adaptive && zeta == 0.0 && d_min == 0.0)
    s << "zeta and d_min are both 0: every point would be split off";
  else if (mode == SplitMode::Fixed && d_min == 0.0)
    s << "fixed mode needs d_min > 0";
  else if (!(std::isfinite(jump_min) && jump_min >= 0.0))
    s << "jump_min must be >= 0 m, got " << jump_min;
  else if (!(std::isfinite(jump_ratio) && jump_ratio >= 0.0))
    s << "jump_ratio must be >= 0, got " << jump_ratio;
  else if (jump_min == 0.0 && jump_ratio == 0.0)
    s << "jump_min and jump_ratio are both 0: every pair of returns would be a jump";
  else if (min_points < 2)
    s << "min_points must be >= 2, got " << min_points;
  else if (!(std::isfinite(veil_angle_deg) && veil_angle_deg >= 0.0 && veil_angle_deg < 45.0))
    s << "veil_angle_deg must be in [0, 45), got " << veil_angle_deg;
  else if (veil_max_beams < 1)
    s << "veil_max_beams must be >= 1, got " << veil_max_beams;
  return s.str();
}

std::string ScanLimits::validate() const {
  if (!(max_ranges >= 2 && max_ranges <= 1000000)) return "max_ranges must be in [2, 1000000], got " + std::to_string(max_ranges);
  if (!(max_duration > 0.0 && max_duration <= 10.0))
    return "max_scan_duration must be in (0, 10] s, got " + std::to_string(max_duration);
  return std::string();
}

ScanError checkScan(const ScanView& scan, const ScanLimits& limits) {
  if (scan.size == 0 || scan.ranges == nullptr) return ScanError::Empty;
  if (scan.size > limits.max_ranges) return ScanError::TooManyRanges;
  if (scan.intensities_size != 0 && scan.intensities_size != scan.size) return ScanError::IntensitySize;
  // A negative increment is a laser mounted upside down: beam i is still at
  // angle_min + i * increment (as laser_geometry projects it).
  if (!std::isfinite(scan.angle_increment) || !(std::abs(scan.angle_increment) > 0.0)) return ScanError::BadIncrement;
  if (!std::isfinite(scan.angle_min) || !std::isfinite(scan.angle_max)) return ScanError::InconsistentAngles;
  // angle_max as drivers publish it: one increment off, or rounded (it is not used).
  const double expected_max = scan.angle_min + static_cast<double>(scan.size - 1) * scan.angle_increment;
  if (std::abs(expected_max - scan.angle_max) > std::abs(scan.angle_increment) + 1e-6)
    return ScanError::InconsistentAngles;
  if (!std::isfinite(scan.range_min) || std::isnan(scan.range_max) || !(scan.range_max > scan.range_min))
    return ScanError::BadRangeLimits;
  const double duration = static_cast<double>(scan.size - 1) * scan.time_increment;
  if (!std::isfinite(scan.time_increment) || scan.time_increment < 0.0 || !(duration <= limits.max_duration) ||
      !std::isfinite(scan.scan_time) || scan.scan_time < 0.0 || scan.scan_time > limits.max_duration)
    return ScanError::BadTimeIncrement;
  return ScanError::None;
}

ScanSplitter::ScanSplitter(const SplitParams& params) { setParams(params); }

void ScanSplitter::setParams(const SplitParams& params) {
  params_ = params;
  cos_veil_ = std::cos(params_.veil_angle_deg * M_PI / 180.0);
}

void ScanSplitter::updateTrig(const ScanView& scan) {
  if (cos_.size() == scan.size && trig_angle_min_ == scan.angle_min && trig_increment_ == scan.angle_increment)
    return;
  cos_.resize(scan.size);
  sin_.resize(scan.size);
  for (std::size_t i = 0; i < scan.size; ++i) {
    const double a = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    cos_[i] = std::cos(a);
    sin_[i] = std::sin(a);
  }
  trig_angle_min_ = scan.angle_min;
  trig_increment_ = scan.angle_increment;
}

ScanError ScanSplitter::split(const ScanView& scan, SplitResult& out) {
  out.segments.clear();
  out.edges.clear();
  out.valid_points = 0;
  const ScanError err = checkScan(scan, limits_);
  if (err != ScanError::None) return err;

  const int n = static_cast<int>(scan.size);
  updateTrig(scan);
  x_.resize(n);
  y_.resize(n);
  r_.resize(n);
  valid_.resize(n);
  // Points, and prefix sums of their moments: the moments of any run of beams in O(1).
  prefix_.resize(n + 1);
  Moments2 sum;  // running sums kept in registers
  prefix_[0] = sum;
  for (int i = 0; i < n; ++i) {
    const double r = scan.ranges[i];
    const bool ok = std::isfinite(r) && r >= scan.range_min && r <= scan.range_max;
    valid_[i] = ok;
    r_[i] = ok ? r : 0.0;
    x_[i] = ok ? r * cos_[i] : 0.0;
    y_[i] = ok ? r * sin_[i] : 0.0;
    if (ok) sum.add(x_[i], y_[i]);
    prefix_[i + 1] = sum;
  }
  out.valid_points = static_cast<int>(sum.n);
  out.veil_points = 0;
  if (params_.veil_angle_deg > 0.0) markVeils(n, out);

  // Runs of valid returns without depth jumps (a veil ends a run as a jump does).
  runs_.clear();
  int start = -1;
  EdgeKind start_kind = EdgeKind::Boundary;
  EdgeKind after_veil = EdgeKind::Boundary;  // the kind the run after a veil starts with
  for (int i = 0; i <= n; ++i) {
    const bool ok = i < n && valid_[i];
    if (start >= 0) {
      bool ends = !ok;
      EdgeKind end_kind = EdgeKind::Boundary;
      EdgeKind next_start = EdgeKind::Boundary;
      if (ok && std::abs(r_[i] - r_[i - 1]) > params_.jumpThreshold(std::min(r_[i], r_[i - 1]))) {
        ends = true;
        const bool prev_near = r_[i - 1] < r_[i];
        end_kind = prev_near ? EdgeKind::Jump : EdgeKind::Occluded;
        next_start = prev_near ? EdgeKind::Occluded : EdgeKind::Jump;
      } else if (!ok && i < n && r_[i] > 0.0) {  // a veil: a depth jump spread over its beams
        int k = i;
        while (k < n && !valid_[k] && r_[k] > 0.0) ++k;
        if (k < n && valid_[k]) {
          const bool prev_near = r_[i - 1] < r_[k];
          end_kind = prev_near ? EdgeKind::Jump : EdgeKind::Occluded;
          after_veil = prev_near ? EdgeKind::Occluded : EdgeKind::Jump;
        }
      }
      if (ends) {
        runs_.push_back(Run{start, i - 1, start_kind, end_kind});
        start = ok ? i : -1;
        start_kind = next_start;
      }
    } else if (ok) {
      start = i;
      start_kind = i > 0 && !valid_[i - 1] && r_[i - 1] > 0.0 ? after_veil : EdgeKind::Boundary;
      after_veil = EdgeKind::Boundary;
    }
  }
  for (const Run& run : runs_)
    if (run.last - run.first + 1 >= params_.min_points) splitRun(run, out);
  if (out.veil_points > 0)  // veil marks were added apart from the runs' edges: back into beam order
    std::stable_sort(out.edges.begin(), out.edges.end(),
                     [](const EdgePoint& a, const EdgePoint& b) { return a.index < b.index; });
  return ScanError::None;
}

void ScanSplitter::markVeils(int n, SplitResult& out) {
  // Beam i is a veil point when the steps to both neighbours run along its
  // ray, one outwards and one inwards: |dr| > cot(angle) * lateral step,
  // where a neighbour's distance from i's ray is its range * sin(increment).
  const double c = std::abs(std::sin(trig_increment_)) / std::tan(params_.veil_angle_deg * M_PI / 180.0);
  const auto along = [&](int i, int j) { return std::abs(r_[j] - r_[i]) > c * r_[j]; };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  int i = 1;
  while (i + 1 < n) {
    const auto veil = [&](int k) {
      return k > 0 && k + 1 < n && valid_[k - 1] && valid_[k] && valid_[k + 1] && along(k, k - 1) &&
             along(k, k + 1) && (r_[k - 1] - r_[k]) * (r_[k + 1] - r_[k]) < 0.0;
    };
    if (!veil(i)) {
      ++i;
      continue;
    }
    int j = i;
    while (veil(j + 1)) ++j;
    // Range noise breaks a surface seen near the veil angle into short runs:
    // one step falls short of the angle by chance, and both beams beside it
    // fail the test. The next run is part of this one when no more beams
    // than a veil may hold lie between them, the ranges go on the same way
    // step by step (a repeated range, a reading that did not change, is no
    // such step), and the range from this run's end to that run's start
    // falls short of the angle's by no more than a difference of two ranges'
    // noise (sqrt(2) d_T: the split's threshold is the significance level's
    // sigmas of range noise). Only the run's length is judged so; the beams
    // marked are those that pass the test themselves.
    const bool outwards = r_[j + 1] > r_[j];
    const auto onward = [&](int k) {
      return valid_[k] && valid_[k + 1] && (outwards ? r_[k + 1] > r_[k] : r_[k + 1] < r_[k]);
    };
    int last = j;  // the run's last veil beam, with the runs it took in
    for (int m = j + 1; m + 1 < n && m - last <= params_.veil_max_beams + 1 && onward(m - 1); ++m) {
      if (!veil(m)) continue;
      const double fell = outwards ? r_[m] - r_[last] : r_[last] - r_[m];
      if (fell < c * r_[m] * (m - last) - std::sqrt(2.0) * params_.threshold(r_[m])) break;
      last = m;
    }
    if (last - i + 1 <= params_.veil_max_beams) {
      const std::size_t from = out.edges.size();
      for (int k = i; k <= last; ++k)
        if (veil(k)) out.edges.push_back(EdgePoint{k, EdgeKind::Veil, nan, Eigen::Vector2d(x_[k], y_[k])});
      // After the run's test, which looks at each beam's neighbours.
      for (std::size_t e = from; e < out.edges.size(); ++e) valid_[out.edges[e].index] = 0;
      out.veil_points += static_cast<int>(out.edges.size() - from);
    }
    i = last + 1;
  }
}

void ScanSplitter::splitRun(const Run& run, SplitResult& out) {
  // Recursive farthest-point split with an explicit stack, left half first,
  // so that pieces come out in beam order.
  pieces_.clear();
  stack_.clear();
  stack_.emplace_back(run.first, run.last);
  while (!stack_.empty()) {
    const auto [a, b] = stack_.back();
    stack_.pop_back();
    int k = -1;
    double dmax = 0.0;
    if (b - a >= 2) {
      // Farthest point from the chord: largest |cross product|, one division at the end.
      const double ax = x_[a], ay = y_[a];
      const double dx = x_[b] - ax, dy = y_[b] - ay;
      const double len = std::sqrt(dx * dx + dy * dy);
      double cmax = -1.0;
      for (int i = a + 1; i < b; ++i) {
        const double c = std::abs((x_[i] - ax) * dy - (y_[i] - ay) * dx);
        if (c > cmax) {
          cmax = c;
          k = i;
        }
      }
      dmax = len > 0.0 ? cmax / len : std::hypot(x_[k] - ax, y_[k] - ay);
    }
    if (k >= 0 && dmax > params_.threshold(r_[k])) {
      stack_.emplace_back(k + 1, b);
      stack_.emplace_back(a, k);
    } else {
      pieces_.emplace_back(a, b);
    }
  }

  // Merge neighbouring pieces whose union lies within d_T of its least-squares
  // line: the chord test above splits on noisy end points, the fitted line does not.
  if (params_.merge) {
    std::size_t w = 0;
    for (std::size_t i = 1; i < pieces_.size(); ++i) {
      if (mergeable(pieces_[w].first, pieces_[w].second, pieces_[i].second)) pieces_[w].second = pieces_[i].second;
      else pieces_[++w] = pieces_[i];
    }
    pieces_.resize(w + 1);
  }

  // The split point went to the left piece; give each boundary point to the
  // piece whose fitted line it is nearer to (the corner may lie on either side).
  for (std::size_t i = 1; i < pieces_.size(); ++i) {
    auto& p = pieces_[i - 1];
    auto& q = pieces_[i];
    if (p.second - p.first < 2 || q.second - q.first < 2) continue;
    const int k = p.second;
    if (lineDistance(q.first, q.second, k) < lineDistance(p.first, k - 1, k)) {
      --p.second;
      --q.first;
    } else if (lineDistance(p.first, p.second, q.first) < lineDistance(q.first + 1, q.second, q.first)) {
      ++p.second;
      ++q.first;
    }
  }

  // Where two pieces meet at a crease, a beam belongs to the surface its ray
  // meets: on the side of the corner's bearing that its own angle lies. The
  // corner is where the two fitted lines meet, which the points of both
  // pieces fix far better than range noise lets any one point beside it say
  // which surface it is on (the farthest point from the chord, where the
  // split cut, lies a beam or two either side of it). Each line is refitted
  // to its piece as the corner moves its end, until the corner stays (three
  // rounds at most). The corner moves the boundary only where the fits know
  // its bearing to a beam (a shallow crease, two lines offset by a step, meet
  // anywhere), where each piece keeps a segment's min_points, and where each
  // beam that changes sides lies within the split's threshold of its new line.
  struct Fit {
    LineFit line;
    double n, spread;  // points; their spread along the line, sum of s^2 [m^2]
  };
  const auto fitOf = [&](int first, int last) {  // the spread along: the whole spread less the rms across
    const Moments2 m = rangeMoments(first, last);
    const LineFit f = fitLine(m);
    return Fit{f, m.n, m.sxx + m.syy - (m.sx * m.sx + m.sy * m.sy) / m.n - m.n * f.rms * f.rms};
  };
  // A fit's offset error at `at` [m].
  const auto offsetSigma = [](const Fit& f, const Eigen::Vector2d& at) {
    const double s = f.line.direction.dot(at - f.line.centroid);
    return f.line.rms * std::sqrt(1.0 / f.n + s * s / std::max(f.spread, 1e-12));
  };
  for (std::size_t i = 1; i < pieces_.size(); ++i) {
    auto& p = pieces_[i - 1];
    auto& q = pieces_[i];
    const int lo = p.first + params_.min_points - 1;  // p keeps [p.first, lo] at least
    const int hi = q.second - params_.min_points;     // q keeps [hi + 1, q.second]
    if (lo > p.second || hi + 1 < q.first) continue;
    for (int round = 0; round < 3; ++round) {
      const Fit fa = fitOf(p.first, p.second), fb = fitOf(q.first, q.second);
      const LineFit &a = fa.line, &b = fb.line;
      const Eigen::Vector2d nb(-b.direction.y(), b.direction.x());
      const double sin_ab = std::abs(a.direction.dot(nb));  // of the angle between the lines
      if (!(sin_ab > 1e-6)) break;
      const Eigen::Vector2d c = a.centroid + nb.dot(b.centroid - a.centroid) / a.direction.dot(nb) * a.direction;
      const double range = c.norm();
      if (!(range > 0.0)) break;
      // The bearing's uncertainty: an offset error of one line moves the
      // corner along the other, and across its ray by as much as the other
      // line runs across it.
      const Eigen::Vector2d across(-c.y() / range, c.x() / range);
      const double ea = offsetSigma(fa, c) * b.direction.dot(across) / sin_ab;
      const double eb = offsetSigma(fb, c) * a.direction.dot(across) / sin_ab;
      if (std::hypot(ea, eb) > range * std::abs(trig_increment_)) break;
      const double f = (std::atan2(c.y(), c.x()) - trig_angle_min_) / trig_increment_;
      if (!(f >= lo && f < hi + 1)) break;
      const int last = static_cast<int>(std::floor(f));
      if (last == p.second) break;
      const LineFit& to = last < p.second ? b : a;
      const Eigen::Vector2d normal(-to.direction.y(), to.direction.x());
      bool near = true;
      for (int k = std::min(last, p.second) + 1; k <= std::max(last, p.second) && near; ++k)
        near = !valid_[k] ||
               std::abs(normal.dot(Eigen::Vector2d(x_[k], y_[k]) - to.centroid)) <= params_.threshold(r_[k]);
      if (!near) break;
      p.second = last;
      q.first = last + 1;
    }
  }

  // A short piece along its own ray is a veil the per-beam test let through
  // (a step just short of its angle, a footprint's blend of the two sides):
  // the same rule as markVeils' at the scale of a piece. Its beams are veil
  // points, and the pieces beside it meet at a depth edge, not a crease.
  // A veil holds no more beams than the footprint spans (veil_max_beams),
  // however markVeils' per-beam test and this one share them: a piece whose
  // ranges go on, the same way, into veil beams beside it is, with them, a
  // surface near the veil angle when they are more than that (a sloping top
  // seen at grazing incidence, its far beams' steps past the angle, its near
  // ones' short of it now and then by the noise).
  const int n = static_cast<int>(r_.size());
  const auto veilBeside = [&](int a, int b) {
    const bool outwards = r_[b] > r_[a];
    const auto onward = [&](int from, int to) { return outwards ? r_[to] > r_[from] : r_[to] < r_[from]; };
    int count = 0;
    for (int k = b + 1; k < n && !valid_[k] && r_[k] > 0.0 && onward(k - 1, k); ++k) ++count;
    for (int k = a - 1; k >= 0 && !valid_[k] && r_[k] > 0.0 && onward(k, k + 1); --k) ++count;
    return count;
  };
  const auto alongRay = [&](const Segment& g, int a, int b) {
    const Eigen::Vector2d mid = 0.5 * (g.start + g.end);
    return params_.veil_angle_deg > 0.0 && g.count <= params_.veil_max_beams && mid.norm() > 0.0 &&
           std::abs(g.direction.dot(mid.normalized())) >= cos_veil_ &&
           g.count + veilBeside(a, b) <= params_.veil_max_beams;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::size_t first_seg = out.segments.size();
  veil_before_.clear();  // per kept segment: the beams [k, first) before it were a veil (k; -1: none)
  int veil_from = -1, veil_to = -1;
  for (const auto& [a, b] : pieces_) {
    if (b - a + 1 < params_.min_points) continue;
    out.segments.emplace_back();
    fitSegment(a, b, out.segments.back());
    if (alongRay(out.segments.back(), a, b)) {
      out.segments.pop_back();
      for (int k = a; k <= b; ++k) {
        out.edges.push_back(EdgePoint{k, EdgeKind::Veil, nan, Eigen::Vector2d(x_[k], y_[k])});
        ++out.veil_points;
      }
      if (veil_from < 0) veil_from = a;
      veil_to = b;
      continue;
    }
    veil_before_.push_back(veil_from);
    veil_from = -1;
  }
  const std::size_t end_seg = out.segments.size();
  if (first_seg == end_seg) return;

  // The kind of the edge on a's side of a veil whose other side is at range r_other.
  const auto besideVeil = [&](int a, double r_other) { return r_[a] < r_other ? EdgeKind::Jump : EdgeKind::Occluded; };
  const Segment& head = out.segments[first_seg];
  const int v0 = veil_before_[0];
  out.edges.push_back(EdgePoint{head.first, v0 < 0 ? run.start_kind : besideVeil(head.first, r_[v0]), nan, head.start});
  for (std::size_t s = first_seg + 1; s < end_seg; ++s) {
    const Segment& p = out.segments[s - 1];
    const Segment& q = out.segments[s];
    if (veil_before_[s - first_seg] >= 0) {
      out.edges.push_back(EdgePoint{p.last, besideVeil(p.last, r_[q.first]), nan, p.end});
      out.edges.push_back(EdgePoint{q.first, besideVeil(q.first, r_[p.last]), nan, q.start});
      continue;
    }
    const double angle = std::acos(std::clamp(p.direction.dot(q.direction), -1.0, 1.0));
    if (q.first == p.last + 1) {
      out.edges.push_back(EdgePoint{p.last, EdgeKind::Crease, angle, creasePoint(p, q)});
    } else {  // points between them were too few for a segment: an edge on either side
      out.edges.push_back(EdgePoint{p.last, EdgeKind::Crease, angle, p.end});
      out.edges.push_back(EdgePoint{q.first, EdgeKind::Crease, angle, q.start});
    }
  }
  const Segment& tail = out.segments[end_seg - 1];
  out.edges.push_back(
      EdgePoint{tail.last, veil_from < 0 ? run.end_kind : besideVeil(tail.last, r_[veil_to]), nan, tail.end});
}

double segmentOverhang(const ScanView& scan, const Segment& seg) {
  const double length = (seg.end - seg.start).norm();
  double over = 0.0;
  for (int i = seg.first; i <= seg.last; ++i) {
    const double r = scan.ranges[i];
    if (!(std::isfinite(r) && r >= scan.range_min && r <= scan.range_max)) continue;
    const double a = scan.angle_min + i * scan.angle_increment;
    const double u = seg.direction.dot(Eigen::Vector2d(r * std::cos(a), r * std::sin(a)) - seg.start);
    over = std::max({over, -u, u - length});
  }
  return over;
}

double segmentBeamAngle(const Segment& seg) {
  const Eigen::Vector2d mid = 0.5 * (seg.start + seg.end);
  const double n = mid.norm();
  if (!(n > 0.0)) return 0.0;
  return std::acos(std::min(1.0, std::abs(seg.direction.dot(mid / n))));
}

Moments2 ScanSplitter::rangeMoments(int first, int last) const {
  const Moments2& a = prefix_[first];
  const Moments2& b = prefix_[last + 1];
  return Moments2{b.n - a.n, b.sx - a.sx, b.sy - a.sy, b.sxx - a.sxx, b.sxy - a.sxy, b.syy - a.syy};
}

double ScanSplitter::lineDistance(int first, int last, int i) const {
  const LineFit fit = fitLine(rangeMoments(first, last));
  const Eigen::Vector2d normal(-fit.direction.y(), fit.direction.x());
  return std::abs(normal.dot(Eigen::Vector2d(x_[i], y_[i]) - fit.centroid));
}

bool ScanSplitter::piecesMeet(int first, int split, int last) const {
  // A run that steps onto a surface a little behind the first (two blocks'
  // fronts) leaves the shorter piece off the longer's line, though a line
  // through both may pass within d_T of every point (onOneLine). Pieces of
  // fewer than three points are not judged so.
  Moments2 ml = rangeMoments(first, split), ms = rangeMoments(split + 1, last);
  if (ml.n < 3.0 || ms.n < 3.0) return true;
  if (ms.n > ml.n) std::swap(ml, ms);
  const LineFit f = fitLine(ml);
  const Eigen::Vector2d& d = f.direction;
  const Eigen::Vector2d c(ms.sx / ms.n, ms.sy / ms.n);
  const double cx = ml.sx / ml.n, cy = ml.sy / ml.n;
  const double along = (ml.sxx - ml.n * cx * cx) * d.x() * d.x() + 2.0 * (ml.sxy - ml.n * cx * cy) * d.x() * d.y() +
                       (ml.syy - ml.n * cy * cy) * d.y() * d.y();
  return onOneLine(Eigen::Vector2d(-d.y(), d.x()).dot(c - f.centroid), d.dot(c - f.centroid), ml.n, along, ms.n,
                   params_.threshold(c.norm()));
}

bool ScanSplitter::withinTolerance(int first, int last) const {
  const LineFit fit = fitLine(rangeMoments(first, last));
  const Eigen::Vector2d normal(-fit.direction.y(), fit.direction.x());
  for (int i = first; i <= last; ++i) {
    const double d = std::abs(normal.dot(Eigen::Vector2d(x_[i], y_[i]) - fit.centroid));
    if (d > params_.threshold(r_[i])) return false;
  }
  return true;
}

bool ScanSplitter::mergeable(int first, int split, int last) const {
  if (!withinTolerance(first, last)) return false;
  if (!piecesMeet(first, split, last)) return false;
  // A scan line crosses a surface in beam order: the second piece must not
  // fold back over the first along the union's line (returns that go out
  // and come back along nearly one line fit it as well as a surface does).
  const LineFit fit = fitLine(rangeMoments(first, last));
  Eigen::Vector2d d = fit.direction;
  if (d.dot(Eigen::Vector2d(x_[last] - x_[first], y_[last] - y_[first])) < 0.0) d = -d;
  double reach = -std::numeric_limits<double>::infinity();
  for (int i = first; i <= split; ++i) reach = std::max(reach, d.dot(Eigen::Vector2d(x_[i], y_[i])));
  for (int i = split + 1; i <= last; ++i)
    if (reach - d.dot(Eigen::Vector2d(x_[i], y_[i])) > params_.threshold(r_[i])) return false;
  return true;
}

Eigen::Vector2d ScanSplitter::creasePoint(const Segment& p, const Segment& q) {
  // Where the two fitted lines meet, if they meet between the two end points;
  // otherwise (nearly parallel lines) the end of the first segment.
  const double den = p.direction.x() * q.direction.y() - p.direction.y() * q.direction.x();
  const Eigen::Vector2d gap = q.start - p.end;
  if (std::abs(den) > 1e-3) {
    const Eigen::Vector2d w = q.start - p.start;
    const double s = (w.x() * q.direction.y() - w.y() * q.direction.x()) / den;
    const Eigen::Vector2d c = p.start + s * p.direction;
    const double reach = gap.norm() + (p.end - p.start).norm() * 0.05;
    if ((c - p.end).norm() <= reach && (c - q.start).norm() <= reach) return c;
  }
  return p.end;
}

void ScanSplitter::fitSegment(int first, int last, Segment& seg) const {
  seg.first = first;
  seg.last = last;
  seg.moments = rangeMoments(first, last);
  seg.count = last - first + 1;
  const LineFit fit = fitLine(seg.moments);
  const Eigen::Vector2d p0(x_[first], y_[first]), p1(x_[last], y_[last]);
  Eigen::Vector2d d = fit.direction;
  if (d.dot(p1 - p0) < 0.0) d = -d;
  seg.direction = d;
  // The ends span every point of the segment (noise along a steep segment
  // may put a point before the first or past the last).
  double lo = d.dot(p0 - fit.centroid), hi = d.dot(p1 - fit.centroid);
  for (int i = first + 1; i < last; ++i) {
    const double u = d.dot(Eigen::Vector2d(x_[i], y_[i]) - fit.centroid);
    lo = std::min(lo, u);
    hi = std::max(hi, u);
  }
  seg.start = fit.centroid + d * lo;
  seg.end = fit.centroid + d * hi;
  seg.rms = fit.rms;
}

}  // namespace core
}  // namespace tilt_laser_perception
