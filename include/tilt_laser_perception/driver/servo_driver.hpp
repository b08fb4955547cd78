/**
 * @file servo_driver.hpp
 * @brief The tilt servo loop: drives an MX-64 through the tilt profile, reads
 *        its joint state at a fixed rate (stamped at the midpoint of request
 *        and reply), watches its health, and recovers from faults (no reply,
 *        bad packets, hardware errors, the port vanishing) without a restart.
 *        ROS-free; one thread of its own.
 */
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "tilt_laser_perception/core/tilt_profile.hpp"
#include "tilt_laser_perception/dynamixel/bus.hpp"

namespace tilt_laser_perception {
namespace driver {

struct ServoDriverOptions {
  std::string device = "/dev/ttyUSB0";
  int baud = 57600;
  std::uint8_t id = 1;
  dynamixel::Protocol protocol = dynamixel::Protocol::V2;
  bool low_latency = true;
  double rate = 200.0;            ///< joint state reads per second [Hz]
  double timeout = 0.02;          ///< status packet wait beyond the transmit time [s]
  int max_failures = 5;           ///< consecutive failed reads before the port is reopened
  double backoff_min = 0.2;       ///< first wait before reopening [s]; doubles up to backoff_max
  double backoff_max = 1.0;       ///< [s] (back within about 1 s of the fault's end)
  double recover_after = 1.0;     ///< a shutdown by a hardware error is cleared after this long [s]
  double joint_offset = 0.0;      ///< joint angle at the servo's centre [rad]
  int direction = 1;              ///< +1 or -1: joint angle = direction * servo angle + offset
  /// A read whose round trip exceeds the shortest of the last 64 by more than
  /// twice this is not published: its stamp (the midpoint) is that uncertain,
  /// since the thread or the line was held up somewhere between request and
  /// reply (the position is still used to drive the profile) [s].
  double max_stamp_uncertainty = 0.001;
  core::TiltProfileParams profile;
};

/// One joint state, stamped when the position was read.
struct JointSample {
  double stamp = 0.0;     ///< host wall time [s]: midpoint of request and reply
  double position = 0.0;  ///< joint angle [rad]
  double velocity = 0.0;  ///< [rad/s]
  double effort = 0.0;    ///< load as a fraction of the maximum torque (1.0), or current [A] (2.0)
  double round_trip = 0.0;  ///< from request to reply [s]
};

/// A snapshot for diagnostics.
struct ServoStatus {
  bool connected = false;
  std::uint16_t model = 0;
  double temperature = 0.0, voltage = 0.0, effort = 0.0;  ///< [deg C], [V], as in JointSample
  std::uint8_t hardware_error = 0;
  std::string hardware_error_names;
  dynamixel::BusCounters bus;
  unsigned long reopens = 0, hardware_error_events = 0, samples = 0, sweeps = 0, aborted_sweeps = 0;
  unsigned long torque_restores = 0;  ///< torque found off with no hardware error and switched on again
  unsigned long late_reads = 0;       ///< reads not published: their round trip made the stamp uncertain
  /// The servo's own position limits as it reported them at start, as joint angles [rad]
  /// (1.0: CW/CCW Angle Limit; 2.0: Min/Max Position Limit).
  double limit_min = 0.0, limit_max = 0.0;
  unsigned long clamped_goals = 0;    ///< tilt goals beyond those limits, sent clamped to them
  unsigned long refused_writes = 0;   ///< writes the servo answered with an error (see last_refusal)
  std::string last_refusal;
  std::string last_error;
};

class ServoDriver {
 public:
  enum class Level { Info, Warn, Error };
  using JointCallback = std::function<void(const JointSample&)>;
  /// A finished sweep (complete), or one dropped by a fault (not complete).
  using SweepCallback = std::function<void(const core::Sweep&, bool complete)>;
  using LogCallback = std::function<void(Level, const std::string&)>;

  ServoDriver(const ServoDriverOptions& options, JointCallback on_joint, SweepCallback on_sweep, LogCallback log);
  ~ServoDriver();
  /// Starts the thread.
  void start();
  /// Stops the thread (joins within one loop period plus a timeout) and switches the torque off.
  void stop();
  ServoStatus status() const;

 private:
  void run();
  bool openAndConfigure();
  dynamixel::TxResult readState(JointSample& s, std::uint8_t& error_byte);
  void sendCommand(const core::TiltCommand& cmd);
  /// Writes a register, and meets the servo's refusals: a 2.0 EEPROM write
  /// refused with the torque on (access error) is made again with the torque
  /// off; any other error is logged with the register, the model and the
  /// e-manual's meaning. True when the value was written.
  bool writeChecked(const dynamixel::Reg& reg, std::uint32_t value);
  /// Reads the servo's position limits (and puts it in joint / position control mode).
  bool readLimits();
  void handleHardwareError(std::uint8_t bits, double now);
  void dropSweep(const std::string& why);
  void sleepUntil(double t);
  bool spinning() const { return opt_.profile.mode == core::TiltProfileParams::Mode::Spin; }
  /// Spinning: the servo's angle with the turns counted (1.0 reports one turn).
  double unwrapped(double servo_rad);
  double toJoint(double servo_rad) const { return opt_.direction * servo_rad + opt_.joint_offset; }
  double toServo(double joint) const { return (joint - opt_.joint_offset) / opt_.direction; }

  ServoDriverOptions opt_;
  JointCallback on_joint_;
  SweepCallback on_sweep_;
  LogCallback log_;
  dynamixel::PortHandler port_;
  dynamixel::Bus bus_;
  core::TiltProfile profile_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  mutable std::mutex status_mutex_;
  ServoStatus status_;
  double last_velocity_cmd_ = -1.0, hw_error_since_ = -1.0;
  double spin_angle_ = 0.0, last_servo_rad_ = 0.0;  ///< spinning: the angle turned through, the last reading
  bool have_spin_angle_ = false;
  std::int32_t goal_min_ = 0, goal_max_ = 4095;  ///< raw goal positions the servo takes (its limits)
  std::uint16_t model_ = 0;
};

}  // namespace driver
}  // namespace tilt_laser_perception
