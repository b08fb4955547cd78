#include "tilt_laser_perception/ros/sweep_grouper_nodelet.hpp"

#include <algorithm>
#include <chrono>

#include <boost/make_shared.hpp>
#include <pluginlib/class_list_macros.hpp>
#include <tf2_eigen/tf2_eigen.h>
#include <urdf/model.h>

#include "tilt_laser_perception/HeightMap.h"
#include "tilt_laser_perception/PlanePolygonArray.h"
#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/ros/conversions.hpp"

namespace tilt_laser_perception {

SweepGrouperNodelet::~SweepGrouperNodelet() {
  poll_timer_.stop();
  diag_timer_.stop();
  joint_sub_.shutdown();  // no inline call after this (it waits for one in progress)
  waiting_ = core::SweepAssembler::Waiting::Nothing;
  if (worker_queue_) worker_queue_->removeByID(reinterpret_cast<uint64_t>(this));
}

void SweepGrouperNodelet::warn(const std::string& msg) {
  // Throttled: a repeating problem is said every 5 s (and always counted in the diagnostics).
  const ros::WallTime now = ros::WallTime::now();
  if (msg == last_warning_ && (now - last_warn_).toSec() < 5.0) return;
  last_warning_ = msg;
  last_warn_ = now;
  NODELET_WARN("%s", msg.c_str());
}

void SweepGrouperNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  pnh.param<std::string>("frame_id", frame_id_, "base_footprint");
  pnh.param<std::string>("joint_name", joint_name_, "head_tilt_joint");
  pnh.param<std::string>("laser_frame", laser_frame_, "laser");
  pnh.param("calibration_check_sweeps", calibration_check_sweeps_, 8);
  pnh.param("calibration_check_period", calibration_check_period_, 60.0);
  core::GroupingParams& g = sweep_params_.grouping;
  pnh.param("plane_dist_min", g.dist_min, g.dist_min);
  pnh.param("plane_dist_ratio", g.dist_ratio, g.dist_ratio);
  pnh.param("plane_angle_deg", g.angle_deg, g.angle_deg);
  pnh.param("merge_angle_deg", g.merge_angle_deg, g.merge_angle_deg);
  pnh.param("min_plane_segments", g.min_segments, g.min_segments);
  pnh.param("min_plane_area", g.min_area, g.min_area);
  pnh.param("crease_reach", g.crease_reach, g.crease_reach);
  pnh.param("crease_margin", g.crease_margin, g.crease_margin);
  double line_sigma_deg = g.line_sigma * 180.0 / M_PI;
  pnh.param("line_sigma_deg", line_sigma_deg, line_sigma_deg);
  g.line_sigma = line_sigma_deg * M_PI / 180.0;
  pnh.param("reversal_hysteresis", sweep_params_.reversal_hysteresis, sweep_params_.reversal_hysteresis);
  pnh.param("spin_span", sweep_params_.spin_span, sweep_params_.spin_span);
  pnh.param("max_joint_gap", sweep_params_.max_joint_gap, sweep_params_.max_joint_gap);
  pnh.param("max_wait", sweep_params_.max_wait, sweep_params_.max_wait);
  pnh.param("min_sweep_lines", sweep_params_.min_lines, sweep_params_.min_lines);
  pnh.param("max_sweep_lines", sweep_params_.max_lines, sweep_params_.max_lines);
  pnh.param("per_beam_tilt", sweep_params_.per_beam, true);
  pnh.param("map_resolution", map_params_.resolution, map_params_.resolution);
  double size_x = map_params_.width * map_params_.resolution, size_y = map_params_.height * map_params_.resolution;
  pnh.param("map_size_x", size_x, size_x);
  pnh.param("map_size_y", size_y, size_y);
  pnh.param("map_origin_x", map_params_.origin_x, map_params_.origin_x);
  pnh.param("map_origin_y", map_params_.origin_y, map_params_.origin_y);
  pnh.param("map_max_slope_deg", map_params_.max_slope_deg, map_params_.max_slope_deg);
  pnh.param("map_max_step_height", map_params_.max_step_height, map_params_.max_step_height);
  pnh.param("map_obstacle_min_height", map_params_.obstacle_min_height, map_params_.obstacle_min_height);
  pnh.param("foot_length", foot_.length, foot_.length);
  pnh.param("foot_width", foot_.width, foot_.width);
  pnh.param("foot_max_tilt_deg", foot_.max_tilt_deg, foot_.max_tilt_deg);
  pnh.param("foot_max_roughness", foot_.max_roughness, foot_.max_roughness);
  if (const std::string bad = foot_.validate(); !bad.empty()) {
    NODELET_ERROR("invalid foot parameters (%s): using HRP-4's", bad.c_str());
    foot_ = core::FootParams();
  }
  core::FusedMapParams fp;
  pnh.param("fuse_sweeps", fuse_, false);
  pnh.param<std::string>("robot_frame", robot_frame_, "base_footprint");
  pnh.param("fused_map_size", fp.size, fp.size);
  pnh.param("fused_map_resolution", fp.resolution, fp.resolution);
  pnh.param("forget_time", fp.forget_time, fp.forget_time);
  pnh.param("map_sigma_min", fp.sigma_min, fp.sigma_min);
  pnh.param("map_sigma_range", fp.sigma_range, fp.sigma_range);
  pnh.param("odom_drift_per_metre", fp.drift_per_metre, fp.drift_per_metre);
  double sigma_pose_deg = fp.sigma_pose * 180.0 / M_PI;
  pnh.param("map_sigma_pose_deg", sigma_pose_deg, sigma_pose_deg);
  fp.sigma_pose = sigma_pose_deg * M_PI / 180.0;
  pnh.param("fusion_gate", fp.gate, fp.gate);
  if (const std::string bad = fp.validate();
      !bad.empty() || fp.size / (fp.resolution > 0.0 ? fp.resolution : map_params_.resolution) > 4000) {
    NODELET_ERROR("invalid fused map parameters (%s): using the defaults", bad.empty() ? "more than 4000 cells a side" : bad.c_str());
    fp = core::FusedMapParams();
  }
  int max_ranges = static_cast<int>(sweep_params_.scan_limits.max_ranges);
  pnh.param("max_ranges", max_ranges, max_ranges);
  pnh.param("max_scan_duration", sweep_params_.scan_limits.max_duration, sweep_params_.scan_limits.max_duration);
  pnh.param("max_stamp_age", stamp_limits_.max_age, stamp_limits_.max_age);
  pnh.param("max_stamp_ahead", stamp_limits_.max_ahead, stamp_limits_.max_ahead);
  pnh.param("stale_after", stale_after_, stale_after_);
  sweep_params_.scan_limits.max_ranges = static_cast<std::size_t>(std::max(0, max_ranges));
  const std::string problem = sweep_params_.validate();
  if (!problem.empty()) {
    NODELET_ERROR("invalid sweep or grouping parameters (%s): using the defaults", problem.c_str());
    const bool per_beam = sweep_params_.per_beam;
    sweep_params_ = core::SweepParams();
    sweep_params_.per_beam = per_beam;
  }
  if (!std::isfinite(stamp_limits_.max_age) || !std::isfinite(stamp_limits_.max_ahead)) {
    NODELET_ERROR("~max_stamp_age and ~max_stamp_ahead must be finite (0: no limit): using 5 and 1 s");
    stamp_limits_ = core::StampLimits();
  }
  if (!(stale_after_ >= 1.0 && stale_after_ <= 600.0)) {
    NODELET_ERROR("~stale_after must be in [1, 600] s: using 5");
    stale_after_ = 5.0;
  }
  health_.init(getName());
  if (!(map_params_.resolution > 0.001 && size_x > 0 && size_y > 0 && size_x / map_params_.resolution <= 4000 &&
        size_y / map_params_.resolution <= 4000)) {
    NODELET_ERROR("invalid height map size or resolution (at most 4000 x 4000 cells): using 4 m x 4 m at 1 cm");
    map_params_ = core::HeightMapParams();
    size_x = size_y = 4.0;
  }
  map_params_.width = static_cast<int>(std::lround(size_x / map_params_.resolution));
  map_params_.height = static_cast<int>(std::lround(size_y / map_params_.resolution));
  map_noise_ = fp;
  if (fuse_) fused_ = std::make_unique<core::FusedMapTracker>(map_params_, fp);

