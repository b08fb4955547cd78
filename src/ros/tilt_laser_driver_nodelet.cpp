#include "tilt_laser_perception/ros/tilt_laser_driver_nodelet.hpp"
#include "tilt_laser_perception/ros/input_health.hpp"

#include <boost/make_shared.hpp>
#include <pluginlib/class_list_macros.hpp>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/MultiEchoLaserScan.h>

#include "tilt_laser_perception/TiltSweep.h"

namespace tilt_laser_perception {

namespace {
/// The angles, times and range limits of a LaserScan or MultiEchoLaserScan.
template <class Msg>
void scanGeometry(const scip::UtmScan& s, Msg& m) {
  m.angle_min = s.angle_min;
  m.angle_max = s.angle_max;
  m.angle_increment = s.angle_increment;
  m.time_increment = s.time_increment;
  m.scan_time = s.scan_time;
  m.range_min = s.range_min;
  m.range_max = s.range_max;
}
}  // namespace

TiltLaserDriverNodelet::~TiltLaserDriverNodelet() {
  diagnostics_timer_.stop();
  // Both loops poll their stop flag at least every 0.1 s and their I/O has timeouts: joined within 2 s.
  if (servo_) servo_->stop();
  if (laser_) laser_->stop();
}

void TiltLaserDriverNodelet::log(int level, const std::string& msg) {
  // Throttled per message kind (its first 30 characters): a fault that repeats is said every 5 s.
  const std::string key = msg.substr(0, 30);
  {
    std::lock_guard<std::mutex> l(log_mutex_);
    const ros::WallTime now = ros::WallTime::now();
    auto it = last_log_.find(key);
    if (level > 0 && it != last_log_.end() && (now - it->second).toSec() < 5.0) return;
    last_log_[key] = now;
  }
  if (level == 0) NODELET_INFO("%s", msg.c_str());
  else if (level == 1) NODELET_WARN("%s", msg.c_str());
  else NODELET_ERROR("%s", msg.c_str());
}

namespace {
/// Reads `name`, or else the parameter's old name `old` with a warning once, or else the default.
template <typename T>
void paramRenamed(ros::NodeHandle& pnh, const std::string& name, const std::string& old, T& value, const T& fallback) {
  if (pnh.getParam(name, value)) return;
  if (pnh.getParam(old, value)) {
    ROS_WARN("%s: ~%s is read as ~%s (urg_node's name); please rename it", pnh.getNamespace().c_str(), old.c_str(),
             name.c_str());
    return;
  }
  value = fallback;
}
}  // namespace

void TiltLaserDriverNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  loads_ = countLoad(getName());
  loaded_at_ = ros::WallTime::now();

