/**
 * @file calibration.hpp
 * @brief The head calibrates itself: the tilt joint's zero offset, the
 *        servo-to-laser time offset and the laser's roll and yaw on the tilt
 *        link, estimated from a few sweeps of a standing robot by making the
 *        sweeps' planes as flat as they can be, the same surface agree between
 *        the up and the down sweeps, and the floor horizontal at z = 0.
 *        ROS-free; time [s], angles [rad], lengths [m].
 *
 * The model of a beam i of a line stamped t (the assembler's, with the four
 * corrections): p = base_to_joint * R(axis, q(t + i dt - time_offset) +
 * joint_offset) * joint_to_laser * mount(yaw, roll) * x_i, q the reported
 * joint angles interpolated, x_i the beam's point in the laser's frame.
 * The conventions are those of the simulator's rig errors (sim::RigErrors):
 * an estimate is the error itself, so applying it corrects the data.
 *
 * What a scene cannot tell is reported, not invented: a mount pitch (about
 * the laser's y axis, parallel to the tilt axis) is the same as a joint zero
 * offset and is folded into it; without the floor, a joint offset rotates
 * every point about the tilt axis and leaves every plane flat; at one tilt
 * speed, a gear play b looks like a time offset of b / (2 speed) (what the
 * pipeline needs at that speed). A parameter whose standard error exceeds
 * CalibrationOptions::max_standard_error, or whose fit runs to its bound
 * (max_abs: a flat direction of the fit), is held at zero and said so.
 */
#pragma once

#include <array>
#include <deque>
#include <future>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tilt_laser_perception/core/sweep.hpp"

namespace tilt_laser_perception {
namespace core {

/// The head's departures from its believed geometry (all zero: as believed).
struct HeadCalibration {
  double joint_offset = 0.0;  ///< true tilt minus the reported one [rad]
  double time_offset = 0.0;   ///< a scan's stamp minus the true time of its beam 0 [s] (positive: stamped late)
  double mount_roll = 0.0;    ///< laser rotated about its own x axis on the tilt link [rad]
  double mount_yaw = 0.0;     ///< laser rotated about its own z axis on the tilt link [rad]

  static constexpr int kParams = 4;
  double& operator[](int k);
  double operator[](int k) const;
  static const char* name(int k);  ///< "joint_offset", "time_offset", "mount_roll", "mount_yaw"
  /// The mount's rotation (yaw about z, then roll about x).
  Eigen::Isometry3d mount() const;
  /// The chain with the mount applied (joint_to_laser * mount()).
  TiltChain correct(const TiltChain& chain) const;
};

struct CalibrationOptions {
  std::array<bool, HeadCalibration::kParams> estimate{{true, true, true, true}};  ///< which to estimate
  bool floor = true;                ///< the robot stands on a flat floor at z = 0 of the assembly frame
  double floor_angle_deg = 10.0;    ///< a plane this close to horizontal ...
  double floor_height = 0.15;       ///< ... and this close to z = 0 is the floor [m]
  int min_plane_points = 300;       ///< smaller planes are not used
  int max_points_per_plane = 2000;  ///< larger ones are subsampled evenly
  double merge_angle_deg = 3.0;     ///< one surface in two sweeps: normals this close ...
  double merge_distance = 0.03;     ///< ... and each centroid this close to the other's plane [m]
  double trim_sigma = 3.0;          ///< points farther from their plane than this many rms are outliers
  int max_iterations = 30;
  /// A parameter with a larger standard error is not observable here: held at zero [rad, s].
  std::array<double, HeadCalibration::kParams> max_standard_error{{0.1 * M_PI / 180.0, 0.002, 0.2 * M_PI / 180.0,
                                                                   0.2 * M_PI / 180.0}};
  /// The largest error a head can have here: an estimate that reaches it is
  /// not fixed by the scene (a flat direction of the fit, e.g. a roll of 90
  /// degrees that lays each line along the tilt axis) and is held [rad, s].
  std::array<double, HeadCalibration::kParams> max_abs{{5.0 * M_PI / 180.0, 0.03, 3.0 * M_PI / 180.0,
                                                        3.0 * M_PI / 180.0}};
  /// The largest change of one iteration (a trust region) [rad, s].
  std::array<double, HeadCalibration::kParams> max_step{{0.5 * M_PI / 180.0, 0.005, 0.5 * M_PI / 180.0,
                                                         0.5 * M_PI / 180.0}};
  /// Empty when valid, else a message naming the option.
  std::string validate() const;
};

struct CalibrationResult {
  bool ok = false;                  ///< false: too little data (why in notes)
  HeadCalibration calibration;      ///< the estimate (held parameters zero)
  /// Standard errors, cluster-robust: the residuals of one scan line on one
  /// plane share that line's errors (its stamp's jitter, the joint's reading),
  /// so each such piece counts as one observation, not as its beams.
  HeadCalibration standard_error;
  std::array<bool, HeadCalibration::kParams> estimated{};  ///< false: not asked for, or not observable (notes say which)
  std::vector<std::string> notes;   ///< what the data could and could not tell
  double rms_before = 0.0;          ///< point-to-plane rms with the believed geometry [m]
  double rms_after = 0.0;           ///< with the estimate [m]
  int sweeps = 0, up_sweeps = 0, surfaces = 0, points = 0, floor_points = 0, iterations = 0;
};

/// Collects a recording's sweeps (as the assembler made them with the
/// believed geometry) and its joint states, then estimates the calibration.
/// The chain's base must stand still in the assembly frame (a standing robot).
class HeadCalibrator {
 public:
  explicit HeadCalibrator(const TiltChain& chain, const CalibrationOptions& options = CalibrationOptions());
  /// The reported joint angles, in time order (others are dropped).
  void addJoint(double t, double q);
  /// A sweep: its planes' points are kept (in the laser's frame, with their times).
  void addSweep(const SweepResult& sweep);
  int sweeps() const { return sweeps_; }
  CalibrationResult solve() const;

