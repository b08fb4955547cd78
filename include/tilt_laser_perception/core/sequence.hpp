/**
 * @file sequence.hpp
 * @brief Counts messages lost upstream from the gaps in their header sequence
 *        numbers (the driver numbers its scans): a bounded queue that dropped
 *        a scan, a slow transport. ROS-free.
 */
#pragma once
#include <cstdint>

namespace tilt_laser_perception {
namespace core {

class SequenceGaps {
 public:
  /// Takes the next sequence number; returns how many were missed before it.
  /// A number at or before the last (a restarted publisher, a looping bag)
  /// starts counting afresh and counts as no loss (restarts() counts it).
  unsigned long add(std::uint32_t seq) {
    unsigned long missed = 0;
    if (have_ && seq > last_) {
      missed = seq - last_ - 1;
    } else if (have_) {
      ++restarts_;
    }
    have_ = true;
    last_ = seq;
    missed_ += missed;
    return missed;
  }
  /// The next number starts afresh (the subscriber was away: what passed
  /// meanwhile was not lost, it was not asked for).
  void forgetLast() { have_ = false; }
  unsigned long missed() const { return missed_; }
  unsigned long restarts() const { return restarts_; }

 private:
  bool have_ = false;
  std::uint32_t last_ = 0;
  unsigned long missed_ = 0, restarts_ = 0;
};

}  // namespace core
}  // namespace tilt_laser_perception