  driver::LaserDriverOptions lo;
  // urg_node's names (REP 138), the old ones still read with a warning.
  paramRenamed(pnh, "ip_address", "laser_ip", lo.host, std::string("192.168.0.10"));
  paramRenamed(pnh, "ip_port", "laser_port", lo.port, 10940);
  paramRenamed(pnh, "serial_port", "laser_serial_device", lo.serial_device, std::string());
  pnh.param("angle_min", lo.client.angle_min, -2.35619449);
  pnh.param("angle_max", lo.client.angle_max, 2.35619449);
  pnh.param("cluster", lo.client.cluster, 1);
  pnh.param("skip", lo.client.skip, 0);
  paramRenamed(pnh, "publish_intensity", "intensity", lo.client.intensity, false);
  // ~echo: first (MD/ME, any UTM-30LX), last or strongest (ND/NE, the -EW's
  // multi-echo): the echo `scan` carries. ~publish_multiecho (urg_node's):
  // every echo on `echoes` too. The old ~echo: multi with ~scan_echo still works.
  std::string echo, scan_echo;
  bool publish_multiecho = false;
  pnh.param<std::string>("echo", echo, "first");
  pnh.param<std::string>("scan_echo", scan_echo, echo == "multi" ? "first" : echo);
  pnh.param("publish_multiecho", publish_multiecho, false);
  if (echo == "multi") {
    NODELET_WARN("~echo: multi is now ~publish_multiecho: true (with ~echo the echo scan carries)");
    publish_multiecho = true;
  }
  if (publish_multiecho) echo = "multi";
  multi_echo_out_ = echo == "multi";
  if (!multi_echo_out_ && !scip::parseEchoChoice(echo, scan_echo_)) {
    NODELET_ERROR("~echo must be first, last, strongest or multi, got '%s': using first", echo.c_str());
    echo = "first";
  }
  if (multi_echo_out_ && !scip::parseEchoChoice(scan_echo, scan_echo_)) {
    NODELET_ERROR("~scan_echo must be first, last or strongest, got '%s': using first", scan_echo.c_str());
    scan_echo_ = scip::EchoChoice::First;
  }
  lo.client.multi_echo = multi_echo_out_ || scan_echo_ != scip::EchoChoice::First;
  // The strongest echo needs the echoes' intensities.
  if (scan_echo_ == scip::EchoChoice::Strongest) lo.client.intensity = true;
  pnh.param("watchdog", lo.client.watchdog, 1.0);
  pnh.param("time_offset", lo.client.time_offset, 0.0);
  pnh.param("clock_sync_period", lo.client.ii_period, 0.1);
  pnh.param<std::string>("frame_id", frame_id_, "laser");

  driver::ServoDriverOptions so;
  int id = 1, protocol = 2, direction = 1;
  pnh.param<std::string>("servo_device", so.device, "/dev/ttyUSB0");
  pnh.param("servo_baud", so.baud, 57600);
  pnh.param("servo_id", id, 1);
  pnh.param("servo_protocol", protocol, 2);
  pnh.param("publish_rate", so.rate, 200.0);
  pnh.param("joint_offset", so.joint_offset, 0.0);
  pnh.param("max_stamp_uncertainty", so.max_stamp_uncertainty, 0.001);
  pnh.param("joint_direction", direction, 1);
  pnh.param<std::string>("joint_name", joint_name_, "head_tilt_joint");
  std::string mode;
  pnh.param<std::string>("tilt_mode", mode, "sweep");
  pnh.param("tilt_min", so.profile.min_angle, 0.1745);
  pnh.param("tilt_max", so.profile.max_angle, 1.0472);
  pnh.param("tilt_speed", so.profile.speed, 1.0);
  pnh.param("tilt_acceleration", so.profile.acceleration, 20.0);
  pnh.param("tilt_step", so.profile.step, 0.00873);
  pnh.param("tilt_hold", so.profile.hold_time, 0.035);
  bool enable_laser = true, enable_servo = true;
  pnh.param("enable_laser", enable_laser, true);
  pnh.param("enable_servo", enable_servo, true);

  // Validation, with a clear message; a bad value falls back to its default.
  pnh.param("spin_span", so.profile.spin_span, so.profile.spin_span);
  so.profile.mode = mode == "step_hold" ? core::TiltProfileParams::Mode::StepHold
                    : mode == "spin"    ? core::TiltProfileParams::Mode::Spin
                                        : core::TiltProfileParams::Mode::Sweep;
  if (mode != "sweep" && mode != "step_hold" && mode != "spin")
    NODELET_ERROR("~tilt_mode must be 'sweep', 'step_hold' or 'spin', got '%s': using sweep", mode.c_str());
  const std::string problem = so.profile.validate();
  if (!problem.empty()) {
    NODELET_ERROR("invalid tilt profile (%s): using the defaults", problem.c_str());
    so.profile = core::TiltProfileParams();
  }
  if (protocol != 1 && protocol != 2) {
    NODELET_ERROR("~servo_protocol must be 1 or 2, got %d: using 2", protocol);
    protocol = 2;
  }
  if (id < 0 || id > 252) {
    NODELET_ERROR("~servo_id must be in 0..252, got %d: using 1", id);
    id = 1;
  }
  if (direction != 1 && direction != -1) {
    NODELET_ERROR("~joint_direction must be 1 or -1, got %d: using 1", direction);
    direction = 1;
  }
  if (!(so.rate >= 10.0 && so.rate <= 1000.0)) {
    NODELET_ERROR("~publish_rate must be in [10, 1000] Hz, got %.1f: using 200", so.rate);
    so.rate = 200.0;
  }
  if (!(lo.client.watchdog > 0.05)) {
    NODELET_ERROR("~watchdog must be > 0.05 s: using 1.0");
    lo.client.watchdog = 1.0;
  }
  so.id = static_cast<std::uint8_t>(id);
  so.protocol = protocol == 1 ? dynamixel::Protocol::V1 : dynamixel::Protocol::V2;
  so.direction = direction;

