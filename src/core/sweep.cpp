#include "tilt_laser_perception/core/sweep.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace tilt_laser_perception {
namespace core {

namespace {
double cpuNow() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
}  // namespace

std::string SweepParams::validate() const {
  const auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v > lo && v <= hi; };
  if (!in(reversal_hysteresis, 0.0, 1.0)) return "reversal_hysteresis must be in (0, 1] rad";
  if (!in(max_joint_gap, 0.0, 10.0)) return "max_joint_gap must be in (0, 10] s";
  if (!(std::isfinite(max_wait) && max_wait >= 0.0 && max_wait <= 10.0)) return "max_wait must be in [0, 10] s";
  if (!in(max_dropped_fraction, -1e-12, 1.0)) return "max_dropped_fraction must be in [0, 1]";
  if (!(min_lines >= 1 && max_lines >= min_lines)) return "need 1 <= min_sweep_lines <= max_sweep_lines";
  if (!in(time_jump_back, 0.0, 1e6)) return "time_jump_back must be > 0 s";
  if (!(std::isfinite(spin_span) && spin_span >= 0.0 && spin_span <= 2.0 * M_PI + 1e-9))
    return "spin_span must be 0 (nodding) or in (0, 2 pi] rad";
  const std::string limits = scan_limits.validate();
  return limits.empty() ? grouping.validate() : limits;
}

bool JointBuffer::add(double t, double q) {
  if (!samples_.empty() && t <= samples_.back().first) return false;
  samples_.emplace_back(t, q);
  while (samples_.size() > 2 && samples_.front().first < t - keep_) samples_.pop_front();
  return true;
}

bool JointBuffer::sample(double t0, double dt, std::size_t n, std::vector<double>& q) const {
  q.resize(n);
  if (samples_.empty() || t0 < samples_.front().first || t0 + (n - 1) * dt > samples_.back().first) return false;
  auto it = std::lower_bound(samples_.begin(), samples_.end(), t0,
                             [](const std::pair<double, double>& s, double v) { return s.first < v; });
  if (it == samples_.begin()) ++it;  // t0 is the first sample: interpolate on the first interval
  // One interval [a, b] at a time: its beams lie on one straight ramp.
  std::size_t i = 0;
  while (i < n) {
    if (it == samples_.end()) return false;
    const auto& b = *it;
    const auto& a = *(it - 1);
    ++it;
    const double t = t0 + i * dt;
    if (b.first < t) continue;
    if (b.first - a.first > max_gap_) return false;
    const double slope = (b.second - a.second) / (b.first - a.first);
    // Beams up to b's time, compared as at() would (a count from a division
    // could round a beam at b's own time out of the last interval).
    for (; i < n; ++i) {
      const double ti = t0 + i * dt;
      if (ti > b.first) break;
      q[i] = a.second + (ti - a.first) * slope;
    }
  }
  return true;
}

bool JointBuffer::at(double t, double& q) const {
  if (samples_.empty() || t < samples_.front().first || t > samples_.back().first) return false;
  auto it = std::lower_bound(samples_.begin(), samples_.end(), t,
                             [](const std::pair<double, double>& s, double v) { return s.first < v; });
  if (it->first == t) {
    q = it->second;
    return true;
  }
  const auto& b = *it;
  const auto& a = *(it - 1);
  if (b.first - a.first > max_gap_) return false;
  q = a.second + (t - a.first) / (b.first - a.first) * (b.second - a.second);
  return true;
}

namespace {
/// The grouping of a sweep: a spinning head's half or whole turn ends in the
/// plane it began in, its last line beside its first.
GroupingParams sweepGrouping(const SweepParams& p, const TiltChain& chain) {
  GroupingParams g = p.grouping;
  g.cyclic_lines = p.spin_span > 0.0 && std::abs(std::remainder(p.spin_span, M_PI)) < 1e-6;
  // The laser's distance from the axis it turns about.
  const Eigen::Vector3d t = chain.joint_to_laser.translation(), a = chain.axis.normalized();
  g.arm = (t - t.dot(a) * a).norm();
  return g;
}
}  // namespace