  // Set before anything that may call kickIf (the inline queues' hooks).
  kick_ = boost::make_shared<TaskCallback>([this] {
    kicked_ = false;
    std::lock_guard<std::mutex> l(mutex_);
    guarded("poll", [&] { pollSweeps(); });
  });
  worker_queue_ = nh.getCallbackQueue();
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>(ros::Duration(10.0));
  // The listener inserts each transform in the thread that delivers it (the
  // head's state publisher publishes /tf at 50 Hz a joint): no thread of its own to wake.
  ros::NodeHandle tf_nh(nh);
  tf_nh.setCallbackQueue(&tf_queue_);
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, tf_nh, false);

  planes_pub_ = nh.advertise<PlanePolygonArray>("planes", 2);
  if (fuse_) terrain_pub_ = nh.advertise<PlanePolygonArray>("terrain_planes", 2, true);
  map_pub_ = nh.advertise<HeightMap>("height_map", 2);
  grid_pub_ = nh.advertise<nav_msgs::OccupancyGrid>("height_map_grid", 2);
  steppable_pub_ = nh.advertise<nav_msgs::OccupancyGrid>("steppable_grid", 2);
  map_cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("height_map_cloud", 2);
  sweep_cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("sweep_cloud", 2);
  edges_pub_ = nh.advertise<sensor_msgs::PointCloud2>("edge_points", 2);
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("plane_markers", 2);

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
  diagnostics_->setHardwareID("none");
  diagnostics_->add("sweep grouper", this, &SweepGrouperNodelet::diagnose);
  diag_timer_ = nh.createTimer(ros::Duration(0.5), [this](const ros::TimerEvent&) { diagnostics_->update(); });

  setupChain();
  // After the parameters above: the server takes the same ones from the parameter server and calls back at once.
  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<SweepGrouperConfig>>(reconfigure_mutex_, pnh);
  reconfigure_server_->setCallback([this](SweepGrouperConfig& c, uint32_t level) { reconfigure(c, level); });
  // The scans and their splits are checked before they are paired: the
  // synchronizer holds only messages that passed (bounded in size).
  sync_ = std::make_unique<message_filters::TimeSynchronizer<sensor_msgs::LaserScan, ScanSegments>>(kScanQueue);
  sync_->registerCallback(boost::bind(&SweepGrouperNodelet::onScan, this, boost::placeholders::_1, boost::placeholders::_2));
  scan_sub_ = nh.subscribe("scan", kScanQueue, &SweepGrouperNodelet::onScanIn, this);
  segments_sub_ = nh.subscribe("scan_segments", kScanQueue, &SweepGrouperNodelet::onSegmentsIn, this);
  ros::SubscribeOptions joints;
  joints.init<sensor_msgs::JointState>("joint_states", 500,
                                       boost::bind(&SweepGrouperNodelet::onJointInline, this, boost::placeholders::_1));
  joints.callback_queue = &joint_queue_;
  joints.allow_concurrent_callbacks = true;  // onJointInline only takes inbox_mutex_
  joint_sub_ = nh.subscribe(joints);
  // A backstop: every scan polls, and a line that waits for joint states or
  // a pose is woken when they come; the timer drains the inbox and gives up
  // on what waits in vain while no scans come.
  poll_timer_ = nh.createTimer(ros::Duration(0.25), [this](const ros::TimerEvent&) {
    std::lock_guard<std::mutex> l(mutex_);
    guarded("poll", [&] { pollSweeps(); });
  });
}