  scan_pub_ = nh.advertise<sensor_msgs::LaserScan>("scan", 20);
  if (multi_echo_out_) echoes_pub_ = nh.advertise<sensor_msgs::MultiEchoLaserScan>("echoes", 20);
  joint_pub_ = nh.advertise<sensor_msgs::JointState>("joint_states", 100);
  sweep_pub_ = nh.advertise<TiltSweep>("tilt_sweep", 10);

  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
  diagnostics_->setHardwareID(enable_laser ? lo.host : "none");
  scan_freq_ = std::make_unique<diagnostic_updater::FrequencyStatus>(
      diagnostic_updater::FrequencyStatusParam(&scan_freq_min_, &scan_freq_max_, 0.0, 5), "scan rate");
  joint_freq_ = std::make_unique<diagnostic_updater::FrequencyStatus>(
      diagnostic_updater::FrequencyStatusParam(&joint_freq_min_, &joint_freq_max_, 0.0, 5), "joint state rate");
  if (enable_laser) {
    diagnostics_->add("laser", this, &TiltLaserDriverNodelet::diagnoseLaser);
    diagnostics_->add(*scan_freq_);
  }
  if (enable_servo) {
    diagnostics_->add("tilt servo", this, &TiltLaserDriverNodelet::diagnoseServo);
    diagnostics_->add(*joint_freq_);
  }
  diagnostics_timer_ = nh.createTimer(ros::Duration(0.5), [this](const ros::TimerEvent&) { diagnostics_->update(); });