SweepAssembler::SweepAssembler(const SweepParams& params, const TiltChain& chain, BasePose base_pose)
    : p_(params), chain_(chain), base_pose_(std::move(base_pose)), joints_(params.max_joint_gap),
      grouper_(sweepGrouping(params, chain)) {}

void SweepAssembler::setParams(const SweepParams& p) {
  p_ = p;
  joints_ = JointBuffer(p.max_joint_gap);
  grouper_.setParams(sweepGrouping(p_, chain_));
}

void SweepAssembler::setGroupingParams(const GroupingParams& g) { next_grouping_ = g; }

void SweepAssembler::restart() {
  joints_ = JointBuffer(p_.max_joint_gap);
  queue_.clear();
  reversals_.clear();
  direction_ = 0;
  have_extreme_ = false;
  last_mid_ = last_joint_t_ = last_line_stamp_ = last_line_added_ = first_start_ = -1e300;
  n_intervals_ = 0;
  joint_jump_ = line_jump_ = std::numeric_limits<double>::quiet_NaN();
  in_sweep_ = false;
  current_ = SweepResult();
  ++counters_.time_jumps;
  warning_ = "time jumped back (a recording looped or restarted): the sweep in progress is dropped, starting again";
}

SweepAssembler::Jump SweepAssembler::jumpBack(double t, double latest, double& suspect) const {
  if (!(t < latest - p_.time_jump_back)) {
    suspect = std::numeric_limits<double>::quiet_NaN();
    return Jump::None;
  }
  // One stamp far back may be a bad message; two in order, near each other, are a new clock.
  if (std::isnan(suspect) || !(t > suspect && t - suspect < p_.time_jump_back)) {
    suspect = t;
    return Jump::Suspect;
  }
  suspect = std::numeric_limits<double>::quiet_NaN();
  return Jump::Restart;
}

void SweepAssembler::addJoint(double t, double q) {
  if (!std::isfinite(t) || !std::isfinite(q)) {
    ++counters_.joints_bad;
    warning_ = "joint state with a time or angle that is not finite: dropped";
    return;
  }
  const Jump jump = jumpBack(t, last_joint_t_, joint_jump_);
  if (jump == Jump::Restart) restart();
  // A spinning joint's reading wraps (a servo's position within a turn):
  // unwrapped, it turns on (it moves less than half a turn between readings).
  const double raw = q;
  if (p_.spin_span > 0.0 && have_extreme_) q = last_q_ + std::remainder(raw - last_raw_q_, 2.0 * M_PI);
  if (jump == Jump::Suspect || !joints_.add(t, q)) {
    ++counters_.joints_out_of_order;
    warning_ = "joint state out of order: dropped";
    return;
  }
  if (p_.spin_span > 0.0) {
    if (have_extreme_) spinBoundaries(last_joint_t_, last_q_, t, q);
    have_extreme_ = true;
    last_joint_t_ = t;
    last_raw_q_ = raw;
    last_q_ = q;
    return;
  }
  last_joint_t_ = t;
  // Reversals: the joint came back from an extreme by more than the hysteresis.
  if (!have_extreme_) {
    have_extreme_ = true;
    extreme_q_ = q;
    extreme_t_ = t;
    return;
  }
  if (direction_ == 0) {
    if (std::abs(q - extreme_q_) > p_.reversal_hysteresis) {
      direction_ = q > extreme_q_ ? 1 : -1;
      extreme_q_ = q;
      extreme_t_ = t;
    }
    return;
  }
  if ((direction_ > 0 && q >= extreme_q_) || (direction_ < 0 && q <= extreme_q_)) {
    extreme_q_ = q;
    extreme_t_ = t;
  } else if (std::abs(q - extreme_q_) > p_.reversal_hysteresis) {
    reversals_.push_back(extreme_t_);
    ++counters_.reversals;
    direction_ = -direction_;
    extreme_q_ = q;
    extreme_t_ = t;
  }
}

