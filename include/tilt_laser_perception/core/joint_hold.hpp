/**
 * @file joint_hold.hpp
 * @brief Whether to hold joints at fixed angles: while nobody else publishes
 *        them (the robot's own joint states), someone must, or the chain
 *        from base_footprint to the laser has a gap in tf. ROS-free; time [s].
 */
#pragma once

#include <cmath>
#include <limits>

namespace tilt_laser_perception {
namespace core {

class JointHold {
 public:
  /// Fresh values older than `timeout` no longer count.
  explicit JointHold(double timeout) : timeout_(timeout) {}
  /// Another publisher gave all the joints at time t.
  void seen(double t) { last_ = t; }
  /// True: nobody else gives them now, publish the fixed angles.
  bool holding(double now) const { return !(now - last_ < timeout_); }

 private:
  double timeout_;
  double last_ = -std::numeric_limits<double>::infinity();
};

}  // namespace core
}  // namespace tilt_laser_perception