void SweepGrouperNodelet::reconfigure(SweepGrouperConfig& c, uint32_t) {
  std::lock_guard<std::mutex> l(mutex_);
  core::SweepParams next = sweep_params_;
  core::GroupingParams& g = next.grouping;
  g.dist_min = c.plane_dist_min;
  g.dist_ratio = c.plane_dist_ratio;
  g.angle_deg = c.plane_angle_deg;
  g.merge_angle_deg = c.merge_angle_deg;
  g.min_segments = c.min_plane_segments;
  g.min_area = c.min_plane_area;
  g.crease_reach = c.crease_reach;
  g.crease_margin = c.crease_margin;
  if (const std::string problem = next.validate(); !problem.empty()) {
    NODELET_ERROR("invalid grouping settings (%s): keeping the previous ones", problem.c_str());
    const core::GroupingParams& old = sweep_params_.grouping;
    c.plane_dist_min = old.dist_min;
    c.plane_dist_ratio = old.dist_ratio;
    c.plane_angle_deg = old.angle_deg;
    c.merge_angle_deg = old.merge_angle_deg;
    c.min_plane_segments = old.min_segments;
    c.min_plane_area = old.min_area;
    c.crease_reach = old.crease_reach;
    c.crease_margin = old.crease_margin;
  } else {
    sweep_params_ = next;
    if (assembler_) assembler_->setGroupingParams(g);
  }
  map_params_.max_slope_deg = c.map_max_slope_deg;
  map_params_.max_step_height = c.map_max_step_height;
  map_params_.obstacle_min_height = c.map_obstacle_min_height;
  if (fused_) fused_->map().setClassification(map_params_);
}

