#include "tilt_laser_perception/core/tilt_profile.hpp"

#include <cmath>
#include <sstream>

namespace tilt_laser_perception {
namespace core {

std::string TiltProfileParams::validate() const {
  std::ostringstream s;
  if (!(std::isfinite(min_angle) && std::isfinite(max_angle) && max_angle > min_angle))
    s << "max_angle must be above min_angle";
  else if (std::abs(min_angle) > 3.1 || std::abs(max_angle) > 3.1)
    s << "tilt angles must be within +-3.1 rad";
  else if (!(speed > 0.0 && speed <= 6.6))
    s << "speed must be in (0, 6.6] rad/s (the MX-64's no-load speed), got " << speed;
  else if (!(acceleration > 0.0))
    s << "acceleration must be > 0";
  else if (mode == Mode::StepHold && !(step > 0.0 && step <= max_angle - min_angle))
    s << "step must be in (0, max_angle - min_angle]";
  else if (mode == Mode::StepHold && !(hold_time >= 0.0))
    s << "hold_time must be >= 0";
  else if (!(tolerance > 0.0))
    s << "tolerance must be > 0";
  else if (mode == Mode::Spin && !(spin_span > 0.0 && spin_span <= 2.0 * M_PI + 1e-9))
    s << "spin_span must be in (0, 2 pi] rad";
  return s.str();
}

void TiltProfile::restart() {
  started_ = false;
  cmd_sent_ = false;
  in_sweep_ = false;
  reached_at_ = -1.0;
}

void TiltProfile::nextSweep(double t, double angle, bool upward, Sweep& done, bool* ended) {
  if (in_sweep_ && ended) {
    done.id = next_id_++;
    done.start_time = sweep_start_t_;
    done.end_time = t;
    done.start_angle = sweep_start_angle_;
    done.end_angle = angle;
    done.upward = upward;
    *ended = true;
  }
  in_sweep_ = true;
  sweep_start_t_ = t;
  sweep_start_angle_ = angle;
}

bool TiltProfile::updateSpin(double t, double pos, TiltCommand& cmd, Sweep& done, bool* ended) {
  // The goal is kept more than half a turn ahead, so the servo never slows
  // for it; a sweep ends each time the position passes a multiple of the span.
  if (!started_) {
    started_ = true;
    spin_last_ = pos;
  }
  const double k = std::floor(pos / p_.spin_span);
  if (k > std::floor(spin_last_ / p_.spin_span)) nextSweep(t, k * p_.spin_span, true, done, ended);
  spin_last_ = pos;
  if (goal_ - pos > M_PI && cmd_sent_) return false;
  goal_ = pos + 2.0 * M_PI;
  cmd_sent_ = true;
  cmd = {goal_, p_.speed};
  return true;
}

bool TiltProfile::update(double t, double pos, TiltCommand& cmd, Sweep& done, bool* ended) {
  if (ended) *ended = false;
  if (p_.mode == TiltProfileParams::Mode::Spin) return updateSpin(t, pos, cmd, done, ended);
  const bool step_mode = p_.mode == TiltProfileParams::Mode::StepHold;
  if (!started_) {
    // Go to the nearer end first; the first sweep starts there.
    started_ = true;
    up_ = pos > 0.5 * (p_.min_angle + p_.max_angle);  // at the far end we will sweep down (up_ flips on arrival)
    goal_ = up_ ? p_.max_angle : p_.min_angle;
    cmd = {goal_, p_.speed};
    reached_at_ = -1.0;
    return true;
  }
  if (std::abs(pos - goal_) > p_.tolerance) {
    reached_at_ = -1.0;
    return false;
  }
  const bool at_end = std::abs(goal_ - (up_ ? p_.max_angle : p_.min_angle)) < 1e-9;
  if (step_mode) {
    if (reached_at_ < 0.0) reached_at_ = t;
    if (t - reached_at_ < p_.hold_time) return false;  // hold still for a scan
  }
  if (at_end) {
    // A reversal: the sweep in progress ends here, the next begins.
    nextSweep(t, pos, up_, done, ended);
    up_ = !up_;
  }
  if (step_mode) {
    const double dir = up_ ? 1.0 : -1.0;
    double next = goal_ + dir * p_.step;
    if ((up_ && next > p_.max_angle) || (!up_ && next < p_.min_angle)) next = up_ ? p_.max_angle : p_.min_angle;
    goal_ = next;
  } else {
    goal_ = up_ ? p_.max_angle : p_.min_angle;
  }
  reached_at_ = -1.0;
  cmd = {goal_, p_.speed};
  return true;
}

}  // namespace core
}  // namespace tilt_laser_perception
