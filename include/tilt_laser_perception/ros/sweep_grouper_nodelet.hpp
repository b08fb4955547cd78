/**
 * @file sweep_grouper_nodelet.hpp
 * @brief tilt_laser_perception/SweepGrouper: scan + scan_segments (exact time
 *        sync) + joint_states + tf + robot_description in; for every finished
 *        tilt sweep: planes, height_map, height_map_cloud, sweep_cloud,
 *        edge_points and plane_markers. The work is core::SweepAssembler and
 *        core::buildHeightMap.
 */
#pragma once

#include <atomic>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <message_filters/time_synchronizer.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "tilt_laser_perception/ScanSegments.h"
#include "tilt_laser_perception/SweepGrouperConfig.h"
#include "tilt_laser_perception/core/calibration.hpp"
#include "tilt_laser_perception/core/fused_map.hpp"
#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/core/sequence.hpp"
#include "tilt_laser_perception/core/sweep.hpp"
#include "tilt_laser_perception/ros/inline_queue.hpp"
#include "tilt_laser_perception/ros/input_health.hpp"

namespace tilt_laser_perception {

class SweepGrouperNodelet : public nodelet::Nodelet {
 public:
  ~SweepGrouperNodelet() override;

 private:
  void onInit() override;
  bool setupChain();
  /// Entry points: every field checked, a bad message dropped and counted by reason.
  void onScanIn(const ros::MessageEvent<sensor_msgs::LaserScan const>& event);
  void onSegmentsIn(const ScanSegmentsConstPtr& segments);
  /// Joint states (200 Hz) arrive inline, in the publisher's thread: put in
  /// the inbox, nothing more; a worker wakes for them only while a line waits.
  void onJointInline(const sensor_msgs::JointStateConstPtr& js);
  /// Wakes the worker (pollSweeps) once if the first waiting line waits for this kind of input.
  void kickIf(core::SweepAssembler::Waiting what);
  /// The inbox into the assembler (called with mutex_ held).
  void drainJoints();
  void addJoint(const sensor_msgs::JointState& js);
  /// A scan and its split, paired by the synchronizer (called with mutex_ held).
  void onScan(const sensor_msgs::LaserScanConstPtr& scan, const ScanSegmentsConstPtr& segments);
  /// Runs f; an exception it throws is counted and warned about, never let out of a callback.
  template <class F>
  void guarded(const char* where, F&& f);
  /// The assembler's counters since the last look, into the recent window by reason.
  void takeAssemblerCounts();
  void pollSweeps();
  void publish(const core::SweepResult& sweep);
  /// The live calibration check: feeds the watch a sweep, starts a window's
  /// solve on a thread of its own, takes a finished one's verdict.
  void checkCalibration(const core::SweepResult* sweep);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void warn(const std::string& msg);
  /// dynamic_reconfigure: the grouping's and the map's main settings, from the next sweep on.
  void reconfigure(SweepGrouperConfig& config, uint32_t level);
  std::unique_ptr<dynamic_reconfigure::Server<SweepGrouperConfig>> reconfigure_server_;
  boost::recursive_mutex reconfigure_mutex_;

  std::mutex mutex_;
  // Declared before the subscriptions and the tf listener that use them: they outlive them.
  InlineCallbackQueue joint_queue_{[this] { kickIf(core::SweepAssembler::Waiting::Joints); }};
  InlineCallbackQueue tf_queue_{[this] { kickIf(core::SweepAssembler::Waiting::Pose); }};
  std::mutex inbox_mutex_;  // held only to push or swap: never while grouping or publishing
  std::vector<sensor_msgs::JointStateConstPtr> inbox_, inbox_taken_;
  static constexpr std::size_t kInboxMax = 4000;  // 20 s at 200 Hz
  unsigned long inbox_dropped_ = 0;               // since the last drain
  std::atomic<core::SweepAssembler::Waiting> waiting_{core::SweepAssembler::Waiting::Nothing};
  std::atomic<bool> kicked_{false};
  ros::CallbackQueueInterface* worker_queue_ = nullptr;  // the nodelet's own
  ros::CallbackInterfacePtr kick_;  // pollSweeps on the worker
  std::unique_ptr<core::SweepAssembler> assembler_;
  InputHealth health_;  // refused inputs by reason, sequence gaps per publisher, loads
  core::SweepCounters counted_;  // the assembler's counters as last taken into health_
  core::WindowCounter scans_in_{10.0}, sweeps_out_{10.0};
  core::StampLimits stamp_limits_;
  double stale_after_ = 5.0, last_sweep_duration_ = 0.0, first_scan_ = -1.0;
  core::SweepParams sweep_params_;
  core::HeightMapParams map_params_;
  core::FootParams foot_;  // the steppable layer's
  std::vector<std::uint8_t> steppable_;
  core::HeightMapGrid grid_;  // reused: no page faults per sweep
  core::FusedMapParams map_noise_;  // the cells' noise terms (the sweep's own map's sigmas too)
  // ~fuse_sweeps: height_map is the map fused over sweeps, its centre on ~robot_frame.
  bool fuse_ = false;
  std::string robot_frame_;
  std::unique_ptr<core::FusedMapTracker> fused_;
  /// Moves the fused map with the robot and fuses the sweep in.
  void fuseSweep(const core::SweepResult& sweep);
  std::string frame_id_, joint_name_, laser_frame_, parent_link_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<message_filters::TimeSynchronizer<sensor_msgs::LaserScan, ScanSegments>> sync_;
  ros::Subscriber scan_sub_, segments_sub_, joint_sub_;
  ros::Publisher planes_pub_, terrain_pub_, map_pub_, map_cloud_pub_, sweep_cloud_pub_, edges_pub_, markers_pub_;
  ros::Publisher grid_pub_;       // height_map_grid: the classes as nav_msgs/OccupancyGrid
  ros::Publisher steppable_pub_;  // steppable_grid: where a foot fits, as nav_msgs/OccupancyGrid
  ros::Timer poll_timer_, diag_timer_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTime last_warn_;
  std::string last_warning_, chain_error_;
  unsigned long exceptions_ = 0;
  unsigned long published_ = 0;
  double last_latency_ms_ = 0.0, last_group_ms_ = 0.0, last_line_sigma_deg_ = 0.0, last_range_noise_mm_ = 0.0;
  std::size_t last_planes_ = 0;
  // The live calibration check (~calibration_check_sweeps; 0: off).
  int calibration_check_sweeps_ = 8;
  double calibration_check_period_ = 60.0;
  std::unique_ptr<core::CalibrationMonitor> calibration_;  ///< null while off or before the chain is known
};

}  // namespace tilt_laser_perception