template <class F>
void SweepGrouperNodelet::guarded(const char* where, F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    ++exceptions_;
    health_.refuse(std::string("exception in ") + where, e.what());
  }
}

bool SweepGrouperNodelet::setupChain() {
  std::string xml;
  ros::NodeHandle nh = getNodeHandle();
  if (!nh.getParam("robot_description", xml)) {
    chain_error_ = "no robot_description parameter: waiting for it";
    return false;
  }
  urdf::Model model;
  if (!model.initString(xml)) {
    chain_error_ = "robot_description is not a valid URDF";
    return false;
  }
  core::TiltChain chain;
  if (!tiltChainFromUrdf(model, joint_name_, laser_frame_, chain, parent_link_, chain_error_)) return false;
  const auto base_pose = [this](double t, Eigen::Isometry3d& pose) {
    using Status = core::SweepAssembler::PoseStatus;
    if (!(t > 0.0 && t < 4.29e9)) return Status::Missing;  // ros::Time would throw
    // canTransform first: a line that waits for its pose is asked again and
    // again, and a failed lookupTransform costs an exception each time.
    const ros::Time at(t);
    const auto lookup = [&]() {
      if (!tf_buffer_->canTransform(frame_id_, parent_link_, at)) return false;
      try {
        pose = tf2::transformToEigen(tf_buffer_->lookupTransform(frame_id_, parent_link_, at));
        return true;
      } catch (const tf2::TransformException&) {
        return false;
      }
    };
    if (lookup()) return Status::Ok;
    // Not yet (the transforms stop short of t: wait for them) or a gap? Once
    // the latest transforms are past t, look again: they may have arrived
    // between the two look-ups. No transform at all yet (start-up, a frame
    // that never comes): asked first, not thrown at every poll.
    if (!tf_buffer_->canTransform(frame_id_, parent_link_, ros::Time(0))) return Status::Wait;
    try {
      if (tf_buffer_->lookupTransform(frame_id_, parent_link_, ros::Time(0)).header.stamp < at) return Status::Wait;
    } catch (const tf2::TransformException&) {
      return Status::Wait;  // no transform at all yet (the assembler gives up after max_wait)
    }
    if (lookup()) return Status::Ok;
    std::string why;
    tf_buffer_->canTransform(frame_id_, parent_link_, at, &why);
    NODELET_WARN_THROTTLE(5.0, "SweepGrouper: no pose of %s in %s at %.3f: %s", parent_link_.c_str(), frame_id_.c_str(),
                          t, why.c_str());
    return Status::Missing;
  };
  assembler_ = std::make_unique<core::SweepAssembler>(sweep_params_, chain, base_pose);
  if (calibration_check_sweeps_ > 0) {
    core::CalibrationWatchOptions wo;
    wo.sweeps = calibration_check_sweeps_;
    wo.period = calibration_check_period_;
    calibration_ = std::make_unique<core::CalibrationMonitor>(chain, wo);
  }
  chain_error_.clear();
  NODELET_INFO("SweepGrouper: %s -> %s (joint %s) -> %s, assembling in %s", parent_link_.c_str(),
               joint_name_.c_str(), joint_name_.c_str(), laser_frame_.c_str(), frame_id_.c_str());
  return true;
}