void SweepAssembler::spinBoundaries(double t0, double q0, double t1, double q1) {
  // Either way round: the multiples of the span between q0 and q1, in the
  // order passed.
  const double k0 = std::floor(q0 / p_.spin_span), k1 = std::floor(q1 / p_.spin_span);
  if (k0 == k1 || q1 == q0) return;
  const double step = k1 > k0 ? 1.0 : -1.0;
  for (double k = k1 > k0 ? k0 + 1.0 : k0; k1 > k0 ? k <= k1 : k > k1; k += step) {
    const double at = k * p_.spin_span;
    reversals_.push_back(t0 + (t1 - t0) * (at - q0) / (q1 - q0));
    ++counters_.reversals;
  }
}

void SweepAssembler::addLine(LineInput line, double arrival) {
  ScanView v;
  v.ranges = line.ranges.data();
  v.size = line.ranges.size();
  v.intensities_size = line.intensities.size();
  v.angle_min = line.angle_min;
  v.angle_increment = line.angle_increment;
  v.angle_max = line.angle_min + (v.size == 0 ? 0.0 : static_cast<double>(v.size - 1) * line.angle_increment);
  v.range_min = line.range_min;
  v.range_max = line.range_max;
  v.time_increment = line.time_increment;
  const ScanError err = checkScan(v, p_.scan_limits);
  if (err != ScanError::None || v.size < 2 || !std::isfinite(line.stamp)) {
    ++counters_.lines_bad;
    warning_ = std::string("malformed scan line: dropped (") +
               (err != ScanError::None ? scanErrorName(err) : v.size < 2 ? "fewer than 2 ranges" : "stamp not finite") + ")";
    return;
  }
  const Jump jump = jumpBack(line.stamp, last_line_added_, line_jump_);
  if (jump == Jump::Suspect) {
    ++counters_.lines_out_of_order;
    warning_ = "scan line far before the latest: dropped (a second one in a row restarts)";
    return;
  }
  if (jump == Jump::Restart) restart();
  last_line_added_ = std::max(last_line_added_, line.stamp);
  queue_.emplace_back(std::move(line), arrival);
}

double SweepAssembler::linePeriod() const {
  if (n_intervals_ == 0) return 0.025;
  const int n = std::min<int>(n_intervals_, intervals_.size());
  std::array<double, 8> v = intervals_;
  std::nth_element(v.begin(), v.begin() + n / 2, v.begin() + n);
  return v[n / 2];
}

int SweepAssembler::missingBetween(double a, double b) const {
  const double period = linePeriod();
  if (!(period > 0.0) || !(b > a)) return 0;
  const double k = std::round((b - a) / period) - 1.0;
  return k > 0.0 ? static_cast<int>(std::min(k, 1e6)) : 0;
}

void SweepAssembler::beginSweep(double start) {
  if (next_grouping_) {
    p_.grouping = *next_grouping_;
    grouper_.setParams(sweepGrouping(p_, chain_));
    next_grouping_.reset();
  }
  in_sweep_ = true;
  sweep_last_mid_ = start - 0.5 * linePeriod();  // a line just before the start: the first one's middle is after it
  current_ = SweepResult();
  current_.id = next_id_;
  current_.start = start;
  // The grouper learns where the sensor is from the sweep's first line, whose
  // pose is known by then (at the reversal itself tf may not have arrived yet:
  // the sensor was taken at the frame's origin and a plane's normal could
  // point the other way than in a replay of the same data).
}

