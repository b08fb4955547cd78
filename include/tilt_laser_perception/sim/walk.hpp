/**
 * @file walk.hpp
 * @brief A walking robot for the simulator: the base follows a path (straight,
 *        an arc, with its height following the ground under it, so a walk
 *        can go up a step) at a constant speed, with the bob, sway, yaw and
 *        roll of a humanoid gait on top; and the odometry a robot would
 *        report for it (the true motion, or with drift). ROS-free; [m], [s], [rad].
 *
 * In the simulator `base_footprint` carries the upper body's motion (the head
 * chain above it is rigid); on the robot that motion reaches the grouper
 * through tf from the robot's own state estimate, which is the same to it: it
 * looks up its frame -> the tilt joint's parent at every line's time.
 */
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tilt_laser_perception/sim/scene.hpp"

namespace tilt_laser_perception {
namespace sim {

/// The gait's defaults are those of a ZMP walk of a human-sized humanoid
/// (HRP-4 walks at 0.2-0.3 m/s with steps of about 0.8 s): the head bobs
/// once a step and sways, yaws and rolls once a stride (two steps). They are
/// assumed, not measured on HRP-4: a centimetre of bob is what the issue that
/// asked for walking saw, a few centimetres of sway what a ZMP gait's centre
/// of mass swings over its feet.
struct WalkParams {
  double speed = 0.0;                 ///< along the path [m/s]; 0: the robot stands
  double start_time = 0.0;            ///< the walk begins at this time of the simulator's clock [s]
  Eigen::Vector3d start{0.0, 0.0, 0.0};  ///< x, y [m] and heading [rad] at t = 0
  double turn_radius = 0.0;           ///< 0: straight; > 0 turns left, < 0 right [m]
  double distance = 1e9;              ///< the robot stops after this far [m]
  bool follow_ground = true;          ///< the base's height follows the ground under it (over one step's length)
  double step_period = 0.8;           ///< [s]
  double bob = 0.01;                  ///< vertical amplitude, once a step [m]
  double sway = 0.03;                 ///< lateral amplitude, once a stride [m]
  double yaw = 1.5 * M_PI / 180.0;    ///< yaw amplitude, once a stride [rad]
  double roll = 1.0 * M_PI / 180.0;   ///< roll amplitude, once a stride [rad]
  double odom_scale_error = 0.0;      ///< odometry's distance error [1] (0.02: 2 % long)
  double odom_yaw_drift = 0.0;        ///< odometry's heading error per metre walked [rad/m]
  bool walking() const { return speed > 0.0; }
};

/// Parses one walk option at argv[i] (advancing past its value): --walk SPEED,
/// --path straight|turn|step, --turn-radius R, --walk-distance D, --start X,Y,YAW_DEG,
/// --step-period S, --bob M, --sway M, --gait-yaw-deg D, --gait-roll-deg D,
/// --odom-drift PCT[,DEG_PER_M]. `turn` is a right turn of radius 1.2 m (it
/// clears the stairs scene's steps); `step` walks 1.35 m straight, onto the
/// stairs scene's first tread, and stands there. False when argv[i] is not
/// one of them; throws std::invalid_argument on a bad value.
bool parseWalkOption(int argc, char** argv, int& i, WalkParams& walk);
const char* walkOptionsUsage();

/// Thread-safe once made.
class WalkModel {
 public:
  /// `scene` gives the ground's height for follow_ground (read once, here).
  WalkModel(const Scene& scene, const WalkParams& params);
  const WalkParams& params() const { return p_; }
  /// Distance walked at t [m].
  double travelled(double t) const;
  /// The true pose of base_footprint in the world (the scene's frame) at t
  /// (the start pose before start_time).
  Eigen::Isometry3d truePose(double t) const;
  /// The pose the robot's odometry reports (odom -> base_footprint; odom is
  /// the world at t = 0): the true one, or drifted by the odometry's errors.
  Eigen::Isometry3d odomPose(double t) const;

 private:
  /// Point and heading of the path after s metres.
  void path(double s, Eigen::Vector2d& p, double& heading) const;
  /// Mean ground height over one step's length centred at s.
  double groundHeight(double s) const;
  WalkParams p_;
  std::vector<double> prefix_;  ///< prefix sums of the ground's height every 1 cm of the path (the first 100 m)
};

}  // namespace sim
}  // namespace tilt_laser_perception
