/**
 * @file tilt_profile.hpp
 * @brief The tilt motion of the head: a continuous triangle sweep between two
 *        angles, or step-and-hold (move a step, stop, hold for a scan). Decides
 *        the servo's next goal from its measured position and reports where
 *        sweeps start and end. ROS-free; angles [rad], time [s].
 */
#pragma once

#include <cstdint>
#include <string>

namespace tilt_laser_perception {
namespace core {

struct TiltProfileParams {
  /// Sweep: to and fro between min_angle and max_angle; StepHold: the same
  /// in steps, holding still for a scan at each; Spin: turning on at `speed`
  /// (the MX-64's wheel or multi-turn mode), a sweep every `spin_span`.
  enum class Mode { Sweep, StepHold, Spin };
  Mode mode = Mode::Sweep;
  double min_angle = 10.0 * 3.14159265358979 / 180.0;  ///< [rad]
  double max_angle = 60.0 * 3.14159265358979 / 180.0;  ///< [rad]
  double speed = 1.0;          ///< velocity limit of the sweep [rad/s]
  double acceleration = 20.0;  ///< acceleration limit [rad/s^2]
  double step = 0.5 * 3.14159265358979 / 180.0;  ///< step-and-hold: angle step [rad]
  double hold_time = 0.035;    ///< step-and-hold: time to hold still at each step [s] (one 25 ms scan and a margin)
  double tolerance = 0.003;    ///< a goal is reached within this [rad]
  double spin_span = 3.14159265358979;  ///< spin: the turn a sweep covers (a half turn sees everything once) [rad]

  /// Empty when valid, else a message naming the bad parameter.
  std::string validate() const;
};

/// A goal for the servo.
struct TiltCommand {
  double goal = 0.0;      ///< [rad]
  double velocity = 0.0;  ///< velocity limit [rad/s]
};

/// A finished sweep: the run between two reversals.
struct Sweep {
  std::uint32_t id = 0;
  double start_time = 0.0, end_time = 0.0;     ///< [s]
  double start_angle = 0.0, end_angle = 0.0;   ///< [rad]
  bool upward = true;                          ///< towards max_angle (tilting down)
};

class TiltProfile {
 public:
  explicit TiltProfile(const TiltProfileParams& params = TiltProfileParams()) : p_(params) {}

  /// Feeds the measured position at time t. Returns true and fills `cmd` when
  /// a new goal must be sent; fills `done` and sets *ended when a sweep ended.
  bool update(double t, double position, TiltCommand& cmd, Sweep& done, bool* ended);

  /// Forgets the sweep in progress (after a fault): the next sweep starts at the next end reached.
  void restart();
  /// A sweep has begun (at a reversal) and not yet ended; it began at sweepStart() [s].
  bool inSweep() const { return in_sweep_; }
  double sweepStart() const { return sweep_start_t_; }
  /// The goal last commanded.
  double goal() const { return goal_; }
  const TiltProfileParams& params() const { return p_; }
  void setParams(const TiltProfileParams& p) { p_ = p; restart(); }

 private:
  TiltProfileParams p_;
  bool started_ = false;   // a goal has been sent
  bool in_sweep_ = false;  // a sweep began at a reversal and has not been dropped
  bool up_ = true;
  double goal_ = 0.0;
  double sweep_start_t_ = 0.0, sweep_start_angle_ = 0.0;
  double spin_last_ = 0.0;  // spin: the position at the last update (unwrapped)
  bool cmd_sent_ = false;   // spin: a goal has been sent since the start
  bool updateSpin(double t, double position, TiltCommand& cmd, Sweep& done, bool* ended);
  /// The sweep in progress (if any) ends at (t, angle) into `done`, the next begins there.
  void nextSweep(double t, double angle, bool upward, Sweep& done, bool* ended);
  double reached_at_ = -1.0;  // step-and-hold: when the current step was reached
  std::uint32_t next_id_ = 0;
};

}  // namespace core
}  // namespace tilt_laser_perception
