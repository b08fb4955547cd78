#include "tilt_laser_perception/scip/time_sync.hpp"

#include <algorithm>
#include <cmath>

namespace tilt_laser_perception {
namespace scip {

namespace {
/// Least-squares line y = a + b x (b = 0 when x does not vary).
template <typename Range, typename X, typename Y>
void fitLine(const Range& r, X x, Y y, double& a, double& b) {
  double n = 0, mx = 0, my = 0;
  for (const auto& e : r) {
    mx += x(e);
    my += y(e);
    ++n;
  }
  mx /= n;
  my /= n;
  double sxx = 0, sxy = 0;
  for (const auto& e : r) {
    sxx += (x(e) - mx) * (x(e) - mx);
    sxy += (x(e) - mx) * (y(e) - my);
  }
  b = sxx > 0 ? sxy / sxx : 0.0;
  a = my - b * mx;
}
}  // namespace

void ScanClock::reset() {
  scans_win_.clear();
  delayed_in_window_ = 0;
  clock_.clear();
  have_origin_ = have_scan_ = false;
  min_rtt_ = 1e9;
  host_per_rev_ = opt_.period_ms * 1e-3;
  g_stream_ = 0.0;
  since_fit_ = -1;
  offset_ = drift_ppm_ = latency_ = sensor_time_ = 0.0;
  scans_ = missed_ = 0;
}

double ScanClock::unwrap(std::uint32_t stamp24) {
  stamp24 &= 0xFFFFFF;
  if (!have_origin_) {
    have_origin_ = true;
    origin_ = stamp24;
    last24_ = stamp24;
    last_abs_ = 0.0;
    return 0.0;
  }
  // Signed difference modulo 2^24: readings are never 2.3 h apart.
  std::int32_t d = static_cast<std::int32_t>((stamp24 - last24_) & 0xFFFFFF);
  if (d >= 0x800000) d -= 0x1000000;
  last24_ = stamp24;
  last_abs_ += d;
  return last_abs_;
}

bool ScanClock::addClockSample(const TmSample& s) {
  // The reading happened somewhere in the round trip; only short ones locate it well.
  const double rtt = s.recv - s.send;
  if (!(rtt >= 0.0) || rtt > opt_.max_rtt) {
    ++rejected_;
    last_rejected_rtt_ = rtt;
    return false;
  }
  min_rtt_ = std::min(min_rtt_ * 1.001 + 1e-6, rtt);  // slowly forgets
  if (rtt > min_rtt_ + opt_.rtt_margin) {
    ++rejected_;
    last_rejected_rtt_ = rtt;
    return false;
  }
  const double mid = 0.5 * (s.send + s.recv);
  if (clock_.empty()) host0_ = mid;
  clock_.push_back(ClockSample{mid - host0_, unwrap(s.stamp) + 0.5});
  while (clock_.size() > 3 && clock_.back().h - clock_.front().h > opt_.clock_window) clock_.pop_front();
  return true;
}

bool ScanClock::calibrate(const std::vector<TmSample>& samples) {
  clock_.clear();
  for (const TmSample& s : samples) addClockSample(s);
  return calibrated();
}

bool ScanClock::fitClock(double& c, double& g) const {
  if (clock_.size() < 3) return false;
  c = 0.0;
  g = 1000.0;
  if (clock_.back().h - clock_.front().h < 2.0) {
    // A short span (the TM series alone): the offset only, at the nominal rate.
    double sum = 0.0;
    for (const ClockSample& e : clock_) sum += e.s - 1000.0 * e.h;
    c = sum / static_cast<double>(clock_.size());
    return true;
  }
  fitLine(clock_, [](const ClockSample& e) { return e.h; }, [](const ClockSample& e) { return e.s; }, c, g);
  if (!(g > 900.0 && g < 1100.0)) {  // nonsense: keep the offset at the nominal rate
    double sum = 0.0;
    for (const ClockSample& e : clock_) sum += e.s - 1000.0 * e.h;
    c = sum / static_cast<double>(clock_.size());
    g = 1000.0;
  }
  return true;
}

double ScanClock::stamp(std::uint32_t stamp24, double recv) {
  stamp24 &= 0xFFFFFF;
  if (have_scan_) {
    const std::uint32_t diff = (stamp24 - last_scan24_) & 0xFFFFFF;
    if (diff == 0 || diff > 10000) {
      // Backwards or a long jump: the sensor rebooted or we lost track. Start over.
      const unsigned long jumps = jumps_ + 1;
      reset();
      jumps_ = jumps;
    } else {
      const double steps = std::round(diff / opt_.period_ms);
      missed_ += steps > 1 ? static_cast<unsigned long>(steps - 1) : 0;
      last_k_ += std::max(1.0, steps);
    }
  }
  if (!have_scan_) {
    have_scan_ = true;
    last_k_ = 0.0;
  }
  last_scan24_ = stamp24;
  ++scans_;
  const double s_abs = unwrap(stamp24);
  scans_win_.push_back(ScanSample{last_k_, s_abs, recv});
  while (scans_win_.size() > 2 && recv - scans_win_.front().r > opt_.scan_window) {
    delayed_in_window_ -= scans_win_.front().delayed;
    scans_win_.pop_front();
  }

  // Sensor time of step 0: a line through (k, stamp + 0.5), narrowed to the
  // offsets every floor allows (floor <= a + p k < floor + 1).
  double a = s_abs + 0.5 - opt_.period_ms * last_k_, p = opt_.period_ms;
  // Between fits the last line, while the new stamp's floor allows it.
  const double predicted = fit_a_ + fit_p_ * last_k_;
  const bool refit = scans_win_.size() >= 8 &&
                     (since_fit_ < 0 || since_fit_ + 1 >= kRefitEvery || predicted < s_abs || predicted >= s_abs + 1.0);
  if (scans_win_.size() >= 8 && !refit) {
    a = fit_a_;
    p = fit_p_;
    ++since_fit_;
  } else if (refit) {
    fitLine(scans_win_, [](const ScanSample& e) { return e.k; }, [](const ScanSample& e) { return e.s + 0.5; }, a, p);
    // For a rate q, the offsets every floor allows are [lo(q), hi(q)]; its
    // width is concave in q. Take the rate that leaves the widest interval
    // (ternary search near the least-squares rate) and the interval's middle.
    const auto interval = [&](double q, double& lo, double& hi) {
      lo = -1e300;
      hi = 1e300;
      const double k0 = scans_win_.back().k;  // offsets at the newest scan: well conditioned
      for (const ScanSample& e : scans_win_) {
        lo = std::max(lo, e.s - q * (e.k - k0));
        hi = std::min(hi, e.s + 1.0 - q * (e.k - k0));
      }
    };
    double q_lo = p - 0.01, q_hi = p + 0.01, lo = 0, hi = 0;
    for (int it = 0; it < 40; ++it) {
      const double m1 = q_lo + (q_hi - q_lo) / 3.0, m2 = q_hi - (q_hi - q_lo) / 3.0;
      double l1, h1, l2, h2;
      interval(m1, l1, h1);
      interval(m2, l2, h2);
      if (h1 - l1 < h2 - l2) q_lo = m1;
      else q_hi = m2;
    }
    p = 0.5 * (q_lo + q_hi);
    interval(p, lo, hi);
    a = 0.5 * (lo + hi) - p * scans_win_.back().k;
    fit_a_ = a;
    fit_p_ = p;
    since_fit_ = 0;
  }
  const double sigma = a + p * last_k_;
  sensor_time_ = origin_ + sigma;

  // The clocks' rate ratio from the stream: sensor milliseconds per revolution
  // (above) over host seconds per revolution (the lower envelope of the
  // arrivals: the earliest in each run of 10 revolutions, jitter only delays).
  // While scans arrive late (a delayed reply within the window), the
  // arrivals tell nothing about the rate: the last rate found is kept.
  if (since_fit_ == 0 && delayed_in_window_ == 0 && scans_win_.size() >= 40 &&
      scans_win_.back().r - scans_win_.front().r >= 2.0) {
    std::vector<std::pair<double, double>> minima;  // (k, arrival)
    const double r0 = scans_win_.front().r;
    for (std::size_t start = 0; start < scans_win_.size(); start += 10) {
      const std::size_t end = std::min(scans_win_.size(), start + 10);
      std::size_t best = start;
      for (std::size_t i = start + 1; i < end; ++i)
        if (scans_win_[i].r - host_per_rev_ * scans_win_[i].k < scans_win_[best].r - host_per_rev_ * scans_win_[best].k)
          best = i;
      minima.emplace_back(scans_win_[best].k, scans_win_[best].r - r0);
    }
    double ia = 0.0, per_rev = 0.0;
    fitLine(minima, [](const std::pair<double, double>& e) { return e.first; },
            [](const std::pair<double, double>& e) { return e.second; }, ia, per_rev);
    if (per_rev > 0.5 * opt_.period_ms * 1e-3 && per_rev < 2.0 * opt_.period_ms * 1e-3) {
      host_per_rev_ = per_rev;
      g_stream_ = p / per_rev;  // sensor ms per host s
    }
  }
  const double g_stream = g_stream_;

  double host;
  double c = 0.0, g = 1000.0;
  if (g_stream > 900.0 && g_stream < 1100.0 && clock_.size() >= 3) {
    // The rate is known: every clock sample then measures the same offset.
    g = g_stream;
    double sum = 0.0;
    for (const ClockSample& e : clock_) sum += e.s - g * e.h;
    c = sum / static_cast<double>(clock_.size());
    host = host0_ + (sigma - c) / g;
    drift_ppm_ = (g / 1000.0 - 1.0) * 1e6;
  } else if (fitClock(c, g)) {
    host = host0_ + (sigma - c) / g;
    drift_ppm_ = (g / 1000.0 - 1.0) * 1e6;
  } else {
    host = recv - opt_.default_latency;
  }
  latency_ = recv - host;
  offset_ = host - sensor_time_ * 1e-3;
  // A delayed reply: this scan does not tell when scans arrive.
  if (latency_ > opt_.max_latency) {
    ++delayed_;
    scans_win_.back().delayed = true;
    ++delayed_in_window_;
  }
  if (latency_ < opt_.min_latency) ++impossible_;
  return host;
}

}  // namespace scip
}  // namespace tilt_laser_perception
