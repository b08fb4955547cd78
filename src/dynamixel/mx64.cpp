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
    t.cw_angle_limit = {6, 2};
    t.ccw_angle_limit = {8, 2};
    t.torque_limit = {34, 2};
    t.registered = {44, 1};
    t.lock = {47, 1};
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
    t.operating_mode = {11, 1};
    t.goal_velocity = {104, 4};
    t.velocity_limit = {44, 4};
    t.max_position_limit = {48, 4};
    t.min_position_limit = {52, 4};
    t.registered = {69, 1};
    t.model = 311;
    t.size = 662;
    return t;
  }();
  return p == Protocol::V1 ? v1 : v2;
}

const std::vector<RegisterInfo>& mx64Registers(Protocol p) {
  constexpr std::int64_t N = kNoInitial;
  // MX-64AR/AT control table (Protocol 1.0), ROBOTIS e-manual: address, size,
  // writable, EEPROM, min, max, initial, name. Ranges from the registers'
  // descriptions; the read-only ones take any value.
  static const std::vector<RegisterInfo> v1 = {
      {0, 2, false, true, 0, 65535, 310, "Model Number"},
      {2, 1, false, true, 0, 255, N, "Firmware Version"},
      {3, 1, true, true, 0, 252, 1, "ID"},
      {4, 1, true, true, 0, 254, 34, "Baud Rate"},
      {5, 1, true, true, 0, 254, 250, "Return Delay Time"},
      {6, 2, true, true, 0, 4095, 0, "CW Angle Limit"},
      {8, 2, true, true, 0, 4095, 4095, "CCW Angle Limit"},
      {11, 1, true, true, 0, 100, 80, "Temperature Limit"},
      {12, 1, true, true, 50, 250, 60, "Min Voltage Limit"},
      {13, 1, true, true, 50, 250, 240, "Max Voltage Limit"},
      {14, 2, true, true, 0, 1023, 1023, "Max Torque"},
      {16, 1, true, true, 0, 2, 2, "Status Return Level"},
      {17, 1, true, true, 0, 127, 36, "Alarm LED"},
      {18, 1, true, true, 0, 127, 36, "Shutdown"},
      {20, 2, true, true, -24576, 24576, 0, "Multi Turn Offset"},
      {22, 1, true, true, 1, 4, 1, "Resolution Divider"},
      {24, 1, true, false, 0, 1, 0, "Torque Enable"},
      {25, 1, true, false, 0, 1, 0, "LED"},
      {26, 1, true, false, 0, 254, 0, "D Gain"},
      {27, 1, true, false, 0, 254, 0, "I Gain"},
      {28, 1, true, false, 0, 254, 32, "P Gain"},
      {30, 2, true, false, 0, 4095, N, "Goal Position"},
      {32, 2, true, false, 0, 2047, 0, "Moving Speed"},
      {34, 2, true, false, 0, 1023, 1023, "Torque Limit"},  // initial: Max Torque
      {36, 2, false, false, 0, 65535, N, "Present Position"},
      {38, 2, false, false, 0, 65535, N, "Present Speed"},
      {40, 2, false, false, 0, 65535, N, "Present Load"},
      {42, 1, false, false, 0, 255, N, "Present Voltage"},
      {43, 1, false, false, 0, 255, N, "Present Temperature"},
      {44, 1, false, false, 0, 1, 0, "Registered"},
      {46, 1, false, false, 0, 1, 0, "Moving"},
      {47, 1, true, false, 0, 1, 0, "Lock"},
      {48, 2, true, false, 0, 1023, 0, "Punch"},
      {50, 2, false, false, 0, 65535, 0, "Realtime Tick"},
      {68, 2, true, false, 0, 4095, 2048, "Current"},  // 2048: no current (4.5 mA * (value - 2048))
      {70, 1, true, false, 0, 1, 0, "Torque Ctrl Mode Enable"},
      {71, 2, true, false, 0, 2047, 0, "Goal Torque"},
      {73, 1, true, false, 0, 254, 0, "Goal Acceleration"},
  };
  // MX-64(2.0) control table (Protocol 2.0), ROBOTIS e-manual.
  static const std::vector<RegisterInfo> v2 = [] {
    std::vector<RegisterInfo> t = {
        {0, 2, false, true, 0, 65535, 311, "Model Number"},
        {2, 4, false, true, 0, 0xFFFFFFFFll, 0, "Model Information"},
        {6, 1, false, true, 0, 255, N, "Firmware Version"},
        {7, 1, true, true, 0, 252, 1, "ID"},
        {8, 1, true, true, 0, 7, 1, "Baud Rate"},
        {9, 1, true, true, 0, 254, 250, "Return Delay Time"},
        {10, 1, true, true, 0, 5, 0, "Drive Mode"},
        {11, 1, true, true, 0, 16, 3, "Operating Mode"},
        {12, 1, true, true, 0, 255, 255, "Secondary(Shadow) ID"},
        {13, 1, true, true, 1, 2, 2, "Protocol Type"},
        {20, 4, true, true, -1044479, 1044479, 0, "Homing Offset"},
        {24, 4, true, true, 0, 1023, 10, "Moving Threshold"},
        {31, 1, true, true, 0, 100, 80, "Temperature Limit"},
        {32, 2, true, true, 95, 160, 160, "Max Voltage Limit"},
        {34, 2, true, true, 95, 160, 95, "Min Voltage Limit"},
        {36, 2, true, true, 0, 885, 885, "PWM Limit"},
        {38, 2, true, true, 0, 1941, 1941, "Current Limit"},
        {40, 4, true, true, 0, 32767, 32767, "Acceleration Limit"},
        {44, 4, true, true, 0, 1023, 435, "Velocity Limit"},
        {48, 4, true, true, 0, 4095, 4095, "Max Position Limit"},
        {52, 4, true, true, 0, 4095, 0, "Min Position Limit"},
        {63, 1, true, true, 0, 255, 52, "Shutdown"},
        {64, 1, true, false, 0, 1, 0, "Torque Enable"},
        {65, 1, true, false, 0, 1, 0, "LED"},
        {68, 1, true, false, 0, 2, 2, "Status Return Level"},
        {69, 1, false, false, 0, 1, 0, "Registered Instruction"},
        {70, 1, false, false, 0, 255, 0, "Hardware Error Status"},
        {76, 2, true, false, 0, 16383, 1920, "Velocity I Gain"},
        {78, 2, true, false, 0, 16383, 100, "Velocity P Gain"},
        {80, 2, true, false, 0, 16383, 0, "Position D Gain"},
        {82, 2, true, false, 0, 16383, 0, "Position I Gain"},
        {84, 2, true, false, 0, 16383, 850, "Position P Gain"},
        {88, 2, true, false, 0, 16383, 0, "Feedforward 2nd Gain"},
        {90, 2, true, false, 0, 16383, 0, "Feedforward 1st Gain"},
        {98, 1, true, false, 0, 127, 0, "Bus Watchdog"},
        {100, 2, true, false, -885, 885, N, "Goal PWM"},           // limit: PWM Limit
        {102, 2, true, false, -1941, 1941, N, "Goal Current"},     // limit: Current Limit
        {104, 4, true, false, -1023, 1023, N, "Goal Velocity"},    // limit: Velocity Limit
        {108, 4, true, false, 0, 32767, 0, "Profile Acceleration"},
        {112, 4, true, false, 0, 32767, 0, "Profile Velocity"},
        // Position Control Mode: 0..4095, and within Min/Max Position Limit
        // (Extended Position Control: +-1,048,575; the emulator checks by mode).
        {116, 4, true, false, -1048575, 1048575, N, "Goal Position"},
        {120, 2, false, false, 0, 32767, N, "Realtime Tick"},
        {122, 1, false, false, 0, 1, 0, "Moving"},
        {123, 1, false, false, 0, 255, 0, "Moving Status"},
        {124, 2, false, false, -32768, 32767, N, "Present PWM"},
        {126, 2, false, false, -32768, 32767, N, "Present Current"},
        {128, 4, false, false, INT32_MIN, INT32_MAX, N, "Present Velocity"},
        {132, 4, false, false, INT32_MIN, INT32_MAX, N, "Present Position"},
        {136, 4, false, false, INT32_MIN, INT32_MAX, N, "Velocity Trajectory"},
        {140, 4, false, false, INT32_MIN, INT32_MAX, N, "Position Trajectory"},
        {144, 2, false, false, 0, 65535, N, "Present Input Voltage"},
        {146, 1, false, false, 0, 255, N, "Present Temperature"},
    };
    // Indirect Address 1..28 (168..222) point at Indirect Data 1..28 (224..251)
    // by default; 29..56 (578..632) at 634..661. Valid targets: 64..661.
    for (int n = 0; n < 28; ++n)
      t.push_back({static_cast<std::uint16_t>(168 + 2 * n), 2, true, false, 64, 661, 224 + n, "Indirect Address"});
    for (int n = 0; n < 28; ++n)
      t.push_back({static_cast<std::uint16_t>(224 + n), 1, true, false, 0, 255, 0, "Indirect Data"});
    for (int n = 0; n < 28; ++n)
      t.push_back({static_cast<std::uint16_t>(578 + 2 * n), 2, true, false, 64, 661, 634 + n, "Indirect Address"});
    for (int n = 0; n < 28; ++n)
      t.push_back({static_cast<std::uint16_t>(634 + n), 1, true, false, 0, 255, 0, "Indirect Data"});
    return t;
  }();
  return p == Protocol::V1 ? v1 : v2;
}