  /// One line: "joint_offset_deg=... time_offset_ms=... mount_roll_deg=...
  /// mount_yaw_deg=... plane_rms_before_m=... plane_rms_after_m=..." and the
  /// standard errors (…_se=), "held" for a parameter not estimated.
  static std::string summary(const CalibrationResult& r);

 private:
  struct Sample {
    Eigen::Vector3d x;  ///< in the laser's frame [m]
    double t;           ///< the beam's stamped time [s]
    int line;           ///< its scan line in the sweep (the points of one line share its errors)
  };
  struct Patch {        ///< one plane of one sweep
    std::vector<Sample> samples;
    int sweep = 0;
    int direction = 0;  ///< +1 tilting up (q increasing), -1 down
  };
  TiltChain chain_;
  CalibrationOptions o_;
  std::vector<std::pair<double, double>> joints_;
  std::vector<Patch> patches_;
  int sweeps_ = 0;
};

/// Watches a running head's calibration: the joint states and sweeps of a
/// window, solved (subsampled) when the window is full, and whether the head
/// has drifted from its calibration (it was knocked, the horn slipped a
/// tooth): an estimate beyond its limit and beyond `sigmas` standard errors.
/// For a standing robot (the chain's base fixed); not thread-safe by itself.
struct CalibrationWatchOptions {
  int sweeps = 8;                   ///< sweeps in a window (half up, half down)
  double period = 60.0;             ///< a window starts this long after the last one began [s] (the check's cost: once a minute)
  CalibrationOptions calibration = watchDefaults();
  std::array<double, HeadCalibration::kParams> limit{{0.2 * M_PI / 180.0, 0.002, 0.3 * M_PI / 180.0,
                                                     0.3 * M_PI / 180.0}};  ///< drift beyond these is reported [rad, s]
  double sigmas = 3.0;
  /// The estimator's options for a live check: few points a plane (cheap), the rest as calibrate's.
  static CalibrationOptions watchDefaults() {
    CalibrationOptions o;
    o.max_points_per_plane = 150;
    return o;
  }
};

class CalibrationWatch {
 public:
  explicit CalibrationWatch(const TiltChain& chain, const CalibrationWatchOptions& options = CalibrationWatchOptions());
  void addJoint(double t, double q);
  /// Adds a finished sweep; when it fills the window, returns the window's
  /// estimator (its joints and sweeps); else null. A window begins with the
  /// first sweep that starts `period` after the last window began.
  /// The caller solves it (on a thread of its own: it takes tens of milliseconds).
  std::unique_ptr<HeadCalibrator> addSweep(const SweepResult& sweep);
  /// Judges a window's result: true when the head has drifted; `message` says
  /// what it found and what it would suggest, or that it holds.
  bool judge(const CalibrationResult& r, std::string& message) const;

 private:
  TiltChain chain_;
  CalibrationWatchOptions o_;
  std::unique_ptr<HeadCalibrator> current_;        ///< the window being collected; null between windows
  std::deque<std::pair<double, double>> recent_;  ///< the last seconds of joint states, for the next window
  double next_start_ = -1e300;                    ///< the next window's first sweep starts at or after this [s]
};

/// The live calibration check of a running head (the grouper's): a
/// CalibrationWatch over the sweeps of a robot that stands, each full window
/// solved on a thread of its own (one at a time; a window that fills while
/// one runs is skipped), and its verdict. A base that moved (a walk, in a
/// fixed frame) starts the window again at its new place. Not thread-safe by
/// itself: call it from one thread (the solve runs apart).
class CalibrationMonitor {
 public:
  /// `chain`: the head's, its base that of the chain in the sweeps' frame up to `base` below.
  CalibrationMonitor(const TiltChain& chain, const CalibrationWatchOptions& options);
  ~CalibrationMonitor();  ///< waits for a check that runs
  void addJoint(double t, double q);
  /// A finished sweep, and the chain's base in the sweeps' frame at its last beam.
  void addSweep(const SweepResult& sweep, const Eigen::Isometry3d& base);
  /// Takes the verdict of a check that finished since: true when one came.
  bool poll();
  bool drifted() const { return drifted_; }
  /// What the last check found ("no check yet", or that the robot must stand still).
  const std::string& message() const { return message_; }
  unsigned long checks() const { return checks_; }

 private:
  TiltChain chain_;
  CalibrationWatchOptions o_;
  std::unique_ptr<CalibrationWatch> watch_;
  Eigen::Isometry3d base_ = Eigen::Isometry3d::Identity();  ///< the chain's base when the window began
  std::future<CalibrationResult> check_;
  std::string message_ = "no check yet";
  bool drifted_ = false;
  unsigned long checks_ = 0;
};

}  // namespace core
}  // namespace tilt_laser_perception