void SweepGrouperNodelet::onJointInline(const sensor_msgs::JointStateConstPtr& js) {
  // The robot's own joint states (1 kHz, without the tilt) are not the
  // grouper's: left out here, not carried to the worker.
  if (std::find(js->name.begin(), js->name.end(), joint_name_) == js->name.end()) return;
  std::lock_guard<std::mutex> l(inbox_mutex_);
  // Bounded: the worker drains it at every scan and poll; full, it is stuck, and
  // the newest are dropped (counted) rather than the memory grown.
  if (inbox_.size() >= kInboxMax) {
    ++inbox_dropped_;
    return;
  }
  inbox_.push_back(js);  // joint_queue_ then wakes the worker if a line waits for it
}

void SweepGrouperNodelet::kickIf(core::SweepAssembler::Waiting what) {
  if (waiting_.load(std::memory_order_relaxed) == what && worker_queue_ && !kicked_.exchange(true))
    worker_queue_->addCallback(kick_, reinterpret_cast<uint64_t>(this));
}

void SweepGrouperNodelet::drainJoints() {
  unsigned long dropped = 0;
  {
    std::lock_guard<std::mutex> l(inbox_mutex_);
    inbox_taken_.swap(inbox_);  // both keep their capacity: no allocation once warm
    dropped = inbox_dropped_;
    inbox_dropped_ = 0;
  }
  if (dropped) health_.refuse("joint_states: inbox full (the worker fell behind)", std::to_string(kInboxMax) + " waiting", dropped);
  for (const auto& js : inbox_taken_) guarded("joint_states", [&] { addJoint(*js); });
  inbox_taken_.clear();
}

void SweepGrouperNodelet::addJoint(const sensor_msgs::JointState& js) {
  if (!assembler_ && !setupChain()) {
    warn(chain_error_);
    return;
  }
  // Every field that is read is checked (InputHealth): names and positions
  // pair up, the stamp is set and near the clock, the tilt's position is a real angle.
  const auto it = std::find(js.name.begin(), js.name.end(), joint_name_);
  if (it == js.name.end() || !health_.acceptJointState(js, stamp_limits_)) return;
  const std::size_t i = it - js.name.begin();
  if (!health_.acceptJointPosition(js, i, sweep_params_.spin_span > 0.0)) return;  // a spinning joint turns on
  const double t = js.header.stamp.toSec();
  assembler_->addJoint(t, js.position[i]);
  if (calibration_) calibration_->addJoint(t, js.position[i]);
}

void SweepGrouperNodelet::onScanIn(const ros::MessageEvent<sensor_msgs::LaserScan const>& event) {
  std::lock_guard<std::mutex> l(mutex_);
  guarded("scan", [&] {
    const sensor_msgs::LaserScanConstPtr& scan = event.getConstMessage();
    scans_in_.add(InputHealth::now());
    if (first_scan_ < 0.0) first_scan_ = InputHealth::now();
    if (const unsigned long missed = health_.sequence(event.getPublisherName(), scan->header.seq))
      warn(std::to_string(missed) + " scan lines missed before seq " + std::to_string(scan->header.seq) +
           " (a full queue upstream, a slow splitter)");
    const double t = scan->header.stamp.toSec();
    if (const char* bad = core::checkStamp(t, InputHealth::now(), stamp_limits_)) {
      health_.refuse(std::string("scan: ") + bad, std::to_string(t));
      return;
    }
    const core::ScanError err = core::checkScan(toScanView(*scan), sweep_params_.scan_limits);
    if (err != core::ScanError::None) {
      health_.refuse(std::string("scan: ") + core::scanErrorName(err), std::to_string(scan->ranges.size()) + " ranges");
      return;
    }
    sync_->add0(scan);
  });
}