bool SweepAssembler::finishSweep(double end, SweepResult& out) {
  in_sweep_ = false;
  // Lines that never came before the end (the laser fell silent) count as dropped.
  current_.dropped_lines += missingBetween(sweep_last_mid_, end + 0.5 * linePeriod());
  const int n = static_cast<int>(current_.lines.size());
  const bool too_many_dropped = current_.dropped_lines > p_.max_dropped_fraction * (n + current_.dropped_lines);
  if (n < p_.min_lines || too_many_dropped) {
    ++counters_.sweeps_dropped;
    warning_ = "sweep dropped: " + std::to_string(n) + " lines, " + std::to_string(current_.dropped_lines) +
               " dropped (missing joint states, poses or out of order)";
    return false;
  }
  const double t0 = cpuNow();
  if (p_.reverse_lines) {
    // The lines last first, numbered so; their numbers given back after.
    for (int k = n - 1; k >= 0; --k) {
      for (Segment3& s : held_[k]) s.line = n - 1 - k;
      grouper_.addLine(held_[k]);
    }
    held_.clear();
    grouper_.finish(current_.planes, [this, n](int line) { return &current_.lines[n - 1 - line].points; });
  } else {
    grouper_.finish(current_.planes, [this](int line) { return &current_.lines[line].points; });
  }
  current_.finish_seconds = cpuNow() - t0;
  current_.grouping = grouper_.params();
  current_.segments = grouper_.segments();
  current_.segment_plane = grouper_.segmentPlane();
  if (p_.reverse_lines) {
    // Given back as a sweep's segments are: lines in order (each line's
    // segments came in beam order), the planes' members renumbered.
    const std::size_t count = current_.segments.size();
    std::vector<int> at(count);  // the new index of each segment
    for (std::size_t b = 0; b < count;) {  // the grouper's lines, last one first
      std::size_t e = b;
      while (e < count && current_.segments[e].line == current_.segments[b].line) ++e;
      for (std::size_t k = b; k < e; ++k) at[k] = static_cast<int>(count - e + (k - b));
      b = e;
    }
    std::vector<Segment3> segments(count);
    std::vector<int> segment_plane(count);
    for (std::size_t k = 0; k < count; ++k) {
      segments[at[k]] = std::move(current_.segments[k]);
      segments[at[k]].line = n - 1 - segments[at[k]].line;
      segment_plane[at[k]] = current_.segment_plane[k];
    }
    current_.segments = std::move(segments);
    current_.segment_plane = std::move(segment_plane);
    for (Plane& p : current_.planes) {
      for (int& m : p.members) m = at[m];
      std::sort(p.members.begin(), p.members.end());
      // The outline too: each line's entry, lines in order, then each exit
      // back (where it has one corner a line end), the holes the same way round.
      std::reverse(p.boundary.begin(), p.boundary.end());
      for (auto& h : p.holes) std::reverse(h.begin(), h.end());
      std::size_t lines = 0;
      for (std::size_t k = 0; k < p.members.size(); ++k)
        lines += k == 0 || current_.segments[p.members[k]].line != current_.segments[p.members[k - 1]].line;
      if (p.boundary.size() == 2 * lines)
        std::rotate(p.boundary.begin(), p.boundary.begin() + static_cast<std::ptrdiff_t>(lines), p.boundary.end());
    }
  }
  current_.end = end;
  out = std::move(current_);
  ++next_id_;
  ++counters_.sweeps;
  return true;
}

void SweepAssembler::takeLine(double mid, bool kept) {
  // Lines between the last one and this one that never came (an outage) are lost too.
  current_.dropped_lines += missingBetween(sweep_last_mid_, mid) + (kept ? 0 : 1);
  sweep_last_mid_ = mid;
}

SweepAssembler::PoseStatus SweepAssembler::lineMotion(const LineInput& in, double mid, LineMotion& motion) const {
  motion = LineMotion();
  if (!base_pose_) return PoseStatus::Ok;
  if (!p_.per_beam || in.ranges.size() < 2 || !(in.time_increment > 0.0)) return base_pose_(mid, motion.mid);
  // A walking robot's base moves some millimetres during a scan: the pose at
  // the first and the last beam, and every beam at its own time in between
  // (to first order: the change in 19 ms is a few millimetres and milliradians).
  Eigen::Isometry3d first = Eigen::Isometry3d::Identity(), last = Eigen::Isometry3d::Identity();
  const PoseStatus a = base_pose_(in.stamp, first);
  if (a == PoseStatus::Missing) return a;
  const PoseStatus b = base_pose_(in.stamp + (in.ranges.size() - 1) * in.time_increment, last);
  if (a != PoseStatus::Ok || b != PoseStatus::Ok) return b == PoseStatus::Missing ? b : PoseStatus::Wait;
  const Eigen::AngleAxisd turn(last.linear() * first.linear().transpose());
  motion.dp = last.translation() - first.translation();
  motion.dtheta = turn.angle() * turn.axis();
  motion.mid = first;
  motion.mid.translation() += 0.5 * motion.dp;
  motion.mid.linear() = Eigen::AngleAxisd(0.5 * turn.angle(), turn.axis()) * first.linear();
  return PoseStatus::Ok;
}

