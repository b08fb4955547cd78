/**
 * @file mx64_emulator.hpp
 * @brief An emulated Dynamixel MX-64 on a pseudo terminal, speaking Protocol
 *        1.0 or 2.0 from its control table and moving a ServoModel. ROS-free.
 *
 * The control table is the e-manual's (dynamixel::mx64Registers): its
 * initial values, access, EEPROM area and value ranges. Instructions: ping,
 * read, write, reg write (sets Registered) and action, factory reset, reboot
 * (2.0; the servo is silent for `reboot_time`), sync write, sync read (2.0),
 * bulk read, bulk write (2.0); the indirect address area (2.0). Errors as the
 * e-manual gives them: 2.0 access (read-only, undefined, or EEPROM with the
 * torque on), data range, data length (part of a register), data limit (a
 * goal beyond the position / velocity / current / PWM limits), instruction
 * (unknown, or action with nothing registered), CRC; 1.0 range, angle limit
 * (a goal outside CW..CCW), instruction and checksum bits. A line set to
 * another baud rate than the Baud Rate register's is not answered. Status
 * return level and return delay time are honoured. Faults: no status packet,
 * bad checksum/CRC, garbage before the header, hardware error bits, the port
 * vanishing.
 */
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "tilt_laser_perception/dynamixel/mx64.hpp"
#include "tilt_laser_perception/sim/head.hpp"

namespace tilt_laser_perception {
namespace sim {

struct Mx64Options {
  dynamixel::Protocol protocol = dynamixel::Protocol::V2;
  std::uint8_t id = 1;
  /// Optional stable path: a symbolic link to the pseudo terminal, made anew when the port reappears.
  std::string link_path;
  double voltage = 12.0;      ///< [V]
  double temperature = 38.0;  ///< [degrees C]
  /// After a reboot the servo answers nothing for this long [s]: an assumed
  /// boot time (the e-manual gives none; a DYNAMIXEL blinks its LED once).
  double reboot_time = 0.5;
  /// Addresses this emulated model lacks (another model's table): reads and
  /// writes of them are refused as undefined.
  std::vector<std::uint16_t> undefined_addresses;
  /// Position limits as a user set them (raw steps; 1.0: CW/CCW Angle Limit,
  /// 2.0: Min/Max Position Limit); lo > hi: the e-manual's initial values.
  std::int32_t limit_lo = 1, limit_hi = 0;
};

struct Mx64Stats {
  std::atomic<unsigned long> packets{0}, replies{0}, bad_packets{0}, garbage_bytes{0};
  std::atomic<unsigned long> error_replies{0};    ///< status packets with an error (not hardware alerts)
  std::atomic<unsigned long> wrong_baud_bytes{0};  ///< bytes ignored: the line is at another baud rate
};

class Mx64Emulator {
 public:
  Mx64Emulator(ServoModel& servo, const Mx64Options& options);
  ~Mx64Emulator();
  Mx64Emulator(const Mx64Emulator&) = delete;
  Mx64Emulator& operator=(const Mx64Emulator&) = delete;

  /// Opens the pseudo terminal and starts serving; throws std::runtime_error on failure.
  void start();
  void stop();
  /// The path a driver opens: the link if one was asked for, else the pty's slave name.
  std::string devicePath() const;

  // ---- faults ----
  void setNoReply(bool on) { no_reply_.store(on); }      ///< answer nothing
  void corruptNextReplies(int n) { corrupt_.store(n); }  ///< bad checksum / CRC in the next n replies
  void garbageBeforeNextReplies(int n) { garbage_.store(n); }  ///< random bytes before the next n replies
  /// Hardware error bits, as in the 1.0 error byte (0x01 input voltage, 0x04 overheating, 0x20 overload);
  /// overload and overheating switch the torque off, as the real servo's shutdown does.
  void setHardwareError(std::uint8_t bits);
  void vanish();     ///< the port disappears (the pty is closed and the link removed)
  void reappear();   ///< a new pty (and link) appears

  const Mx64Stats& stats() const { return stats_; }
  /// A register value as the servo holds it (for tests).
  std::uint32_t reg(const dynamixel::Reg& r);

 private:
  void run();
  void openPort();
  void closePort();
  void handle(const dynamixel::Packet& p);
  void reply(std::uint8_t error, const std::vector<std::uint8_t>& params, bool is_ping = false);
  void refresh(double t);
  /// 0 when the write may be made, else its error (1.0 bits, 2.0 number).
  std::uint8_t checkWrite(std::uint16_t addr, const std::vector<std::uint8_t>& data) const;
  void applyWrite(std::uint16_t addr, const std::vector<std::uint8_t>& data, double t);
  /// The bytes [addr, addr + len) as a read returns them (indirect data through their addresses).
  std::vector<std::uint8_t> readBytes(std::uint16_t addr, std::uint16_t len) const;
  /// The address an indirect data byte stands for; -1 when `addr` is none.
  int indirectTarget(std::uint16_t addr) const;
  void resetTable(bool eeprom_too = true);
  bool lineBaudMatches() const;
  bool lacks(std::uint16_t addr) const;  ///< a register this model lacks (options_.undefined_addresses)
  bool lacksAny(std::uint16_t addr, std::uint16_t len) const;
  std::uint32_t get(const dynamixel::Reg& r) const;
  void set(const dynamixel::Reg& r, std::uint32_t v);

  ServoModel& servo_;
  Mx64Options options_;
  const dynamixel::Mx64Table& table_;
  std::vector<std::uint8_t> mem_;
  std::vector<std::uint8_t> registered_;  // REG_WRITE: addr (2 bytes) + data
  std::recursive_mutex mutex_;
  int master_fd_ = -1, slave_fd_ = -1;
  std::string slave_name_;
  std::thread thread_;
  std::atomic<bool> running_{false}, port_open_{false};
  std::atomic<bool> no_reply_{false};
  std::atomic<int> corrupt_{0}, garbage_{0};
  std::uint8_t hw_error_ = 0;
  double silent_until_ = 0.0;  ///< rebooting
  Mx64Stats stats_;
};

}  // namespace sim
}  // namespace tilt_laser_perception
