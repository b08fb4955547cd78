/**
 * @file head.hpp
 * @brief The simulated HRP-4 sensor head: an MX-64 servo model (velocity and
 *        acceleration limited motion, with a history for per-beam look-ups),
 *        the mounting of the laser on the tilt joint, a tilt sweep controller,
 *        and scans of a scene taken while the head tilts. ROS-free; time in [s].
 */
#pragma once

#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tilt_laser_perception/core/tilt_profile.hpp"
#include "tilt_laser_perception/sim/lidar_sim.hpp"

namespace tilt_laser_perception {
namespace sim {

/// Motion of the servo horn: moves to the goal with a velocity limit and an
/// acceleration limit (a trapezoidal profile). Thread-safe. Angles [rad],
/// 0 at the servo's centre position (raw 2048).
class ServoModel {
 public:
  struct State {
    double position = 0.0;  ///< [rad]
    double velocity = 0.0;  ///< [rad/s]
    double goal = 0.0;      ///< [rad]
    bool moving = false;
    bool torque = true;
  };

  /// MX-64 at 12 V: 63 rpm no-load speed.
  static constexpr double kMaxVelocity = 63.0 * 2.0 * M_PI / 60.0;

  explicit ServoModel(double initial_position = 0.0, double t0 = 0.0);

  void setGoal(double t, double goal);
  /// Velocity limit [rad/s]; <= 0 or above kMaxVelocity means kMaxVelocity.
  void setVelocityLimit(double t, double v);
  /// Acceleration limit [rad/s^2]; <= 0 or inf means 200 rad/s^2 (the motor's own limit).
  void setAccelerationLimit(double t, double a);
  /// Torque off: the horn coasts to a stop and holds no goal.
  void setTorque(double t, bool on);

  /// State at time t (advances the model; t earlier than the last call is looked up in the history).
  State state(double t);
  /// Position at time t, interpolated from the history (the last 5 s) or advanced to t.
  double positionAt(double t);
  double velocityLimit() const;

 private:
  void advance(double t);
  double historyAt(double t) const;  // t < t_; mutex held
  mutable std::mutex mutex_;
  double t_, pos_, vel_ = 0.0, goal_, vmax_ = kMaxVelocity, amax_ = 200.0;
  bool torque_ = true;
  std::deque<std::pair<double, double>> history_;  // (t, position), 1 ms apart
};

/// How the laser sits on the head. Frames: base (the robot's base_footprint),
/// the tilt axis at `axis_origin` (y axis = tilt axis; a positive tilt pitches
/// the laser down), and the laser at `laser_offset` in the tilting frame.
struct HeadGeometry {
  Eigen::Vector3d axis_origin{0.0, 0.0, 1.40};   ///< tilt axis in the base frame [m]
  Eigen::Vector3d laser_offset{0.05, 0.0, 0.06}; ///< laser origin in the tilting frame [m]
  double tilt_offset = 0.0;                      ///< joint angle at servo centre [rad]

  /// Pose of the laser frame in the base frame for a joint angle [rad].
  Eigen::Isometry3d laserPose(double tilt) const;
  /// Loads axis_origin, laser_offset, tilt_offset_deg from a YAML file (missing keys keep defaults).
  static HeadGeometry load(const std::string& path);
};

/// Drives a servo model through the tilt profile the driver uses (sweep or
/// step-and-hold). Call update() often (every millisecond of sim time).
class SweepController {
 public:
  SweepController(ServoModel& servo, const core::TiltProfileParams& params);
  /// Sends the profile's next goal when due; returns true when a sweep ended (its data in *sweep).
  bool update(double t, core::Sweep* sweep = nullptr);

 private:
  ServoModel& servo_;
  core::TiltProfile profile_;
};

/// A scan of the head simulator: the simulated scan plus the joint angle at every beam.
struct HeadScan {
  SimScan scan;
  std::vector<float> tilt;  ///< joint angle at each beam's own time [rad]
};

/// Scans of a scene from the tilting head. Not thread-safe by itself.
class HeadSimulator {
 public:
  HeadSimulator(const Scene& scene, const HeadGeometry& head, ServoModel& servo, const NoiseParams& noise,
                std::uint64_t seed, const LidarModel& model = LidarModel());
  /// Simulates the scan whose beam 0 is at time t0 (the servo must have been driven up to t0 + scan time).
  void scan(double t0, HeadScan& out);
  const LidarModel& model() const { return lidar_.model(); }
  const HeadGeometry& head() const { return head_; }

 private:
  const Scene& scene_;
  HeadGeometry head_;
  ServoModel& servo_;
  LidarSimulator lidar_;
};

/// The true height map of a scene: for each cell centre, the height of the
/// highest face point above it, NaN where there is none. Row-major, x along
/// rows: cell (ix, iy) at origin + ((ix + 0.5) r, (iy + 0.5) r).
std::vector<float> trueHeightMap(const Scene& scene, double origin_x, double origin_y, double resolution, int width,
                                 int height);

}  // namespace sim
}  // namespace tilt_laser_perception
