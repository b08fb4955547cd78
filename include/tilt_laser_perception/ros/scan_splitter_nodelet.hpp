/**
 * @file scan_splitter_nodelet.hpp
 * @brief tilt_laser_perception/ScanSplitter: LaserScan in, ScanSegments out.
 *
 * Subscribes:  scan (sensor_msgs/LaserScan), only while an output has subscribers.
 * Publishes:   scan_segments (ScanSegments), segment_markers (visualization_msgs/MarkerArray,
 *              built only while subscribed), /diagnostics.
 * Parameters:  ~mode, ~zeta, ~d_min, ~jump_min, ~jump_ratio, ~min_points (dynamic_reconfigure);
 *              ~max_ranges, ~max_scan_duration (bounds on a scan).
 */
#pragma once

#include <array>
#include <boost/thread/recursive_mutex.hpp>
#include <memory>
#include <mutex>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>

#include "tilt_laser_perception/ScanSplitterConfig.h"
#include "tilt_laser_perception/core/scan_split.hpp"
#include "tilt_laser_perception/ros/input_health.hpp"

namespace tilt_laser_perception {

class ScanSplitterNodelet : public nodelet::Nodelet {
 public:
  ScanSplitterNodelet() = default;
  ~ScanSplitterNodelet() override;

 private:
  void onInit() override;
  void connectCallback();
  void scanCallback(const ros::MessageEvent<sensor_msgs::LaserScan const>& event);
  void split(const ros::MessageEvent<sensor_msgs::LaserScan const>& event);
  void reconfigure(ScanSplitterConfig& config, uint32_t level);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  std::mutex mutex_;  // guards everything below that callbacks touch
  core::ScanSplitter splitter_;
  core::SplitResult result_;
  ros::Subscriber scan_sub_;
  ros::Publisher segments_pub_, markers_pub_;
  std::unique_ptr<dynamic_reconfigure::Server<ScanSplitterConfig>> reconfigure_server_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::Timer diagnostics_timer_;

  // counters for diagnostics
  unsigned long received_ = 0, published_ = 0, dropped_ = 0, intensities_dropped_ = 0;
  InputHealth health_;  // refused scans by reason, sequence gaps per publisher, loads
  core::WindowCounter scans_in_{10.0}, scans_out_{10.0};
  double first_scan_ = -1.0;
  double split_time_sum_ = 0.0, split_time_max_ = 0.0;  // [s] since the last report
  unsigned long split_count_ = 0;
};

}  // namespace tilt_laser_perception