  const auto logger = [this](auto level, const std::string& m) { log(static_cast<int>(level), m); };
  if (enable_laser) {
    laser_ = std::make_unique<driver::LaserDriver>(
        lo,
        [this](const scip::UtmScan& s) {
          auto msg = boost::make_shared<sensor_msgs::LaserScan>();
          msg->header.seq = scan_seq_++;
          msg->header.stamp = ros::Time(s.stamp);
          msg->header.frame_id = frame_id_;
          scanGeometry(s, *msg);
          const std::size_t n = s.ranges.size();
          const bool multi = !s.echo_count.empty();
          const bool with_intensity = !s.intensities.empty();
          if (multi && multi_echo_out_) {
            auto e = boost::make_shared<sensor_msgs::MultiEchoLaserScan>();
            e->header = msg->header;
            scanGeometry(s, *e);
            e->ranges.resize(n);
            if (with_intensity) e->intensities.resize(n);
            for (std::size_t i = 0; i < n; ++i) {
              const std::size_t at = i * scip::kMaxEchoes;
              e->ranges[i].echoes.assign(s.echo_ranges.begin() + at, s.echo_ranges.begin() + at + s.echo_count[i]);
              if (with_intensity)
                e->intensities[i].echoes.assign(s.echo_intensities.begin() + at,
                                                s.echo_intensities.begin() + at + s.echo_count[i]);
            }
            echoes_pub_.publish(e);
          }
          if (multi && scan_echo_ != scip::EchoChoice::First) {
            msg->ranges.resize(n);
            if (with_intensity) msg->intensities.resize(n);
            for (std::size_t i = 0; i < n; ++i) {
              const std::size_t at = i * scip::kMaxEchoes;
              const int k = scip::chooseEcho(scan_echo_, s.echo_count[i],
                                             with_intensity ? &s.echo_intensities[at] : nullptr);
              msg->ranges[i] = s.echo_ranges[at + k];
              if (with_intensity) msg->intensities[i] = s.echo_intensities[at + k];
            }
          } else {
            msg->ranges = s.ranges;
            msg->intensities = s.intensities;
          }
          scan_pub_.publish(msg);
          scan_freq_->tick();
        },
        logger);
    laser_->start();
  }
  if (enable_servo) {
    servo_ = std::make_unique<driver::ServoDriver>(
        so,
        [this](const driver::JointSample& j) {
          auto msg = boost::make_shared<sensor_msgs::JointState>();
          msg->header.stamp = ros::Time(j.stamp);
          msg->name = {joint_name_};
          msg->position = {j.position};
          msg->velocity = {j.velocity};
          msg->effort = {j.effort};
          joint_pub_.publish(msg);
          joint_freq_->tick();
        },
        [this](const core::Sweep& s, bool complete) {
          auto msg = boost::make_shared<TiltSweep>();
          msg->header.stamp = ros::Time(s.end_time);
          msg->id = s.id;
          msg->start = ros::Time(s.start_time);
          msg->end = ros::Time(s.end_time);
          msg->start_angle = s.start_angle;
          msg->end_angle = s.end_angle;
          msg->upward = s.upward;
          msg->complete = complete;
          sweep_pub_.publish(msg);
        },
        logger);
    servo_->start();
  }
  NODELET_INFO("TiltLaserDriver: laser %s, servo %s (protocol %d, id %d), tilt %s %.1f..%.1f deg at %.2f rad/s",
               enable_laser ? (lo.serial_device.empty() ? (lo.host + ":" + std::to_string(lo.port)).c_str()
                                                        : lo.serial_device.c_str())
                            : "off",
               enable_servo ? so.device.c_str() : "off", protocol, id, mode.c_str(),
               so.profile.min_angle * 180 / M_PI, so.profile.max_angle * 180 / M_PI, so.profile.speed);
}

