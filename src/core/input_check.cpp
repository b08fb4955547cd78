#include "tilt_laser_perception/core/input_check.hpp"

#include <algorithm>
#include <cmath>

namespace tilt_laser_perception {
namespace core {

const char* checkStamp(double stamp, double now, const StampLimits& limits) {
  if (!std::isfinite(stamp)) return "stamp not finite";
  if (stamp == 0.0) return "stamp zero (not set)";
  if (stamp < 0.0) return "stamp negative";
  if (now <= 0.0) return nullptr;
  if (limits.max_age > 0.0 && stamp < now - limits.max_age) return "stamp too old for the clock (a bag without --clock?)";
  if (limits.max_ahead > 0.0 && stamp > now + limits.max_ahead) return "stamp ahead of the clock";
  return nullptr;
}

const char* checkJointPosition(double q, bool continuous) {
  if (!std::isfinite(q)) return "joint position not finite";
  if (continuous) return std::abs(q) > kMaxContinuousJointAngle ? "continuous joint position beyond +-1e7 rad" : nullptr;
  if (std::abs(q) > kMaxJointAngle) return "joint position beyond +-2 pi";
  return nullptr;
}

WindowCounter::WindowCounter(double window)
    : window_(std::isfinite(window) && window >= 1.0 ? std::min(window, double(kBuckets - 1)) : 10.0) {}

void WindowCounter::advance(long second) const {
  if (head_ < 0 || second - head_ >= kBuckets) {
    buckets_.fill(0);
  } else {
    for (long s = head_ + 1; s <= second; ++s) buckets_[s % kBuckets] = 0;
  }
  head_ = second;
}

void WindowCounter::add(double now, unsigned long k) {
  total_ += k;
  last_ = now;
  if (!std::isfinite(now) || now < 0.0) return;
  const long s = static_cast<long>(now);
  if (s > head_) advance(s);
  if (head_ - s < kBuckets) buckets_[s % kBuckets] += k;  // a clock that went back counts in its own second
}

unsigned long WindowCounter::recent(double now) const {
  if (!std::isfinite(now) || now < 0.0) return 0;
  const long s = static_cast<long>(now);
  if (head_ < 0) return 0;
  if (s < head_) {  // the clock went back (a looping bag): what the buckets hold is from another time
    buckets_.fill(0);
    head_ = s;
    return 0;
  }
  advance(s);
  unsigned long n = 0;
  const long w = static_cast<long>(std::ceil(window_));
  for (long i = 0; i < w; ++i) n += buckets_[(s - i) % kBuckets];
  return n;
}

unsigned long ReasonCounts::add(const std::string& reason, double now, unsigned long k) {
  for (auto& [r, c] : counts_)
    if (r == reason) {
      c.add(now, k);
      return c.total();
    }
  counts_.emplace_back(reason, WindowCounter(window_));
  counts_.back().second.add(now, k);
  return k;
}

unsigned long ReasonCounts::recent(double now) const {
  unsigned long n = 0;
  for (const auto& rc : counts_) n += rc.second.recent(now);
  return n;
}

unsigned long ReasonCounts::total() const {
  unsigned long n = 0;
  for (const auto& rc : counts_) n += rc.second.total();
  return n;
}

std::vector<ReasonCounts::Entry> ReasonCounts::entries(double now) const {
  std::vector<Entry> e;
  for (const auto& [r, c] : counts_) e.push_back({r, c.recent(now), c.total()});
  return e;
}

Health judgeFlow(const FlowState& s, double stale_after, std::string& why) {
  if (s.last_input < 0.0 || s.now - s.last_input > stale_after) {
    why = s.last_input < 0.0 ? "no input yet" : "no input for " + std::to_string(int(s.now - s.last_input)) + " s";
    return Health::Stale;
  }
  const double since_output = s.last_output < 0.0 ? s.now - s.first_input : s.now - s.last_output;
  if (since_output > stale_after) {
    why = "inputs flow but no output for " + std::to_string(int(since_output)) + " s";
    return Health::Error;
  }
  if (s.recent_problems > 0) {
    why = std::to_string(s.recent_problems) + " inputs dropped in the last seconds";
    return Health::Warn;
  }
  why = s.last_output < 0.0 ? "starting" : "ok";
  return Health::Ok;
}

}  // namespace core
}  // namespace tilt_laser_perception
