/**
 * @file mx64_emulator.hpp
 * @brief An emulated Dynamixel MX-64 on a pseudo terminal, speaking Protocol
 *        1.0 or 2.0 from its control table and moving a ServoModel. ROS-free.
 *
 * Instructions: ping, read, write, reg write/action, factory reset, reboot
 * (2.0), sync write, sync read (2.0), bulk read; status return level and return
 * delay time are honoured. Faults: no status packet, bad checksum/CRC, garbage
 * before the header, hardware error bits, and the port vanishing.
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
};

struct Mx64Stats {
  std::atomic<unsigned long> packets{0}, replies{0}, bad_packets{0}, garbage_bytes{0};
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
  void applyWrite(std::uint16_t addr, const std::vector<std::uint8_t>& data, double t);
  void resetTable();
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
  Mx64Stats stats_;
};

}  // namespace sim
}  // namespace tilt_laser_perception
