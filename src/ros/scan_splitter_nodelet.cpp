#include "tilt_laser_perception/ros/scan_splitter_nodelet.hpp"

#include <chrono>

#include <boost/make_shared.hpp>
#include <pluginlib/class_list_macros.hpp>
#include <visualization_msgs/MarkerArray.h>

#include "tilt_laser_perception/ScanSegments.h"
#include "tilt_laser_perception/ros/conversions.hpp"

namespace tilt_laser_perception {

ScanSplitterNodelet::~ScanSplitterNodelet() { diagnostics_timer_.stop(); }

void ScanSplitterNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();

  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<ScanSplitterConfig>>(reconfigure_mutex_, pnh);
  reconfigure_server_->setCallback(
      [this](ScanSplitterConfig& config, uint32_t level) { reconfigure(config, level); });

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
  diagnostics_->setHardwareID("none");
  diagnostics_->add("scan splitter", this, &ScanSplitterNodelet::diagnose);
  diagnostics_timer_ = nh.createTimer(ros::Duration(0.5), [this](const ros::TimerEvent&) { diagnostics_->update(); });

  const ros::SubscriberStatusCallback connect = [this](const ros::SingleSubscriberPublisher&) { connectCallback(); };
  ros::Publisher segments = nh.advertise<ScanSegments>("scan_segments", 10, connect, connect);
  ros::Publisher markers = nh.advertise<visualization_msgs::MarkerArray>("segment_markers", 2, connect, connect);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    segments_pub_ = segments;
    markers_pub_ = markers;
  }
  connectCallback();
}

void ScanSplitterNodelet::connectCallback() {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool wanted = segments_pub_.getNumSubscribers() > 0 || markers_pub_.getNumSubscribers() > 0;
  if (wanted && !scan_sub_) {
    gaps_.forgetLast();  // the scans while nobody listened were not lost
    scan_sub_ = getNodeHandle().subscribe("scan", 10, &ScanSplitterNodelet::scanCallback, this);
    NODELET_DEBUG("output subscribed: subscribing to %s", scan_sub_.getTopic().c_str());
  } else if (!wanted && scan_sub_) {
    scan_sub_.shutdown();
    NODELET_DEBUG("no subscribers left: unsubscribed from scan");
  }
}

void ScanSplitterNodelet::reconfigure(ScanSplitterConfig& config, uint32_t) {
  core::SplitParams p;
  p.mode = config.mode == "fixed" ? core::SplitMode::Fixed : core::SplitMode::Adaptive;
  if (config.mode != "fixed" && config.mode != "adaptive")
    NODELET_ERROR("mode must be 'adaptive' or 'fixed', got '%s': using adaptive", config.mode.c_str());
  p.zeta = config.zeta;
  p.d_min = config.d_min;
  p.jump_min = config.jump_min;
  p.jump_ratio = config.jump_ratio;
  p.min_points = config.min_points;
  p.merge = config.merge;
  const std::string problem = p.validate();
  std::lock_guard<std::mutex> lock(mutex_);
  if (!problem.empty()) {
    NODELET_ERROR("invalid splitter settings (%s): keeping the previous ones", problem.c_str());
    const core::SplitParams& old = splitter_.params();
    config.mode = old.mode == core::SplitMode::Fixed ? "fixed" : "adaptive";
    config.zeta = old.zeta;
    config.d_min = old.d_min;
    config.jump_min = old.jump_min;
    config.jump_ratio = old.jump_ratio;
    config.min_points = old.min_points;
    config.merge = old.merge;
    return;
  }
  if (p.mode == core::SplitMode::Fixed && config.mode != "fixed") config.mode = "adaptive";
  splitter_.setParams(p);
  NODELET_INFO("split: mode %s, zeta %.4f, d_min %.3f m, jump %.3f m + %.3f*R, min_points %d, merge %s",
               p.mode == core::SplitMode::Fixed ? "fixed" : "adaptive", p.zeta, p.d_min, p.jump_min, p.jump_ratio,
               p.min_points, p.merge ? "on" : "off");
}

void ScanSplitterNodelet::scanCallback(const sensor_msgs::LaserScanConstPtr& scan) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++received_;
  if (const unsigned long missed = gaps_.add(scan->header.seq))
    NODELET_WARN_THROTTLE(5.0, "%lu scans missed before seq %u (a full queue upstream, a slow link); %lu so far", missed,
                          scan->header.seq, gaps_.missed());
  const auto t0 = std::chrono::steady_clock::now();
  const core::ScanError err = splitter_.split(toScanView(*scan), result_);
  const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (err != core::ScanError::None) {
    ++dropped_;
    ++dropped_by_reason_[static_cast<int>(err)];
    NODELET_WARN_THROTTLE(5.0, "dropped a scan (frame '%s', %zu ranges): %s; %lu dropped so far",
                          scan->header.frame_id.c_str(), scan->ranges.size(), core::scanErrorName(err), dropped_);
    return;
  }
  split_time_sum_ += dt;
  split_time_max_ = std::max(split_time_max_, dt);
  ++split_count_;

  auto msg = boost::make_shared<ScanSegments>();
  toMsg(result_, splitter_.params(), scan->header, *msg);
  if (markers_pub_.getNumSubscribers() > 0) {
    auto markers = boost::make_shared<visualization_msgs::MarkerArray>();
    segmentMarkers(*msg, *markers);
    markers_pub_.publish(markers);
  }
  segments_pub_.publish(msg);
  ++published_;
}

void ScanSplitterNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (dropped_ > dropped_reported_)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%lu bad scans dropped since the last report",
                  dropped_ - dropped_reported_);
  else if (!scan_sub_)
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "idle: nobody subscribes to the outputs");
  else
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "ok");
  dropped_reported_ = dropped_;
  stat.add("scans received", received_);
  stat.add("scans published", published_);
  stat.add("scans dropped", dropped_);
  stat.add("scans missed upstream (sequence gaps)", gaps_.missed());
  for (int e = 1; e < core::kScanErrorCount; ++e)
    stat.add(std::string("dropped: ") + core::scanErrorName(static_cast<core::ScanError>(e)), dropped_by_reason_[e]);
  stat.add("split time mean [us]", split_count_ ? 1e6 * split_time_sum_ / split_count_ : 0.0);
  stat.add("split time max [us]", 1e6 * split_time_max_);
  split_time_sum_ = split_time_max_ = 0.0;
  split_count_ = 0;
}

}  // namespace tilt_laser_perception

PLUGINLIB_EXPORT_CLASS(tilt_laser_perception::ScanSplitterNodelet, nodelet::Nodelet)
