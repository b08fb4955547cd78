/**
 * @file input_health.hpp
 * @brief What the splitter and the grouper share where messages enter:
 *        refused inputs counted by reason over a recent window and warned
 *        about (throttled, naming the field), scan sequence gaps kept per
 *        publisher, the nodelet's load count (a respawned manager says so),
 *        and the diagnostics that follow from them. The rules are core's
 *        (core/input_check.hpp); this is their ROS side.
 */
#pragma once

#include <map>
#include <string>

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>

#include "tilt_laser_perception/core/input_check.hpp"
#include "tilt_laser_perception/core/sequence.hpp"

namespace tilt_laser_perception {

/// How many times the nodelet `name` has been loaded in this process
/// (core::countLoad); above 1 (unloaded and loaded again) logged as a warning.
int countLoad(const std::string& name);
/// The load count and the process's uptime in a nodelet's diagnostics: a
/// manager that died and was respawned shows a young process.
void addLoadStatus(diagnostic_updater::DiagnosticStatusWrapper& stat, int loads);

class InputHealth {
 public:
  /// `name` prefixes the log lines and names the load count.
  void init(const std::string& name, double window = 10.0);
  /// Counts k refused (or dropped) inputs and warns, at most every 5 s per reason.
  void refuse(const std::string& reason, const std::string& detail = std::string(), unsigned long k = 1);
  /// A joint state's own fields, for a reader of some of its joints: names
  /// and positions pair up, the stamp is set and near the clock. False: refused (counted).
  bool acceptJointState(const sensor_msgs::JointState& js, const core::StampLimits& limits);
  /// One joint's position is a real angle (core::checkJointPosition). False: refused (counted).
  bool acceptJointPosition(const sensor_msgs::JointState& js, std::size_t i, bool continuous = false);
  /// Scan lines lost upstream, counted per publisher (a second publisher on
  /// the topic numbers its own messages); returns how many were missed.
  unsigned long sequence(const std::string& publisher, std::uint32_t seq);
  void forgetSequences() { gaps_.clear(); }
  unsigned long missedUpstream() const;
  /// The wall clock or the ROS clock, as the checks need it [s].
  static double now() { return ros::Time::now().toSec(); }
  const core::ReasonCounts& refused() const { return refused_; }
  /// The stage's health now (core::judgeFlow): inputs and outputs counted
  /// over the window, the first input's time, refusals of the window.
  core::Health judge(const core::WindowCounter& in, const core::WindowCounter& out, double first_input,
                     double stale_after, std::string& why) const;
  /// Adds the refusals (recent and total, by reason), the losses upstream and
  /// the load count to a diagnostic status; a load after the first (a
  /// respawned manager) is said in the summary's words for a minute.
  void report(diagnostic_updater::DiagnosticStatusWrapper& stat, core::Health level, const std::string& why) const;
  int loads() const { return loads_; }

 private:
  std::string name_;
  double window_ = 10.0;
  core::ReasonCounts refused_;
  std::map<std::string, ros::WallTime> last_warned_;
  std::map<std::string, core::SequenceGaps> gaps_;
  int loads_ = 1;
  ros::WallTime loaded_at_;
};

}  // namespace tilt_laser_perception
