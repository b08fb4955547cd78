/**
 * @file input_check.hpp
 * @brief What the nodelets check where a message enters, and how they count
 *        it: message stamps against the clock, joint samples, counts over a
 *        recent window (so diagnostics tell the present, not the sum since
 *        start-up) and the health verdict of a stage. ROS-free; time [s].
 */
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace tilt_laser_perception {
namespace core {

/// How far a message's stamp may be from the receiver's clock.
struct StampLimits {
  double max_age = 5.0;    ///< older than this is useless (the joint buffer keeps 5 s) [s]; <= 0: no limit
  double max_ahead = 1.0;  ///< farther ahead than this cannot be (clocks of one robot agree) [s]; <= 0: no limit
};

/// Why a stamp is refused: nullptr when it is fine. A zero stamp is "not
/// set" (ROS); `now` <= 0 is a clock that has not started (use_sim_time
/// before the first /clock): then only the stamp itself is checked.
const char* checkStamp(double stamp, double now, const StampLimits& limits);

/// Largest joint angle a tilt joint can report [rad] (a revolute joint of a head; absurd beyond).
constexpr double kMaxJointAngle = 6.283185307179586;
/// Largest angle a continuous (spinning) joint may have turned through [rad]:
/// 1e7 rad is 17 days at the MX-64's full speed; beyond, a double's step at
/// that angle (2e-9 rad) still resolves a beam, but a reading so far is absurd.
constexpr double kMaxContinuousJointAngle = 1e7;

/// Why a joint sample is refused: nullptr when its position is finite and
/// within kMaxJointAngle (a continuous joint, which turns on without end:
/// kMaxContinuousJointAngle).
const char* checkJointPosition(double q, bool continuous = false);

/// Events counted over a sliding window of whole seconds, and in total.
class WindowCounter {
 public:
  static constexpr int kBuckets = 64;  ///< seconds kept at most
  explicit WindowCounter(double window = 10.0);
  void add(double now, unsigned long k = 1);
  /// Events within the last `window` seconds before now.
  unsigned long recent(double now) const;
  unsigned long total() const { return total_; }
  /// Time of the latest event, -1 when none [s].
  double last() const { return last_; }
  double window() const { return window_; }

 private:
  void advance(long second) const;
  double window_;
  unsigned long total_ = 0;
  double last_ = -1.0;
  mutable long head_ = -1;  // the second of bucket head_ % kBuckets
  mutable std::array<unsigned long, kBuckets> buckets_{};
};

/// Counts by reason (fixed strings naming the field and the fault), each over a window and in total.
class ReasonCounts {
 public:
  explicit ReasonCounts(double window = 10.0) : window_(window) {}
  /// Counts k (one); returns that reason's total so far.
  unsigned long add(const std::string& reason, double now, unsigned long k = 1);
  unsigned long recent(double now) const;
  unsigned long total() const;
  /// (reason, recent, total) for every reason seen.
  struct Entry {
    std::string reason;
    unsigned long recent, total;
  };
  std::vector<Entry> entries(double now) const;

 private:
  double window_;
  std::vector<std::pair<std::string, WindowCounter>> counts_;
};

enum class Health { Ok = 0, Warn = 1, Error = 2, Stale = 3 };

/// What a stage that turns inputs into outputs is doing now.
struct FlowState {
  double now = 0.0;
  double first_input = -1.0;   ///< -1 before the first input [s]
  double last_input = -1.0;    ///< [s]
  double last_output = -1.0;   ///< -1 before the first output [s]
  unsigned long recent_problems = 0;  ///< bad or dropped inputs within the window
};

/// The verdict: Stale when no input came for `stale_after` seconds (or none
/// ever), Error when inputs flow but no output came for `stale_after` seconds
/// (after the start-up grace of the same length), Warn when something was
/// dropped within the window, else Ok. `why` says which in words.
Health judgeFlow(const FlowState& s, double stale_after, std::string& why);

}  // namespace core
}  // namespace tilt_laser_perception
