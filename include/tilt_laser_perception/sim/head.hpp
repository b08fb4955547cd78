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
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tilt_laser_perception/core/calibration.hpp"
#include "tilt_laser_perception/core/tilt_profile.hpp"
#include "tilt_laser_perception/sim/lidar_sim.hpp"
#include "tilt_laser_perception/sim/walk.hpp"

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

  /// Position control: to `goal` (leaves velocity control).
  void setGoal(double t, double goal);
  /// Velocity control (the MX-64's wheel mode, 2.0's velocity control): turns
  /// at `w` [rad/s] (within kMaxVelocity, reached at the acceleration limit)
  /// without end, until setGoal.
  void setGoalVelocity(double t, double w);
  /// Back to position control within one turn of the centre, where it stands
  /// (the turns made in velocity control forgotten, as a servo's encoder does).
  void wrapToOneTurn(double t);
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
  /// What the servo's encoder reports at time t: the position plus the
  /// reading noise set by setReadingNoise (none by default).
  double reading(double t);
  /// Gaussian noise of every reading [rad, standard deviation]; deterministic for a seed.
  void setReadingNoise(double sigma, std::uint64_t seed);
  double velocityLimit() const;

 private:
  void advance(double t);
  double historyAt(double t) const;  // t < t_; mutex held
  mutable std::mutex mutex_;
  double t_, pos_, vel_ = 0.0, goal_, vmax_ = kMaxVelocity, amax_ = 200.0;
  bool torque_ = true;
  bool velocity_mode_ = false;
  double wheel_ = 0.0;  // velocity control's goal [rad/s]
  std::deque<std::pair<double, double>> history_;  // (t, position), 1 ms apart
  double reading_sigma_ = 0.0;
  std::mt19937_64 reading_rng_;
};

/// The errors of a real tilting rig: what stands between the joint angle the
/// servo reports, the stamp the laser's driver gives a scan, and where the
/// beams really went. The head's believed geometry (HeadGeometry, head.yaml)
/// stays as it is; these are the truth's departures from it. All zero: the
/// ideal rig of the package's earlier figures. See rigErrorsRealistic() for
/// a set typical of a real head and where its values come from.
struct RigErrors {
  double tilt_noise = 0.0;    ///< encoder noise of every joint reading [rad, sigma]
  bool quantize = false;      ///< joint readings in the MX-64's 4096 steps a turn (evaluate always quantizes)
  double backlash = 0.0;      ///< gear play [rad, full width]: the laser follows the horn only when pushed, lagging by up to half of it
  double time_offset = 0.0;   ///< a scan's stamp minus the true time of its beam 0 [s] (positive: stamped late)
  double line_jitter = 0.0;   ///< per-scan error of that stamp [s, sigma] (USB and host timing)
  double joint_offset = 0.0;  ///< true tilt minus the reported one [rad] (a horn mounted a tooth off, a zero not set)
  double mount_roll = 0.0;    ///< laser rotated about its own x axis on the tilt link [rad]
  double mount_yaw = 0.0;     ///< laser rotated about its own z axis on the tilt link [rad]

  /// The four a calibration estimates (the same conventions): what a perfect calibration gives.
  core::HeadCalibration calibration() const { return {joint_offset, time_offset, mount_roll, mount_yaw}; }
};

/// The realistic set (`--realistic`): encoder noise 0.5 step (0.044 deg) and
/// quantization, backlash 0.3 deg, time offset 5 ms, per-line jitter 1 ms,
/// joint offset 0.5 deg, mount roll 0.3 deg and yaw 0.3 deg; for the laser a
/// footprint of 1 deg (NoiseParams::footprint). doc/simulator.md says where each comes from.
void setRealistic(RigErrors& rig, NoiseParams& noise);