const RegisterInfo* mx64RegisterAt(Protocol p, std::uint16_t addr) {
  const auto& regs = mx64Registers(p);
  auto it = std::upper_bound(regs.begin(), regs.end(), addr,
                             [](std::uint16_t a, const RegisterInfo& r) { return a < r.addr; });
  if (it == regs.begin()) return nullptr;
  --it;
  return addr < it->addr + it->size ? &*it : nullptr;
}

int baudRateOf(Protocol p, std::uint32_t v) {
  if (p == Protocol::V1) {
    if (v == 250) return 2250000;
    if (v == 251) return 2500000;
    if (v == 252) return 3000000;
    return v < 250 ? static_cast<int>(2000000 / (v + 1)) : 0;
  }
  static const int rates[] = {9600, 57600, 115200, 1000000, 2000000, 3000000, 4000000, 4500000};
  return v < 8 ? rates[v] : 0;
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

std::uint32_t radPerSecToGoalVelocity(Protocol p, double w) {
  const double unit = velocityUnitRpm(p) * kRpmToRadPerSec;
  const auto mag = static_cast<std::uint32_t>(std::min(std::round(std::abs(w) / unit), p == Protocol::V1 ? 1023.0 : 32767.0));
  if (p == Protocol::V1) return mag | (w < 0.0 ? 0x400u : 0u);
  return static_cast<std::uint32_t>(w < 0.0 ? -static_cast<std::int32_t>(mag) : static_cast<std::int32_t>(mag));
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
