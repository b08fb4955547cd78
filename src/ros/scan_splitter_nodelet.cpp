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
  health_.init(getName());
  core::ScanLimits limits;
  int max_ranges = static_cast<int>(limits.max_ranges);
  pnh.param("max_ranges", max_ranges, max_ranges);
  pnh.param("max_scan_duration", limits.max_duration, limits.max_duration);
  limits.max_ranges = static_cast<std::size_t>(std::max(0, max_ranges));
  const std::string problem = limits.validate();
  if (!problem.empty()) {
    NODELET_ERROR("%s: using %zu ranges and %.1f s", problem.c_str(), core::ScanLimits().max_ranges,
                  core::ScanLimits().max_duration);
    limits = core::ScanLimits();
  }
  splitter_.setLimits(limits);

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
    health_.forgetSequences();  // the scans while nobody listened were not lost
    scan_sub_ = getNodeHandle().subscribe("scan", kScanQueue, &ScanSplitterNodelet::scanCallback, this);
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
  p.veil_angle_deg = config.veil_angle_deg;
  p.veil_max_beams = config.veil_max_beams;
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
    config.veil_angle_deg = old.veil_angle_deg;
    config.veil_max_beams = old.veil_max_beams;
    return;
  }
  if (p.mode == core::SplitMode::Fixed && config.mode != "fixed") config.mode = "adaptive";
  splitter_.setParams(p);
  NODELET_INFO("split: mode %s, zeta %.4f, d_min %.3f m, jump %.3f m + %.3f*R, min_points %d, merge %s, "
               "veil %.1f deg up to %d beams",
               p.mode == core::SplitMode::Fixed ? "fixed" : "adaptive", p.zeta, p.d_min, p.jump_min, p.jump_ratio,
               p.min_points, p.merge ? "on" : "off", p.veil_angle_deg, p.veil_max_beams);
}

void ScanSplitterNodelet::scanCallback(const ros::MessageEvent<sensor_msgs::LaserScan const>& event) {
  std::lock_guard<std::mutex> lock(mutex_);
  try {
    split(event);
  } catch (const std::exception& e) {  // never out of a callback: the manager holds the driver and the grouper too
    ++dropped_;
    health_.refuse("exception while splitting", e.what());
  }
}

void ScanSplitterNodelet::split(const ros::MessageEvent<sensor_msgs::LaserScan const>& event) {
  const sensor_msgs::LaserScan& scan = *event.getConstMessage();
  ++received_;
  const double now = InputHealth::now();
  scans_in_.add(now);
  if (first_scan_ < 0.0) first_scan_ = now;
  if (const unsigned long missed = health_.sequence(event.getPublisherName(), scan.header.seq))
    NODELET_WARN_THROTTLE(5.0, "%lu scans missed before seq %u (a full queue upstream, a slow link); %lu so far", missed,
                          scan.header.seq, health_.missedUpstream());
  if (!scan.intensities.empty() && scan.intensities.size() != scan.ranges.size()) {
    ++intensities_dropped_;
    NODELET_WARN_ONCE("scans with %zu intensities for %zu ranges: the intensities are left out, the ranges split",
                      scan.intensities.size(), scan.ranges.size());
  }
  const auto t0 = std::chrono::steady_clock::now();
  const core::ScanError err = splitter_.split(toScanView(scan), result_);
  const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (err != core::ScanError::None) {
    ++dropped_;
    health_.refuse(std::string("scan: ") + core::scanErrorName(err),
                   "frame '" + scan.header.frame_id + "', " + std::to_string(scan.ranges.size()) + " ranges");
    return;
  }
  split_time_sum_ += dt;
  split_time_max_ = std::max(split_time_max_, dt);
  ++split_count_;

  auto msg = boost::make_shared<ScanSegments>();
  toMsg(result_, splitter_.params(), scan.header, *msg);
  if (markers_pub_.getNumSubscribers() > 0) {
    auto markers = boost::make_shared<visualization_msgs::MarkerArray>();
    segmentMarkers(*msg, *markers);
    markers_pub_.publish(markers);
  }
  segments_pub_.publish(msg);
  scans_out_.add(now);
  ++published_;
}

void ScanSplitterNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double t = InputHealth::now();
  core::Health level = core::Health::Ok;
  std::string why = "idle: nobody subscribes to the outputs";
  if (scan_sub_) level = health_.judge(scans_in_, scans_out_, first_scan_, 5.0, why);
  health_.report(stat, level, why);
  stat.add("scans received", received_);
  stat.add("scans received (last 10 s)", scans_in_.recent(t));
  stat.add("scans published", published_);
  stat.add("scans published (last 10 s)", scans_out_.recent(t));
  stat.add("scans dropped", dropped_);
  stat.add("intensities left out (other length than ranges)", intensities_dropped_);
  stat.add("split time mean [us]", split_count_ ? 1e6 * split_time_sum_ / split_count_ : 0.0);
  stat.add("split time max [us]", 1e6 * split_time_max_);
  split_time_sum_ = split_time_max_ = 0.0;
  split_count_ = 0;
}

}  // namespace tilt_laser_perception

PLUGINLIB_EXPORT_CLASS(tilt_laser_perception::ScanSplitterNodelet, nodelet::Nodelet)
