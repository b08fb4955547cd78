/**
 * @file mx64.hpp
 * @brief MX-64 control tables of Protocol 1.0 and 2.0 (firmware "MX(2.0)") and
 *        conversions of raw units to SI. ROS-free.
 *
 * Facts used (ROBOTIS MX-64 e-manual): 4096 position steps per turn, 2048 at
 * the centre; 1.0 speed unit 0.114 rpm (bit 10 of present speed/load: the CW
 * direction), load 0.1 % units, current 4.5 mA * (raw - 2048); 2.0 velocity
 * unit 0.229 rpm (signed 32 bit), profile acceleration 214.577 rev/min^2,
 * current 3.36 mA (signed 16 bit); voltage 0.1 V; temperature 1 degree C.
 */
#pragma once

#include <climits>
#include <cmath>
#include <cstdint>
#include <vector>

#include "tilt_laser_perception/dynamixel/protocol.hpp"

namespace tilt_laser_perception {
namespace dynamixel {

/// Register address and size.
struct Reg {
  std::uint16_t addr = 0;
  std::uint8_t size = 0;
  bool valid() const { return size > 0; }
};

/// The MX-64 registers the package uses, for one protocol.
struct Mx64Table {
  Reg model_number, firmware, id, baud_rate, return_delay, status_return_level, torque_enable, led,
      goal_position, moving_speed /*1.0*/, goal_acceleration /*1.0*/, profile_acceleration /*2.0*/,
      profile_velocity /*2.0*/, present_position, present_speed, present_load /*1.0*/, present_current,
      present_voltage, present_temperature, moving, hardware_error /*2.0*/, max_torque /*1.0*/,
      torque_limit /*1.0*/, cw_angle_limit /*1.0*/, ccw_angle_limit /*1.0*/, lock /*1.0*/,
      min_position_limit /*2.0*/, max_position_limit /*2.0*/, velocity_limit /*2.0*/, operating_mode /*2.0*/,
      goal_velocity /*2.0*/, registered;
  std::uint16_t model = 0;   ///< model number the servo reports
  std::uint16_t size = 0;    ///< bytes of control table (1.0: 74; 2.0: 662, to the last indirect data)
};

/// The table of a protocol.
const Mx64Table& mx64Table(Protocol p);

/// One entry of the e-manual's control table ("MX-64AR/AT" for Protocol 1.0,
/// "MX-64(2.0)" for 2.0): address, size, access, area, the range a write must
/// lie in, and the initial value (kNoInitial: "-", the servo's own state).
struct RegisterInfo {
  std::uint16_t addr;
  std::uint8_t size;
  bool writable;
  bool eeprom;  ///< 2.0: written only while Torque Enable is 0
  std::int64_t min, max, initial;
  const char* name;
};
constexpr std::int64_t kNoInitial = INT64_MIN;
/// Every register of the control table, in address order.
const std::vector<RegisterInfo>& mx64Registers(Protocol p);
/// The register holding byte `addr`, or null (reserved or past the table).
const RegisterInfo* mx64RegisterAt(Protocol p, std::uint16_t addr);

/// 2.0 status packet error numbers (the error byte without its alert bit 0x80).
namespace err2 {
constexpr std::uint8_t kResultFail = 0x01, kInstruction = 0x02, kCrc = 0x03, kDataRange = 0x04, kDataLength = 0x05,
                       kDataLimit = 0x06, kAccess = 0x07;
}
/// 1.0 status packet error bits.
namespace err1 {
constexpr std::uint8_t kInputVoltage = 0x01, kAngleLimit = 0x02, kOverheating = 0x04, kRange = 0x08,
                       kChecksum = 0x10, kOverload = 0x20, kInstruction = 0x40;
}
/// The part of a status packet's error byte that says the instruction was
/// refused (1.0: angle limit, range, checksum, instruction bits; 2.0: the
/// error number), without the hardware alarms; 0 when it was carried out.
inline std::uint8_t refusal(Protocol p, std::uint8_t error) {
  return p == Protocol::V1 ? error & (err1::kAngleLimit | err1::kRange | err1::kChecksum | err1::kInstruction)
                           : error & 0x7F;
}
/// Baud rate [bps] of a Baud Rate register value (1.0: 2 Mbps / (value + 1),
/// 250..252 = 2.25, 2.5, 3 Mbps; 2.0: 0..7 = 9600, 57600, 115200, 1 M, 2 M,
/// 3 M, 4 M, 4.5 Mbps); 0 for a value with no rate.
int baudRateOf(Protocol p, std::uint32_t value);

constexpr double kStepsPerRev = 4096.0;
constexpr int kCenter = 2048;
constexpr double kRadPerStep = 2.0 * M_PI / kStepsPerRev;

/// Raw position to angle [rad] (0 at 2048).
inline double positionToRad(std::int32_t raw) { return (raw - kCenter) * kRadPerStep; }
/// Angle [rad] to raw position (rounded).
inline std::int32_t radToPosition(double rad) { return static_cast<std::int32_t>(std::lround(rad / kRadPerStep)) + kCenter; }

/// rpm per raw velocity unit.
inline double velocityUnitRpm(Protocol p) { return p == Protocol::V1 ? 0.114 : 0.229; }
/// Raw present speed/velocity to rad/s (1.0: bit 10 = CW = negative; 2.0: signed 32 bit).
double velocityToRadPerSec(Protocol p, std::uint32_t raw);
/// Speed limit [rad/s] to the raw moving speed (1.0) or profile velocity (2.0), at least 1.
std::uint32_t radPerSecToVelocity(Protocol p, double rad_per_s);
/// A signed velocity [rad/s] to the raw goal of velocity control: 1.0's wheel
/// mode Moving Speed (0..1023, bit 10 = CW = negative), 2.0's Goal Velocity (signed).
std::uint32_t radPerSecToGoalVelocity(Protocol p, double rad_per_s);
/// Acceleration [rad/s^2] to raw goal acceleration (1.0, 8.583 deg/s^2 units, 0..254)
/// or profile acceleration (2.0, 214.577 rev/min^2 units).
std::uint32_t radPerSec2ToAcceleration(Protocol p, double rad_per_s2);
/// Raw acceleration to rad/s^2 (0 means no limit: returns +inf).
double accelerationToRadPerSec2(Protocol p, std::uint32_t raw);
/// 1.0 present load (0.1 % of max torque, bit 10 CW) to a signed fraction [-1, 1].
double loadToFraction(std::uint32_t raw);
/// 2.0 present current (signed 16 bit, 3.36 mA) or 1.0 current (4.5 mA * (raw - 2048)) to A.
double currentToAmp(Protocol p, std::uint32_t raw);

}  // namespace dynamixel
}  // namespace tilt_laser_perception