/// Parses one rig option at argv[i] (advancing i past its value): --tilt-noise-deg,
/// --backlash-deg, --time-offset-ms, --line-jitter-ms, --joint-offset-deg,
/// --mount-error-deg DEG (roll and yaw) or ROLL,YAW, --footprint-deg, --realistic
/// (the set above; options after it change single values). Returns false when
/// argv[i] is not one of them; throws std::invalid_argument on a bad value.
bool parseRigOption(int argc, char** argv, int& i, RigErrors& rig, NoiseParams& noise);
/// The usage lines of those options.
const char* rigOptionsUsage();

/// How the laser sits on the head. Frames: base (the robot's base_footprint),
/// the tilt axis at `axis_origin` (y axis = tilt axis; a positive tilt pitches
/// the laser down), and the laser at `laser_offset` in the tilting frame.
///
/// A spinning head (`spinning`): the joint's axis is the base's x axis
/// pitched down by `spin_pitch` (the spindle), the laser at `laser_offset` in
/// the turning frame with its scan plane containing the spin axis, or turned
/// from it by `laser_to_axis` about the laser's y axis (the tilted variant).
/// At joint angle 0 the scan plane is the spindle's x-y plane; a turn about
/// the axis sweeps every plane through it twice (a half turn sees all).
struct HeadGeometry {
  Eigen::Vector3d axis_origin{0.0, 0.0, 1.40};   ///< tilt axis (spinning: the spindle's origin) in the base frame [m]
  Eigen::Vector3d laser_offset{0.05, 0.0, 0.06}; ///< laser origin in the tilting (turning) frame [m]
  double tilt_offset = 0.0;                      ///< joint angle at servo centre [rad]
  bool spinning = false;
  double spin_pitch = 0.0;                       ///< spinning: the spin axis below the horizontal [rad]
  double laser_to_axis = 0.0;                    ///< spinning: the scan plane's turn from the axis [rad]

  /// Pose of the laser frame in the base frame for a joint angle [rad].
  Eigen::Isometry3d laserPose(double tilt) const;
  /// The chain the assembler puts lines in 3D with (the same poses).
  core::TiltChain chain() const;
  /// Loads axis_origin, laser_offset, tilt_offset_deg, spinning, spin_pitch_deg,
  /// laser_to_axis_deg from a YAML file (missing keys keep defaults).
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
  std::vector<float> tilt;  ///< true tilt of the laser at each beam's own time [rad] (the rig's errors in it)
};

/// Scans of a scene from the tilting head. Not thread-safe by itself.
class HeadSimulator {
 public:
  HeadSimulator(const Scene& scene, const HeadGeometry& head, ServoModel& servo, const NoiseParams& noise,
                std::uint64_t seed, const LidarModel& model = LidarModel(), const RigErrors& rig = RigErrors());
  /// Simulates the scan stamped t0 (its beam 0 at t0 - rig.time_offset, plus
  /// the line's jitter; the servo must have been driven up to t0 + scan time).
  /// Scans must come in time order (the gear play has a state).
  void scan(double t0, HeadScan& out);
  const LidarModel& model() const { return lidar_.model(); }
  const HeadGeometry& head() const { return head_; }
  const RigErrors& rig() const { return rig_; }
  /// A walking robot (kept by pointer; null: the base stands at the scene's
  /// origin): every beam from the base's true pose at its own time.
  void setWalk(const WalkModel* walk) { walk_ = walk; }

 private:
  const Scene& scene_;
  HeadGeometry head_;
  ServoModel& servo_;
  LidarSimulator lidar_;
  RigErrors rig_;
  Eigen::Isometry3d mount_;
  std::mt19937_64 rng_;
  bool load_set_ = false;
  double load_ = 0.0;  // the laser's side of the gear play [rad]
  const WalkModel* walk_ = nullptr;
};

/// The true height map of a scene: for each cell centre, the height of the
/// highest face point above it, NaN where there is none. Row-major, x along
/// rows: cell (ix, iy) at origin + ((ix + 0.5) r, (iy + 0.5) r).
std::vector<float> trueHeightMap(const Scene& scene, double origin_x, double origin_y, double resolution, int width,
                                 int height);

}  // namespace sim
}  // namespace tilt_laser_perception