void SweepGrouperNodelet::onSegmentsIn(const ScanSegmentsConstPtr& segs) {
  std::lock_guard<std::mutex> l(mutex_);
  guarded("scan_segments", [&] {
    const std::size_t limit = sweep_params_.scan_limits.max_ranges;
    if (segs->segments.size() > limit || segs->edge_indices.size() > limit) {
      health_.refuse("scan_segments: more segments or edges than max_ranges");
      return;
    }
    if (segs->edge_indices.size() != segs->edge_kinds.size()) {
      health_.refuse("scan_segments: edge_indices and edge_kinds differ in length");
      return;
    }
    for (const std::uint8_t k : segs->edge_kinds)
      if (k < 1 || k > 5) {
        health_.refuse("scan_segments: unknown edge kind", std::to_string(k));
        return;
      }
    for (const auto& sg : segs->segments)
      if (sg.first_index > sg.last_index) {
        health_.refuse("scan_segments: a segment's first_index after its last_index");
        return;
      }
    sync_->add1(segs);
  });
}

void SweepGrouperNodelet::onScan(const sensor_msgs::LaserScanConstPtr& scan, const ScanSegmentsConstPtr& segs) {
  if (!assembler_) return;
  // The indices must lie in this scan (the split of another scan with the same stamp would not).
  const std::size_t n = scan->ranges.size();
  for (const auto& sg : segs->segments)
    if (sg.last_index >= n) {
      health_.refuse("scan_segments: a segment beyond the scan's ranges");
      return;
    }
  for (const auto i : segs->edge_indices)
    if (i >= n) {
      health_.refuse("scan_segments: an edge index beyond the scan's ranges");
      return;
    }
  if (!scan->header.frame_id.empty() && scan->header.frame_id != laser_frame_)
    warn("scan frame '" + scan->header.frame_id + "' is not ~laser_frame '" + laser_frame_ + "': using the URDF chain to '" +
         laser_frame_ + "'");
  core::LineInput in = toLineInput(*scan);
  for (const auto& s : segs->segments) in.segments.emplace_back(static_cast<int>(s.first_index), static_cast<int>(s.last_index));
  for (std::size_t i = 0; i < segs->edge_indices.size() && i < segs->edge_kinds.size(); ++i)
    in.edges.emplace_back(static_cast<int>(segs->edge_indices[i]), static_cast<core::EdgeKind>(segs->edge_kinds[i]));
  assembler_->addLine(std::move(in), ros::Time::now().toSec());
  pollSweeps();
}

void SweepGrouperNodelet::takeAssemblerCounts() {
  // The assembler counts since its start; the diagnostics want the recent window.
  using C = core::SweepCounters;
  static const std::pair<unsigned long C::*, const char*> kinds[] = {
      {&C::lines_no_joint, "lines: no joint state"},      {&C::lines_no_pose, "lines: no pose (tf)"},
      {&C::lines_out_of_order, "lines: out of order"},     {&C::lines_bad, "lines: malformed"},
      {&C::joints_out_of_order, "joint states: out of order"}, {&C::joints_bad, "joint states: not finite"},
      {&C::sweeps_dropped, "sweeps dropped"},              {&C::time_jumps, "time jumped back (restart)"}};
  const C& now = assembler_->counters();
  for (const auto& [field, name] : kinds)
    for (unsigned long k = counted_.*field; k < now.*field; ++k) health_.refuse(name, assembler_->lastWarning());
  counted_ = now;
}