bool SweepAssembler::process(const LineInput& in, const LineMotion& motion) {
  const Eigen::Isometry3d& base = motion.mid;
  const double t0 = cpuNow();
  const std::size_t n = in.ranges.size();  // checked in addLine
  SweepLine line;
  line.stamp = in.stamp;
  line.time_increment = in.time_increment;
  line.points.resize(n);
  line.tilt.resize(n);
  line.intensities = in.intensities;
  line.edges = in.edges;
  // The joint angle of every beam (or one for the line at its stamp).
  if (p_.per_beam) {
    if (!joints_.sample(in.stamp, in.time_increment, n, q_)) {
      ++counters_.lines_no_joint;
      warning_ = "no joint state at a beam's time (gap or late): line dropped";
      return false;
    }
  } else {
    double q0 = 0.0;
    if (!joints_.at(in.stamp, q0)) {
      ++counters_.lines_no_joint;
      warning_ = "no joint state at the line's stamp: line dropped";
      return false;
    }
    q_.assign(n, q0);
  }
  const Eigen::Vector3d origin = transformBeams(in, motion, line);
  line.origin = origin.cast<float>();
  const int index = static_cast<int>(current_.lines.size());
  std::vector<Segment3> segs;
  segs.reserve(in.segments.size());
  for (const auto& [first, last] : in.segments) {
    if (first < 0 || last >= static_cast<int>(n) || last < first) continue;
    Segment3 s;
    if (!makeSegment3(line.points, in.ranges, index, first, last, s)) continue;
    s.origin = origin;
    segs.push_back(s);
  }
  if (current_.lines.empty()) {
    grouper_.reset((base * chain_.laserPose(0.0)).translation());
    held_.clear();
  }
  if (p_.reverse_lines) held_.push_back(std::move(segs));
  else grouper_.addLine(segs);
  current_.lines.push_back(std::move(line));
  current_.group_seconds += cpuNow() - t0;
  ++counters_.lines;
  return true;
}

