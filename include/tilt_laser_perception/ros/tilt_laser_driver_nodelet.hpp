/**
 * @file tilt_laser_driver_nodelet.hpp
 * @brief tilt_laser_perception/TiltLaserDriver: the Hokuyo and the tilt servo
 *        in one nodelet, two threads (driver/laser_driver, driver/servo_driver).
 *
 * Publishes: scan (sensor_msgs/LaserScan, stamped at its first beam's host time),
 *            joint_states (sensor_msgs/JointState, stamped when read),
 *            tilt_sweep (TiltSweep), /diagnostics.
 */
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include <diagnostic_updater/diagnostic_updater.h>
#include <diagnostic_updater/publisher.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include "tilt_laser_perception/core/input_check.hpp"

#include "tilt_laser_perception/driver/laser_driver.hpp"
#include "tilt_laser_perception/driver/servo_driver.hpp"

namespace tilt_laser_perception {

class TiltLaserDriverNodelet : public nodelet::Nodelet {
 public:
  ~TiltLaserDriverNodelet() override;

 private:
  void onInit() override;
  void log(int level, const std::string& msg);
  void diagnoseLaser(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void diagnoseServo(diagnostic_updater::DiagnosticStatusWrapper& stat);

  std::unique_ptr<driver::LaserDriver> laser_;
  // The laser's timing faults over the last seconds (the status counts since start).
  core::WindowCounter delayed_win_{10.0}, impossible_win_{10.0}, slow_reply_win_{10.0};
  unsigned long delayed_seen_ = 0, impossible_seen_ = 0, rejected_seen_ = 0;
  int loads_ = 1;  // loads in this process (core::countLoad): a reload is said in the diagnostics for a minute
  ros::WallTime loaded_at_;
  std::unique_ptr<driver::ServoDriver> servo_;
  ros::Publisher scan_pub_, joint_pub_, sweep_pub_, echoes_pub_;
  bool multi_echo_out_ = false;                             ///< ~echo: multi
  scip::EchoChoice scan_echo_ = scip::EchoChoice::First;  ///< the echo `scan` carries
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  std::unique_ptr<diagnostic_updater::FrequencyStatus> scan_freq_, joint_freq_;
  double scan_freq_min_ = 38.0, scan_freq_max_ = 42.0, joint_freq_min_ = 100.0, joint_freq_max_ = 1000.0;
  ros::Timer diagnostics_timer_;
  std::string frame_id_, joint_name_;
  std::mutex log_mutex_;
  std::map<std::string, ros::WallTime> last_log_;
  uint32_t scan_seq_ = 0;
};

}  // namespace tilt_laser_perception