void SweepGrouperNodelet::pollSweeps() {
  drainJoints();
  if (!assembler_) return;
  core::SweepResult sweep;
  while (assembler_->poll(ros::Time::now().toSec(), sweep)) publish(sweep);
  waiting_ = assembler_->waiting();
  takeAssemblerCounts();  // anything dropped (or a restart) since the last look: counted, a throttled warning
}

void SweepGrouperNodelet::fuseSweep(const core::SweepResult& sweep) {
  // Where the robot was at the sweep's last beam: a pose the sweep's lines
  // have waited for, so live and replayed runs find it alike.
  try {
    const Eigen::Vector2d xy =
        tf2::transformToEigen(tf_buffer_->lookupTransform(frame_id_, robot_frame_, ros::Time(core::lastBeamTime(sweep))))
            .translation()
            .head<2>();
    fused_->addSweep(sweep, &xy);
  } catch (const tf2::TransformException& e) {
    warn("no pose of ~robot_frame '" + robot_frame_ + "' in '" + frame_id_ + "' at the sweep's last beam: the fused map stays where it was (" +
         e.what() + ")");
    fused_->addSweep(sweep, nullptr);
  }
}

void SweepGrouperNodelet::publish(const core::SweepResult& sweep) {
  const auto t0 = std::chrono::steady_clock::now();
  if (fused_) fuseSweep(sweep);
  else core::buildHeightMap(sweep, map_params_, grid_);
  const core::HeightMapGrid& grid = fused_ ? fused_->map().grid() : grid_;
  std_msgs::Header header;
  header.stamp = ros::Time(sweep.end);
  header.frame_id = frame_id_;
  auto planes = boost::make_shared<PlanePolygonArray>();
  planes->header = header;
  toMsg(sweep.planes, *planes);
  auto map = boost::make_shared<HeightMap>();
  map->header = header;
  toMsg(grid, *map);
  map->info.map_load_time = header.stamp;
  if (fused_) fused_->map().uncertainty(sweep.end, fused_->travelled(), map->sigmas, map->ages);
  else core::sweepUncertainty(grid, core::meanOrigin(sweep), map_noise_, map->sigmas);
  planes_pub_.publish(planes);
  map_pub_.publish(map);
  if (grid_pub_.getNumSubscribers() > 0) {
    auto occupancy = boost::make_shared<nav_msgs::OccupancyGrid>();
    occupancy->header = header;
    toOccupancyGrid(grid, *occupancy);
    occupancy->info.map_load_time = header.stamp;
    grid_pub_.publish(occupancy);
  }
  std::vector<core::Plane> kept;  // the fused map's planes, which its plane ids name
  if (fused_)
    for (const auto& [id, tp] : fused_->map().planes()) kept.push_back(tp.plane);
  if (steppable_pub_.getNumSubscribers() > 0) {
    core::steppableCells(grid, fused_ ? kept : sweep.planes, foot_, steppable_);
    auto steppable = boost::make_shared<nav_msgs::OccupancyGrid>();
    steppable->header = header;
    steppableGrid(grid, steppable_, *steppable);
    steppable->info.map_load_time = header.stamp;
    steppable_pub_.publish(steppable);
  }
  if (fused_) {
    auto terrain = boost::make_shared<PlanePolygonArray>();
    terrain->header = header;
    toMsg(kept, *terrain);
    terrain_pub_.publish(terrain);
  }
  last_latency_ms_ = 1e3 * (sweep.finish_seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  last_group_ms_ = 1e3 * sweep.group_seconds;
  last_planes_ = sweep.planes.size();
  last_sweep_duration_ = sweep.end - sweep.start;
  sweeps_out_.add(InputHealth::now());
  ++published_;
  checkCalibration(&sweep);
  // The noise model as this sweep shows it, its range noise and its line
  // term (after the outputs: not in the latency).
  const core::SweepNoiseEstimate noise = core::estimateSweepNoise(sweep);
  last_line_sigma_deg_ = noise.line_sigma * 180.0 / M_PI;
  last_range_noise_mm_ = noise.range.along * 1e3;
  // The clouds for rviz are built only while somebody listens.
  const auto publishCloud = [&](ros::Publisher& pub, const auto& fill) {
    if (pub.getNumSubscribers() == 0) return;
    auto c = boost::make_shared<sensor_msgs::PointCloud2>();
    fill(*c);
    c->header = header;
    pub.publish(c);
  };
  publishCloud(map_cloud_pub_, [&](sensor_msgs::PointCloud2& c) { heightMapCloud(grid, c); });
  publishCloud(sweep_cloud_pub_, [&](sensor_msgs::PointCloud2& c) { sweepCloud(sweep, c); });
  publishCloud(edges_pub_, [&](sensor_msgs::PointCloud2& c) { edgeCloud(sweep, c); });
  if (markers_pub_.getNumSubscribers() > 0) {
    auto m = boost::make_shared<visualization_msgs::MarkerArray>();
    planeMarkers(sweep.planes, header, *m);
    markers_pub_.publish(m);
  }
}

void SweepGrouperNodelet::checkCalibration(const core::SweepResult* sweep) {
  if (!calibration_) return;
  if (calibration_->poll() && calibration_->drifted()) warn(calibration_->message());
  if (!sweep) return;
  // The standing robot's base: the chain's base in the frame at the sweep's last beam.
  try {
    calibration_->addSweep(*sweep, tf2::transformToEigen(tf_buffer_->lookupTransform(
                                       frame_id_, parent_link_, ros::Time(core::lastBeamTime(*sweep)))));
  } catch (const tf2::TransformException&) {
  }
}

void SweepGrouperNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> l(mutex_);
  if (!assembler_) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "not ready: %s", chain_error_.c_str());
    return;
  }
  // The present: scans in and sweeps out over the last seconds. A sweep may
  // take a while (a slow tilt), so the stale time is at least three of them.
  const double t = InputHealth::now();
  std::string why;
  const core::Health level =
      health_.judge(scans_in_, sweeps_out_, first_scan_, std::max(stale_after_, 3.0 * last_sweep_duration_), why);
  health_.report(stat, level,
                 why + "; " + std::to_string(sweeps_out_.recent(t)) + " sweeps and " +
                     std::to_string(scans_in_.recent(t)) + " scans in the last 10 s");
  const core::SweepCounters& c = assembler_->counters();
  stat.add("sweeps published", published_);
  stat.add("sweeps published (last 10 s)", sweeps_out_.recent(t));
  stat.add("scans received (last 10 s)", scans_in_.recent(t));
  stat.add("sweeps dropped", c.sweeps_dropped);
  stat.add("tilt reversals", c.reversals);
  stat.add("scan lines used", c.lines);
  stat.add("exceptions caught", exceptions_);
  stat.add("lines waiting", assembler_->pending());
  stat.add("planes (last sweep)", last_planes_);
  stat.add("grouping as lines came [ms] (last sweep)", last_group_ms_);
  stat.add("latency after the last line [ms] (last sweep)", last_latency_ms_);
  stat.addf("line pose error [deg] (last sweep, estimated; ~line_sigma_deg applied)", "%.3f (%.3f)",
            last_line_sigma_deg_, sweep_params_.grouping.line_sigma * 180.0 / M_PI);
  stat.addf("range noise [mm] (last sweep, estimated along its lines)", "%.1f", last_range_noise_mm_);
  if (fused_) {
    stat.add("fused map: distance walked [m]", fused_->travelled());
    stat.add("fused map: terrain planes", fused_->map().planes().size());
  }
  if (calibration_) {
    checkCalibration(nullptr);  // a verdict that came since the last sweep
    stat.add("calibration check", calibration_->message());
    stat.add("calibration checks", calibration_->checks());
    if (calibration_->drifted()) stat.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, "calibration drifted");
  }
}

}  // namespace tilt_laser_perception

PLUGINLIB_EXPORT_CLASS(tilt_laser_perception::SweepGrouperNodelet, nodelet::Nodelet)
