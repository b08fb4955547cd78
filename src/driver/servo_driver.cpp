#include "tilt_laser_perception/driver/servo_driver.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "tilt_laser_perception/scip/client.hpp"  // wallNow()

namespace tilt_laser_perception {
namespace driver {

using dynamixel::Protocol;
using dynamixel::TxResult;

ServoDriver::ServoDriver(const ServoDriverOptions& options, JointCallback on_joint, SweepCallback on_sweep,
                         LogCallback log)
    : opt_(options),
      on_joint_(std::move(on_joint)),
      on_sweep_(std::move(on_sweep)),
      log_(std::move(log)),
      bus_(port_, options.protocol),
      profile_(options.profile) {}

ServoDriver::~ServoDriver() { stop(); }

void ServoDriver::start() {
  if (running_) return;
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

void ServoDriver::stop() {
  if (!running_) return;
  running_ = false;
  if (thread_.joinable()) thread_.join();
  if (port_.isOpen()) {
    std::uint8_t e = 0;
    bus_.writeReg(opt_.id, dynamixel::mx64Table(opt_.protocol).torque_enable, 0, &e, true, opt_.timeout);
    port_.close();
  }
}

ServoStatus ServoDriver::status() const {
  std::lock_guard<std::mutex> l(status_mutex_);
  return status_;  // status_.bus is copied from the bus by the servo thread (readState): no race
}

void ServoDriver::sleepUntil(double t) {
  while (running_) {
    const double left = t - dynamixel::monotonicNow();
    if (left <= 0) return;
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(left, 0.05)));
  }
}

void ServoDriver::dropSweep(const std::string& why) {
  if (profile_.inSweep()) {
    core::Sweep s;
    s.start_time = profile_.sweepStart();
    s.end_time = scip::wallNow();
    if (on_sweep_) on_sweep_(s, false);
    std::lock_guard<std::mutex> l(status_mutex_);
    ++status_.aborted_sweeps;
    if (log_) log_(Level::Warn, "tilt sweep in progress dropped: " + why);
  }
  profile_.restart();
}

bool ServoDriver::openAndConfigure() {
  const auto& tab = dynamixel::mx64Table(opt_.protocol);
  std::string err;
  if (!port_.open(opt_.device, opt_.baud, opt_.low_latency, err)) {
    std::lock_guard<std::mutex> l(status_mutex_);
    status_.last_error = err;
    return false;
  }
  bus_.resetParser();
  std::uint16_t model = 0;
  std::uint8_t e = 0;
  TxResult r = TxResult::Timeout;
  // Three silent pings: nobody there. A corrupt reply is somebody there:
  // try on (the bus resynchronises on every request), up to 20 pings.
  for (int i = 0, silent = 0; i < 20 && silent < 3 && r != TxResult::Ok; ++i) {
    r = bus_.ping(opt_.id, &model, &e, opt_.timeout);
    silent += r != TxResult::BadPacket;
  }
  if (r != TxResult::Ok) {
    std::lock_guard<std::mutex> l(status_mutex_);
    status_.last_error = "servo " + std::to_string(opt_.id) + " on " + opt_.device + " does not answer ping: " +
                         dynamixel::txResultName(r);
    port_.close();
    return false;
  }
  if (model != tab.model && log_)
    log_(Level::Warn, "servo model " + std::to_string(model) + " is not an MX-64 (" + std::to_string(tab.model) +
                          "): the control table may differ");
  model_ = model;
  // Restore the configuration: prompt replies, limits, torque. The return
  // delay is EEPROM in both protocols: a 2.0 servo refuses it while its torque
  // is on (a driver restarted under a running head); writeChecked meets that.
  bool ok = writeChecked(tab.return_delay, 0);
  ok = ok && writeChecked(tab.status_return_level, 2);
  ok = ok && writeChecked(tab.torque_enable, 0);
  ok = ok && readLimits();
  if (opt_.protocol == Protocol::V1) {
    ok = ok && writeChecked(tab.goal_acceleration,
                            dynamixel::radPerSec2ToAcceleration(opt_.protocol, opt_.profile.acceleration));
  } else {
    ok = ok && writeChecked(tab.profile_acceleration,
                            dynamixel::radPerSec2ToAcceleration(opt_.protocol, opt_.profile.acceleration));
  }
  ok = ok && writeChecked(tab.torque_enable, 1);
  if (!ok) {
    std::lock_guard<std::mutex> l(status_mutex_);
    status_.last_error = "configuring the servo failed" + (status_.last_refusal.empty() ? "" : ": " + status_.last_refusal);
    port_.close();
    return false;
  }
  last_velocity_cmd_ = -1.0;
  {
    std::lock_guard<std::mutex> l(status_mutex_);
    status_.connected = true;
    status_.model = model;
    status_.last_error.clear();
  }
  if (log_)
    log_(Level::Info, "servo " + std::to_string(opt_.id) + " (model " + std::to_string(model) + ", protocol " +
                          std::to_string(static_cast<int>(opt_.protocol)) + ".0) ready on " + opt_.device);
  return true;
}

bool ServoDriver::writeChecked(const dynamixel::Reg& reg, std::uint32_t value) {
  const bool v1 = opt_.protocol == Protocol::V1;
  const auto& tab = dynamixel::mx64Table(opt_.protocol);
  std::uint8_t e = 0;
  if (bus_.writeReg(opt_.id, reg, value, &e, true, opt_.timeout) != TxResult::Ok) return false;
  const std::uint8_t refusal = dynamixel::refusal(opt_.protocol, e);
  if (!refusal) return true;
  const dynamixel::RegisterInfo* info = dynamixel::mx64RegisterAt(opt_.protocol, reg.addr);
  if (!v1 && refusal == dynamixel::err2::kAccess && info && info->eeprom && info->writable) {
    // "Data in the EEPROM Area can only be written when Torque Enable is 0."
    if (bus_.writeReg(opt_.id, tab.torque_enable, 0, &e, true, opt_.timeout) == TxResult::Ok &&
        bus_.writeReg(opt_.id, reg, value, &e, true, opt_.timeout) == TxResult::Ok &&
        !dynamixel::refusal(opt_.protocol, e)) {
      if (log_)
        log_(Level::Info, std::string("servo: ") + info->name + " (EEPROM) written with the torque off, as the servo asks");
      return true;  // (the configuration switches the torque on again at its end)
    }
  }
  const std::string what = v1 ? dynamixel::hardwareErrorNames(opt_.protocol, refusal) : dynamixel::statusErrorName2(refusal);
  const std::string msg = "servo model " + std::to_string(model_) + " refused writing " + std::to_string(value) +
                          " to address " + std::to_string(reg.addr) + " (" + (info ? info->name : "not in the MX-64's table") +
                          "): " + what +
                          (!v1 && refusal == dynamixel::err2::kAccess && !info ? " (this model has no such register?)" : "");
  {
    std::lock_guard<std::mutex> l(status_mutex_);
    ++status_.refused_writes;
    status_.last_refusal = msg;
  }
  if (log_) log_(Level::Warn, msg);
  return false;
}

bool ServoDriver::readLimits() {
  const bool v1 = opt_.protocol == Protocol::V1;
  const auto& tab = dynamixel::mx64Table(opt_.protocol);
  std::uint8_t e = 0;
  std::uint32_t lo = 0, hi = 4095;
  if (spinning()) {
    // Turning without end: 1.0's wheel mode (CW and CCW Angle Limit 0), 2.0's
    // velocity control (Operating Mode 1); no position limits apply.
    {
      std::lock_guard<std::mutex> l(status_mutex_);
      status_.limit_min = -std::numeric_limits<double>::infinity();
      status_.limit_max = std::numeric_limits<double>::infinity();
    }
    return v1 ? writeChecked(tab.cw_angle_limit, 0) && writeChecked(tab.ccw_angle_limit, 0)
              : writeChecked(tab.operating_mode, 1);
  }
  if (v1) {
    // Joint mode: the goal within CW..CCW Angle Limit. Both 0 is wheel mode
    // (no position control), both 4095 multi-turn: the tilt needs joint mode.
    if (bus_.readReg(opt_.id, tab.cw_angle_limit, lo, &e, opt_.timeout) != TxResult::Ok ||
        bus_.readReg(opt_.id, tab.ccw_angle_limit, hi, &e, opt_.timeout) != TxResult::Ok)
      return false;
    if ((lo == 0 && hi == 0) || (lo == 4095 && hi == 4095)) {
      if (log_) log_(Level::Warn, "servo in wheel or multi-turn mode (CW/CCW angle limits " + std::to_string(lo) + "/" +
                                      std::to_string(hi) + "): setting joint mode over the whole turn");
      lo = 0;
      hi = 4095;
      if (!writeChecked(tab.cw_angle_limit, lo) || !writeChecked(tab.ccw_angle_limit, hi)) return false;
    }
    std::uint32_t torque_limit = 0;
    if (bus_.readReg(opt_.id, tab.torque_limit, torque_limit, &e, opt_.timeout) == TxResult::Ok && torque_limit == 0) {
      if (log_) log_(Level::Warn, "servo torque limit 0: the horn could not move; setting it to the maximum");
      std::uint32_t max_torque = 1023;
      bus_.readReg(opt_.id, tab.max_torque, max_torque, &e, opt_.timeout);
      if (!writeChecked(tab.torque_limit, max_torque ? max_torque : 1023)) return false;
    }
  } else {
    std::uint32_t mode = 3;
    if (bus_.readReg(opt_.id, tab.operating_mode, mode, &e, opt_.timeout) != TxResult::Ok) return false;
    if (mode != 3) {
      if (log_) log_(Level::Warn, "servo operating mode " + std::to_string(mode) + ": setting position control (3)");
      if (!writeChecked(tab.operating_mode, 3)) return false;
    }
    if (bus_.readReg(opt_.id, tab.min_position_limit, lo, &e, opt_.timeout) != TxResult::Ok ||
        bus_.readReg(opt_.id, tab.max_position_limit, hi, &e, opt_.timeout) != TxResult::Ok)
      return false;
  }
  if (hi < lo) std::swap(lo, hi);
  goal_min_ = static_cast<std::int32_t>(lo);
  goal_max_ = static_cast<std::int32_t>(hi);
  const double a = toJoint(dynamixel::positionToRad(goal_min_)), b = toJoint(dynamixel::positionToRad(goal_max_));
  const double jmin = std::min(a, b), jmax = std::max(a, b);
  {
    std::lock_guard<std::mutex> l(status_mutex_);
    status_.limit_min = jmin;
    status_.limit_max = jmax;
  }
  // The sweep between the ends the servo takes: a goal it refuses would stop
  // the head at its limit with the sweep waiting for an end it cannot reach.
  core::TiltProfileParams pp = opt_.profile;
  const double margin = dynamixel::kRadPerStep;
  pp.min_angle = std::max(pp.min_angle, jmin + margin);
  pp.max_angle = std::min(pp.max_angle, jmax - margin);
  if (pp.max_angle <= pp.min_angle) {
    std::lock_guard<std::mutex> l(status_mutex_);
    status_.last_refusal = "the servo's limits leave no tilt range";
    return false;
  }
  if (pp.min_angle != profile_.params().min_angle || pp.max_angle != profile_.params().max_angle) {
    if (log_ && (pp.min_angle != opt_.profile.min_angle || pp.max_angle != opt_.profile.max_angle))
      log_(Level::Warn, "the tilt range " + std::to_string(opt_.profile.min_angle * 180 / M_PI).substr(0, 5) + ".." +
                            std::to_string(opt_.profile.max_angle * 180 / M_PI).substr(0, 5) +
                            " deg goes beyond the servo's own limits " + std::to_string(jmin * 180 / M_PI).substr(0, 5) +
                            ".." + std::to_string(jmax * 180 / M_PI).substr(0, 5) + " deg: sweeping within them");
    profile_.setParams(pp);
  }
  return true;
}

dynamixel::TxResult ServoDriver::readState(JointSample& s, std::uint8_t& error_byte) {
  const bool v1 = opt_.protocol == Protocol::V1;
  // One read: 1.0 position, speed, load (36..41); 2.0 current, velocity, position (126..135).
  const std::uint16_t addr = v1 ? 36 : 126;
  const std::uint16_t len = v1 ? 6 : 10;
  std::vector<std::uint8_t> d;
  const double t0 = scip::wallNow();
  const TxResult r = bus_.read(opt_.id, addr, len, d, &error_byte, opt_.timeout);
  const double t1 = scip::wallNow();
  {
    std::lock_guard<std::mutex> l(status_mutex_);
    status_.bus = bus_.counters();  // found by ThreadSanitizer: status() read them while this thread wrote
    if (r != TxResult::Ok) status_.last_error = std::string("reading the joint state: ") + dynamixel::txResultName(r);
  }
  if (r != TxResult::Ok) return r;
  s.stamp = 0.5 * (t0 + t1);
  s.round_trip = t1 - t0;
  if (v1) {
    const double pos = dynamixel::positionToRad(static_cast<std::int32_t>(dynamixel::getLE(d.data(), 2)));
    s.position = toJoint(unwrapped(pos));
    s.velocity = opt_.direction * dynamixel::velocityToRadPerSec(opt_.protocol, dynamixel::getLE(d.data() + 2, 2));
    s.effort = opt_.direction * dynamixel::loadToFraction(dynamixel::getLE(d.data() + 4, 2));
  } else {
    s.effort = opt_.direction * dynamixel::currentToAmp(opt_.protocol, dynamixel::getLE(d.data(), 2));
    s.velocity = opt_.direction * dynamixel::velocityToRadPerSec(opt_.protocol, dynamixel::getLE(d.data() + 2, 4));
    const auto raw = static_cast<std::int32_t>(dynamixel::getLE(d.data() + 6, 4));
    s.position = toJoint(unwrapped(dynamixel::positionToRad(raw)));
  }
  return TxResult::Ok;
}

double ServoDriver::unwrapped(double servo_rad) {
  // Spinning, 1.0 reports the angle within one turn: the turns are counted
  // here (reads come far faster than half a turn); 2.0's velocity control
  // counts them itself, and this leaves its angle as it is.
  if (!spinning()) return servo_rad;
  if (have_spin_angle_) spin_angle_ += std::remainder(servo_rad - last_servo_rad_, 2.0 * M_PI);
  else spin_angle_ = servo_rad;
  have_spin_angle_ = true;
  last_servo_rad_ = servo_rad;
  return spin_angle_;
}

void ServoDriver::sendCommand(const core::TiltCommand& cmd) {
  const auto& tab = dynamixel::mx64Table(opt_.protocol);
  std::uint8_t e = 0;
  if (spinning()) {  // velocity control: the speed only, in the joint's direction
    if (std::abs(cmd.velocity - last_velocity_cmd_) > 1e-9 &&
        bus_.writeReg(opt_.id, opt_.protocol == Protocol::V1 ? tab.moving_speed : tab.goal_velocity,
                      dynamixel::radPerSecToGoalVelocity(opt_.protocol, cmd.velocity / opt_.direction), &e, true,
                      opt_.timeout) == TxResult::Ok)
      last_velocity_cmd_ = cmd.velocity;
    return;
  }
  if (std::abs(cmd.velocity - last_velocity_cmd_) > 1e-9) {
    const dynamixel::Reg& vreg = opt_.protocol == Protocol::V1 ? tab.moving_speed : tab.profile_velocity;
    if (bus_.writeReg(opt_.id, vreg, dynamixel::radPerSecToVelocity(opt_.protocol, cmd.velocity), &e, true,
                      opt_.timeout) == TxResult::Ok)
      last_velocity_cmd_ = cmd.velocity;
  }
  const std::int32_t want = dynamixel::radToPosition(toServo(cmd.goal));
  const std::int32_t raw = std::clamp(want, goal_min_, goal_max_);
  if (raw != want) {
    bool first = false;
    {
      std::lock_guard<std::mutex> l(status_mutex_);
      first = status_.clamped_goals++ == 0;
    }
    if (log_)
      log_(Level::Warn, std::string("tilt goal beyond the servo's limits: clamped") +
                            (first ? " (the servo's own limits; see the diagnostics)" : ""));
  }
  bus_.writeReg(opt_.id, tab.goal_position, static_cast<std::uint32_t>(raw), &e, true, opt_.timeout);
}

void ServoDriver::handleHardwareError(std::uint8_t bits, double now) {
  const bool v1 = opt_.protocol == Protocol::V1;
  const auto& tab = dynamixel::mx64Table(opt_.protocol);
  std::uint8_t hw = bits;
  if (!v1) {  // the alert bit: the reason is in the hardware error register
    std::uint32_t value = 0;
    std::uint8_t e = 0;
    if (bus_.readReg(opt_.id, tab.hardware_error, value, &e, opt_.timeout) == TxResult::Ok) hw = static_cast<std::uint8_t>(value);
  } else {
    hw = bits & 0x25;  // input voltage, overheating, overload (range/checksum/instruction are ours)
  }
  const std::string names = dynamixel::hardwareErrorNames(opt_.protocol, hw);
  bool is_new = false;
  {
    std::lock_guard<std::mutex> l(status_mutex_);
    is_new = status_.hardware_error != hw;
    status_.hardware_error = hw;
    status_.hardware_error_names = names;
    if (is_new && hw) ++status_.hardware_error_events;
  }
  if (!hw) {
    hw_error_since_ = -1.0;
    return;
  }
  if (is_new && log_) log_(Level::Error, "servo hardware error: " + names);
  if (hw_error_since_ < 0) {
    hw_error_since_ = now;
    if (hw & (0x04 | 0x20)) dropSweep("servo shut down (" + names + ")");
  }
  if ((hw & (0x04 | 0x20)) && now - hw_error_since_ >= opt_.recover_after) {
    // The servo switched its torque off: reboot it (2.0) or enable the torque again (1.0).
    std::uint8_t e = 0;
    if (!v1) {
      bus_.reboot(opt_.id, &e, opt_.timeout);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      port_.close();  // reconfigure from scratch
    } else {
      bus_.writeReg(opt_.id, tab.torque_enable, 1, &e, true, opt_.timeout);
    }
    hw_error_since_ = now;
    if (log_) log_(Level::Warn, "trying to recover the servo from: " + names);
  }
}

void ServoDriver::run() {
  double backoff = opt_.backoff_min;
  int failures = 0, corrupt = 0;
  double next = dynamixel::monotonicNow();
  double next_health = 0.0;
  std::array<double, 64> round_trips{};
  std::size_t n_round_trips = 0;
  const double period = 1.0 / std::max(1.0, opt_.rate);
  const auto& tab = dynamixel::mx64Table(opt_.protocol);
  while (running_) {
    if (!port_.isOpen()) {
      {
        std::lock_guard<std::mutex> l(status_mutex_);
        status_.connected = false;
      }
      if (!openAndConfigure()) {
        if (log_) log_(Level::Warn, "servo not available (" + status().last_error + "); retrying in " +
                                        std::to_string(backoff).substr(0, 4) + " s");
        sleepUntil(dynamixel::monotonicNow() + backoff);
        backoff = std::min(opt_.backoff_max, backoff * 2.0);
        continue;
      }
      backoff = opt_.backoff_min;
      failures = 0;
      profile_.restart();
      next = dynamixel::monotonicNow();
    }

    JointSample s;
    std::uint8_t err = 0;
    const TxResult rr = readState(s, err);
    if (rr != TxResult::Ok) {
      // A corrupt reply is no lost servo: the line is alive and the next
      // request starts afresh; reopening would only cost the backoff (20 bad
      // checksums cost 5.5 s of joint states that way). Only a run of them
      // far longer than a glitch (1 s at 200 Hz) counts as a lost link.
      const bool lost = rr == TxResult::PortError || rr == TxResult::NotSent ||
                        (rr == TxResult::BadPacket ? ++corrupt >= 200 : ++failures >= opt_.max_failures);
      if (lost) {
        corrupt = 0;
        const std::string why = status().last_error;
        port_.close();
        dropSweep(why);
        std::lock_guard<std::mutex> l(status_mutex_);
        ++status_.reopens;
        status_.connected = false;
        if (log_) log_(Level::Error, "servo lost (" + why + "): reopening " + opt_.device);
      }
      next += period;
      sleepUntil(next);
      continue;
    }
    failures = corrupt = 0;
    round_trips[n_round_trips++ % round_trips.size()] = s.round_trip;
    const double shortest = *std::min_element(round_trips.begin(),
                                              round_trips.begin() + std::min(n_round_trips, round_trips.size()));
    const bool late = s.round_trip > shortest + 2.0 * opt_.max_stamp_uncertainty;
    {
      std::lock_guard<std::mutex> l(status_mutex_);
      ++status_.samples;
      status_.late_reads += late;
      status_.effort = s.effort;
    }
    if (on_joint_ && !late) on_joint_(s);

    const double now = dynamixel::monotonicNow();
    const bool alert = opt_.protocol == Protocol::V1 ? (err & 0x25) != 0 : (err & 0x80) != 0;
    if (alert || status().hardware_error) handleHardwareError(alert ? err : 0, now);
    if (!port_.isOpen()) continue;

    core::TiltCommand cmd;
    core::Sweep sweep;
    bool ended = false;
    if (!status().hardware_error && profile_.update(s.stamp, s.position, cmd, sweep, &ended)) sendCommand(cmd);
    if (ended) {
      if (on_sweep_) on_sweep_(sweep, true);
      std::lock_guard<std::mutex> l(status_mutex_);
      ++status_.sweeps;
    }

    if (now >= next_health) {
      next_health = now + 1.0;
      std::uint32_t temp = 0, volt = 0;
      std::uint8_t e = 0;
      if (bus_.readReg(opt_.id, tab.present_temperature, temp, &e, opt_.timeout) == TxResult::Ok &&
          bus_.readReg(opt_.id, tab.present_voltage, volt, &e, opt_.timeout) == TxResult::Ok) {
        std::lock_guard<std::mutex> l(status_mutex_);
        status_.temperature = temp;
        status_.voltage = volt * 0.1;
      }
      // The torque went off with no hardware error to show for it (the
      // servo's power was cycled, an error cleared itself): the head would
      // stand still while the sweep waits for it. Switch it on again.
      std::uint32_t torque = 1;
      if (!status().hardware_error && bus_.readReg(opt_.id, tab.torque_enable, torque, &e, opt_.timeout) == TxResult::Ok &&
          torque == 0) {
        dropSweep("the servo's torque was off");
        bus_.writeReg(opt_.id, tab.torque_enable, 1, &e, true, opt_.timeout);
        last_velocity_cmd_ = -1.0;  // a spinning servo's speed sent again
        {
          std::lock_guard<std::mutex> l(status_mutex_);
          ++status_.torque_restores;
        }
        if (log_) log_(Level::Warn, "the servo's torque was off with no hardware error: switched on again");
      }
    }
    next += period;
    if (next < dynamixel::monotonicNow() - 5 * period) next = dynamixel::monotonicNow();  // fell behind: no burst
    sleepUntil(next);
  }
}

}  // namespace driver
}  // namespace tilt_laser_perception