Eigen::Vector3d SweepAssembler::transformBeams(const LineInput& in, const LineMotion& motion, SweepLine& line) {
  const std::size_t n = in.ranges.size();
  const Eigen::Isometry3d& base = motion.mid;
  // Beam directions in the joint frame, cached while the scan geometry stays the same.
  if (ux_.size() != n || trig_min_ != in.angle_min || trig_inc_ != in.angle_increment) {
    ux_.resize(n);
    uy_.resize(n);
    uz_.resize(n);
    const Eigen::Matrix3d JL = chain_.joint_to_laser.linear();
    for (std::size_t i = 0; i < n; ++i) {
      const double a = in.angle_min + i * in.angle_increment;
      const Eigen::Vector3d u = JL.col(0) * std::cos(a) + JL.col(1) * std::sin(a);
      ux_[i] = static_cast<float>(u.x());
      uy_[i] = static_cast<float>(u.y());
      uz_[i] = static_cast<float>(u.z());
    }
    trig_min_ = in.angle_min;
    trig_inc_ = in.angle_increment;
  }
  // p = O (R(axis, q) v) + o with v = r u + j (u the beam's direction, j the
  // laser's origin in the joint frame), O and o the joint's pose, and R by
  // Rodrigues' formula: O R v = c (O v) + s (O [k]x v) + (1 - c) (k . v) O k.
  const Eigen::Isometry3d joint_pose = base * chain_.base_to_joint;
  const Eigen::Vector3d k = chain_.axis;
  Eigen::Matrix3d K;
  K << 0, -k.z(), k.y(), k.z(), 0, -k.x(), -k.y(), k.x(), 0;
  const Eigen::Matrix3d A = joint_pose.linear(), B = A * K;
  const Eigen::Vector3d Ak = A * k, o = joint_pose.translation(), j = chain_.joint_to_laser.translation();

  // cos and sin of each beam's angle from those of the line's middle one:
  // q = qm + d, |d| the joint's travel in half a scan (milliradians), so
  // cos d and sin d by their Taylor series (to d^6 and d^7: within float's
  // precision for |d| < 0.5); exact ones where the joint went farther.
  const double qm = q_[n / 2], cm = std::cos(qm), sm = std::sin(qm);
  dq_.resize(n);
  c_.resize(n);
  s_.resize(n);
  double dmax = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    line.tilt[i] = static_cast<float>(q_[i]);
    const double d = q_[i] - qm;
    dq_[i] = static_cast<float>(d);
    dmax = std::max(dmax, std::abs(d));
  }
  if (dmax < 0.5) {
    const float fcm = static_cast<float>(cm), fsm = static_cast<float>(sm);
    const float* dq = dq_.data();
    float* c = c_.data();
    float* s = s_.data();
#pragma omp simd
    for (std::size_t i = 0; i < n; ++i) {
      const float d = dq[i], d2 = d * d;
      const float cd = 1.0f - d2 * (0.5f - d2 * (1.0f / 24.0f - d2 * (1.0f / 720.0f)));
      const float sd = d * (1.0f - d2 * (1.0f / 6.0f - d2 * (1.0f / 120.0f - d2 * (1.0f / 5040.0f))));
      c[i] = fcm * cd - fsm * sd;
      s[i] = fsm * cd + fcm * sd;
    }
  } else {
    for (std::size_t i = 0; i < n; ++i) {
      c_[i] = static_cast<float>(std::cos(q_[i]));
      s_[i] = static_cast<float>(std::sin(q_[i]));
    }
  }

  // The chain in float, one beam per SIMD lane (points are kept in float:
  // its rounding is microns at the sensor's 30 m).
  const auto f = [](double v) { return static_cast<float>(v); };
  const float a00 = f(A(0, 0)), a01 = f(A(0, 1)), a02 = f(A(0, 2)), a10 = f(A(1, 0)), a11 = f(A(1, 1)),
              a12 = f(A(1, 2)), a20 = f(A(2, 0)), a21 = f(A(2, 1)), a22 = f(A(2, 2));
  const float b00 = f(B(0, 0)), b01 = f(B(0, 1)), b02 = f(B(0, 2)), b10 = f(B(1, 0)), b11 = f(B(1, 1)),
              b12 = f(B(1, 2)), b20 = f(B(2, 0)), b21 = f(B(2, 1)), b22 = f(B(2, 2));
  const float kx = f(k.x()), ky = f(k.y()), kz = f(k.z()), akx = f(Ak.x()), aky = f(Ak.y()), akz = f(Ak.z());
  const float ox = f(o.x()), oy = f(o.y()), oz = f(o.z()), jx = f(j.x()), jy = f(j.y()), jz = f(j.z());
  px_.resize(n);
  py_.resize(n);
  pz_.resize(n);
  {
    const float *r = in.ranges.data(), *ux = ux_.data(), *uy = uy_.data(), *uz = uz_.data(), *c = c_.data(),
                *s = s_.data();
    float *px = px_.data(), *py = py_.data(), *pz = pz_.data();
#pragma omp simd
    for (std::size_t i = 0; i < n; ++i) {
      const float vx = r[i] * ux[i] + jx, vy = r[i] * uy[i] + jy, vz = r[i] * uz[i] + jz;
      const float kv = (1.0f - c[i]) * (kx * vx + ky * vy + kz * vz);
      px[i] = c[i] * (a00 * vx + a01 * vy + a02 * vz) + s[i] * (b00 * vx + b01 * vy + b02 * vz) + kv * akx + ox;
      py[i] = c[i] * (a10 * vx + a11 * vy + a12 * vz) + s[i] * (b10 * vx + b11 * vy + b12 * vz) + kv * aky + oy;
      pz[i] = c[i] * (a20 * vx + a21 * vy + a22 * vz) + s[i] * (b20 * vx + b21 * vy + b22 * vz) + kv * akz + oz;
    }
  }
  // The base's motion during the scan: beam i moved by f (dp + dtheta x (p - o)),
  // f its time from the middle beam as a fraction of the scan (first order).
  const Eigen::Vector3d o_laser = cm * (A * j) + sm * (B * j) + (1.0 - cm) * k.dot(j) * Ak + o;
  if (motion.moving()) {
    const float dpx = f(motion.dp.x()), dpy = f(motion.dp.y()), dpz = f(motion.dp.z()), wx = f(motion.dtheta.x()),
                wy = f(motion.dtheta.y()), wz = f(motion.dtheta.z()), cx = f(base.translation().x()),
                cy = f(base.translation().y()), cz = f(base.translation().z());
    const float step = 1.0f / static_cast<float>(n - 1), half = 0.5f * static_cast<float>(n - 1);
    float *px = px_.data(), *py = py_.data(), *pz = pz_.data();
#pragma omp simd
    for (std::size_t i = 0; i < n; ++i) {
      const float fr = (static_cast<float>(i) - half) * step;
      const float rx = px[i] - cx, ry = py[i] - cy, rz = pz[i] - cz;
      px[i] += fr * (dpx + wy * rz - wz * ry);
      py[i] += fr * (dpy + wz * rx - wx * rz);
      pz[i] += fr * (dpz + wx * ry - wy * rx);
    }
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  int first = static_cast<int>(n), last = -1;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = in.ranges[i];
    const bool valid = std::isfinite(r) && r >= in.range_min && r <= in.range_max;
    line.points[i] = valid ? Eigen::Vector3f(px_[i], py_[i], pz_[i]) : Eigen::Vector3f(nan, nan, nan);
    if (valid) {
      first = std::min(first, static_cast<int>(i));
      last = static_cast<int>(i);
    }
  }
  line.returns_begin = first;
  line.returns_end = last + 1;
  // The laser's origin (v = j) at the middle beam.
  return o_laser;
}

