#include "tilt_laser_perception/dynamixel/mx64.hpp"

#include <algorithm>
#include <limits>

namespace tilt_laser_perception {
namespace dynamixel {

const Mx64Table& mx64Table(Protocol p) {
  static const Mx64Table v1 = [] {
    Mx64Table t;
    t.model_number = {0, 2};
    t.firmware = {2, 1};
    t.id = {3, 1};
    t.baud_rate = {4, 1};
    t.return_delay = {5, 1};
    t.max_torque = {14, 2};
    t.status_return_level = {16, 1};
    t.torque_enable = {24, 1};
    t.led = {25, 1};
    t.goal_position = {30, 2};
    t.moving_speed = {32, 2};
    t.present_position = {36, 2};
    t.present_speed = {38, 2};
    t.present_load = {40, 2};
    t.present_voltage = {42, 1};
    t.present_temperature = {43, 1};
    t.moving = {46, 1};
    t.present_current = {68, 2};
    t.goal_acceleration = {73, 1};
    t.model = 310;
    t.size = 74;
    return t;
  }();
  static const Mx64Table v2 = [] {
    Mx64Table t;
    t.model_number = {0, 2};
    t.firmware = {6, 1};
    t.id = {7, 1};
    t.baud_rate = {8, 1};
    t.return_delay = {9, 1};
    t.status_return_level = {68, 1};
    t.torque_enable = {64, 1};
    t.led = {65, 1};
    t.hardware_error = {70, 1};
    t.profile_acceleration = {108, 4};
    t.profile_velocity = {112, 4};
    t.goal_position = {116, 4};
    t.moving = {122, 1};
    t.present_current = {126, 2};
    t.present_speed = {128, 4};
    t.present_position = {132, 4};
    t.present_voltage = {144, 2};
    t.present_temperature = {146, 1};
    t.model = 311;
    t.size = 147;
    return t;
  }();
  return p == Protocol::V1 ? v1 : v2;
}

namespace {
constexpr double kRpmToRadPerSec = 2.0 * M_PI / 60.0;
}

double velocityToRadPerSec(Protocol p, std::uint32_t raw) {
  const double unit = velocityUnitRpm(p) * kRpmToRadPerSec;
  if (p == Protocol::V1) {
    const double mag = (raw & 0x3FF) * unit;
    return (raw & 0x400) ? -mag : mag;
  }
  return static_cast<std::int32_t>(raw) * unit;
}

std::uint32_t radPerSecToVelocity(Protocol p, double w) {
  const double unit = velocityUnitRpm(p) * kRpmToRadPerSec;
  const double raw = std::round(std::abs(w) / unit);
  const double max = p == Protocol::V1 ? 1023.0 : 32767.0;
  return static_cast<std::uint32_t>(std::clamp(raw, 1.0, max));
}

std::uint32_t radPerSec2ToAcceleration(Protocol p, double a) {
  if (p == Protocol::V1) {
    const double unit = 8.583 * M_PI / 180.0;
    return static_cast<std::uint32_t>(std::clamp(std::round(a / unit), 1.0, 254.0));
  }
  const double unit = 214.577 * 2.0 * M_PI / 3600.0;  // rev/min^2 -> rad/s^2
  return static_cast<std::uint32_t>(std::clamp(std::round(a / unit), 1.0, 32767.0));
}

double accelerationToRadPerSec2(Protocol p, std::uint32_t raw) {
  if (raw == 0) return std::numeric_limits<double>::infinity();
  if (p == Protocol::V1) return raw * 8.583 * M_PI / 180.0;
  return raw * 214.577 * 2.0 * M_PI / 3600.0;
}

double loadToFraction(std::uint32_t raw) {
  const double mag = (raw & 0x3FF) / 1000.0;
  return (raw & 0x400) ? -mag : mag;
}

double currentToAmp(Protocol p, std::uint32_t raw) {
  if (p == Protocol::V1) return 0.0045 * (static_cast<double>(raw) - 2048.0);
  return static_cast<std::int16_t>(raw & 0xFFFF) * 0.00336;
}

}  // namespace dynamixel
}  // namespace tilt_laser_perception