void TiltLaserDriverNodelet::diagnoseLaser(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const driver::LaserStatus s = laser_->status();
  const double now = ros::WallTime::now().toSec();
  delayed_win_.add(now, s.delayed_scans - std::min(delayed_seen_, s.delayed_scans));
  impossible_win_.add(now, s.impossible_stamps - std::min(impossible_seen_, s.impossible_stamps));
  // A clock reading that took 10 times the sensor's few ms: replies wait somewhere.
  if (s.clock_rejected > rejected_seen_ && s.last_rejected_rtt > 0.05) slow_reply_win_.add(now);
  delayed_seen_ = s.delayed_scans;
  impossible_seen_ = s.impossible_stamps;
  rejected_seen_ = s.clock_rejected;
  const unsigned long delayed = delayed_win_.recent(now), impossible = impossible_win_.recent(now),
                      slow = slow_reply_win_.recent(now);
  if (!s.streaming)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "not streaming: %s", s.last_error.c_str());
  else if (loads_ > 1 && (ros::WallTime::now() - loaded_at_).toSec() < 60.0)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "reloaded (load %d in this process)", loads_);
  else if (delayed + impossible + slow > 0)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                  "replies delayed: %lu scans late, %lu stamped after they arrived, %lu slow clock readings "
                  "(last round trip %.0f ms) in the last 10 s",
                  delayed, impossible, slow, 1e3 * s.last_rejected_rtt);
  else if (s.scan_rate < 38.0)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "scan rate %.1f Hz (expected 40)", s.scan_rate);
  else
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "streaming");
  stat.add("echoes", s.multi_echo ? "multi-echo (ND/NE)" : "single (MD/ME)");
  addLoadStatus(stat, loads_);
  stat.add("scans arrived late (last 10 s)", delayed);
  stat.add("scans stamped after they arrived (last 10 s)", impossible);
  stat.add("clock readings left out (round trip too long)", s.clock_rejected);
  stat.add("round trip of the last one left out [ms]", 1e3 * s.last_rejected_rtt);
  stat.add("endpoint", s.endpoint);
  stat.add("model", s.info.model);
  stat.add("serial", s.info.serial);
  stat.add("firmware", s.info.firmware);
  stat.add("scan rate [Hz]", s.scan_rate);
  stat.add("stamp delay [ms]", s.stamp_delay * 1e3);
  stat.add("clock offset host-sensor [s]", s.clock_offset);
  stat.add("clock drift [ppm]", s.clock_drift_ppm);
  stat.add("clock samples", s.clock_samples);
  stat.add("scans", s.counters.scans);
  stat.add("checksum errors", s.counters.checksum_errors);
  stat.add("truncated scans", s.counters.truncated);
  stat.add("other bad scans", s.counters.bad_scans + s.counters.error_status);
  stat.add("watchdog timeouts", s.counters.timeouts);
  stat.add("connections", s.counters.connects);
  stat.add("failed connection attempts", s.counters.connect_failures);
  stat.add("reconnects", s.reconnects);
  stat.add("clock jumps (reboots)", s.counters.clock_jumps);
  stat.add("sensor restarts (clock started again)", s.sensor_restarts);
  stat.add("last error", s.last_error);
}

void TiltLaserDriverNodelet::diagnoseServo(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const driver::ServoStatus s = servo_->status();
  if (!s.connected)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "not connected: %s", s.last_error.c_str());
  else if (s.hardware_error)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "hardware error: %s", s.hardware_error_names.c_str());
  else if (s.bus.successRate() < 0.99)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "transactions %.1f %% successful", 100 * s.bus.successRate());
  else
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "ok");
  stat.add("model", s.model);
  stat.add("position limits [deg] (the servo's own)", std::to_string(s.limit_min * 180 / M_PI).substr(0, 6) + " .. " +
                                                         std::to_string(s.limit_max * 180 / M_PI).substr(0, 6));
  stat.add("goals clamped to the limits", s.clamped_goals);
  stat.add("writes refused", s.refused_writes);
  if (!s.last_refusal.empty()) stat.add("last refusal", s.last_refusal);
  stat.add("temperature [C]", s.temperature);
  stat.add("voltage [V]", s.voltage);
  stat.add("effort", s.effort);
  stat.add("hardware error bits", static_cast<int>(s.hardware_error));
  stat.add("hardware errors", s.hardware_error_names.empty() ? "none" : s.hardware_error_names);
  stat.add("hardware error events", s.hardware_error_events);
  stat.add("transactions", s.bus.transactions);
  stat.add("transaction success rate [%]", 100.0 * s.bus.successRate());
  stat.add("timeouts", s.bus.timeouts);
  stat.add("bad packets", s.bus.bad_packets);
  stat.add("garbage bytes", s.bus.garbage_bytes);
  stat.add("port reopens", s.reopens);
  stat.add("torque restores", s.torque_restores);
  stat.add("joint states", s.samples);
  stat.add("joint reads not published (late reply, stamp uncertain)", s.late_reads);
  stat.add("sweeps", s.sweeps);
  stat.add("sweeps dropped", s.aborted_sweeps);
  stat.add("last error", s.last_error);
}

}  // namespace tilt_laser_perception

PLUGINLIB_EXPORT_CLASS(tilt_laser_perception::TiltLaserDriverNodelet, nodelet::Nodelet)