bool SweepAssembler::poll(double now, SweepResult& out) {
  waiting_ = Waiting::Nothing;
  while (!queue_.empty()) {
    const LineInput& in = queue_.front().first;
    const double last_beam = in.stamp + (in.ranges.empty() ? 0.0 : (in.ranges.size() - 1) * in.time_increment);
    const double mid = 0.5 * (in.stamp + last_beam);
    // A reversal before this line's middle ends the sweep in progress first.
    if (!reversals_.empty() && reversals_.front() <= mid) {
      const double r = reversals_.front();
      reversals_.pop_front();
      const bool had = in_sweep_;
      SweepResult done;
      const bool finished = had && finishSweep(r, done);
      beginSweep(r);
      if (finished) {
        out = std::move(done);
        return true;
      }
      continue;
    }
    if (joints_.latest() < last_beam) {
      if (now - queue_.front().second <= p_.max_wait) {
        waiting_ = Waiting::Joints;
        return false;
      }
      ++counters_.lines_no_joint;
      warning_ = "no joint states for a scan line within " + std::to_string(p_.max_wait).substr(0, 4) + " s: dropped";
      if (in_sweep_) takeLine(mid, false);
      queue_.pop_front();
      continue;
    }
    // A reversal is known only once the joint has come back from its extreme
    // by the hysteresis. While one that would end the sweep before this
    // line's middle may still come (the joint has turned at or before it),
    // the line waits for it, up to max_wait (a head that holds still there
    // is no reversal): otherwise when the line is put in 3D, before or after
    // the reversal is known, would decide its sweep (a replay differed from
    // the live run by the first line after a reversal).
    if (direction_ != 0 && extreme_t_ <= mid && last_joint_t_ > extreme_t_ &&
        now - queue_.front().second <= p_.max_wait) {
      waiting_ = Waiting::Joints;
      return false;
    }
    if (in.stamp > last_line_stamp_ && mid < first_start_) {
      // Before the first sweep began (its start known before this line came):
      // in no sweep, as the lines before it.
      last_line_stamp_ = in.stamp;
      ++counters_.lines_outside_sweeps;
      queue_.pop_front();
      continue;
    }
    if (in.stamp <= last_line_stamp_ || (in_sweep_ && mid < current_.start)) {
      // Out of order, or late for the sweep it belongs to (already finished): never mixed into the next.
      ++counters_.lines_out_of_order;
      warning_ = "scan line out of order or too late for its sweep: dropped";
      queue_.pop_front();
      continue;
    }
    LineMotion motion;
    const PoseStatus pose = lineMotion(in, mid, motion);
    if (pose == PoseStatus::Wait && now - queue_.front().second <= p_.max_wait) {
      waiting_ = Waiting::Pose;  // wait for tf
      return false;
    }
    if (last_line_stamp_ > -1e299) {
      intervals_[n_intervals_ % intervals_.size()] = in.stamp - last_line_stamp_;
      ++n_intervals_;
    }
    last_line_stamp_ = in.stamp;
    last_mid_ = mid;
    if (in_sweep_ && static_cast<int>(current_.lines.size()) >= p_.max_lines) {
      // No reversal for this long: the head stands still (servo off?). Drop
      // the sweep and wait for the next reversal rather than grow without bound.
      ++counters_.sweeps_dropped;
      warning_ = "sweep dropped: " + std::to_string(current_.lines.size()) +
                 " lines without a tilt reversal (is the head moving?)";
      in_sweep_ = false;
      current_ = SweepResult();
    }
    if (pose != PoseStatus::Ok) {
      ++counters_.lines_no_pose;
      warning_ = "no pose of the head at the scan's time (tf gap): line dropped";
      if (in_sweep_) takeLine(mid, false);
    } else if (in_sweep_) {
      takeLine(mid, process(in, motion));
    } else {
      ++counters_.lines_outside_sweeps;
    }
    queue_.pop_front();
  }
  // The next line's middle will be past a known reversal: every line of the
  // sweep is in, so finish now (the latency users feel).
  if (!reversals_.empty() && in_sweep_ && last_mid_ + linePeriod() > reversals_.front()) {
    const double r = reversals_.front();
    reversals_.pop_front();
    SweepResult done;
    const bool finished = finishSweep(r, done);
    beginSweep(r);
    if (finished) {
      out = std::move(done);
      return true;
    }
  } else if (!reversals_.empty() && !in_sweep_) {
    first_start_ = reversals_.front();
    beginSweep(reversals_.front());
    reversals_.pop_front();
  }
  // The joint has turned back from its extreme: the next joint states may
  // show the reversal that ends the sweep in progress.
  if (in_sweep_ && direction_ != 0 && last_joint_t_ > extreme_t_) waiting_ = Waiting::Joints;
  return false;
}

bool SweepAssembler::flush(double now, SweepResult& out) {
  if (poll(now + p_.max_wait + 1.0, out)) return true;
  if (!in_sweep_) return false;
  if (current_.lines.empty()) {  // the last reversal was the end: nothing after it
    in_sweep_ = false;
    return false;
  }
  return finishSweep(sweep_last_mid_ + 0.5 * linePeriod(), out);
}

Eigen::Vector3d meanOrigin(const SweepResult& sweep) {
  Eigen::Vector3d o = Eigen::Vector3d::Zero();
  for (const SweepLine& line : sweep.lines) o += line.origin.cast<double>();
  return sweep.lines.empty() ? o : Eigen::Vector3d(o / static_cast<double>(sweep.lines.size()));
}

double lastBeamTime(const SweepResult& sweep) {
  if (sweep.lines.empty()) return sweep.end;
  const SweepLine& l = sweep.lines.back();
  return l.stamp + (l.points.empty() ? 0.0 : (l.points.size() - 1) * l.time_increment);
}

void transformSweep(SweepResult& sw, const Eigen::Isometry3d& T) {
  const Eigen::Isometry3f Tf = T.cast<float>();
  for (SweepLine& line : sw.lines) {
    for (Eigen::Vector3f& p : line.points)
      if (p.allFinite()) p = Tf * p;
    line.origin = Tf * line.origin;
  }
  for (Segment3& s : sw.segments) {
    s.start = T * s.start;
    s.end = T * s.end;
    s.moments = s.moments.transformed(T);
    if (s.origin.allFinite()) s.origin = T * s.origin;
  }
  for (Plane& pl : sw.planes) {
    pl.fit.normal = T.linear() * pl.fit.normal;
    pl.fit.centroid = T * pl.fit.centroid;
    pl.fit.offset = pl.fit.normal.dot(pl.fit.centroid);
    for (Eigen::Vector3d& v : pl.boundary) v = T * v;
    for (auto& hole : pl.holes)
      for (Eigen::Vector3d& v : hole) v = T * v;
  }
}

}  // namespace core
}  // namespace tilt_laser_perception
