/**
 * @file bus.hpp
 * @brief The package's in-tree Dynamixel SDK: a serial port handler on termios
 *        (standard and custom baud rates up to 4.5 Mbps, low-latency mode,
 *        timeouts on a monotonic clock, flushing) and a bus that sends
 *        instruction packets and waits for the status packet, skipping garbage
 *        and reporting hardware errors with the data. ROS-free.
 */
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tilt_laser_perception/dynamixel/mx64.hpp"

namespace tilt_laser_perception {
namespace dynamixel {

/// A serial port for a Dynamixel bus (U2D2, USB2Dynamixel, or a pseudo terminal).
class PortHandler {
 public:
  PortHandler() = default;
  ~PortHandler() { close(); }
  PortHandler(const PortHandler&) = delete;
  PortHandler& operator=(const PortHandler&) = delete;

  /// Opens `device` at `baud` bps (any rate: non-standard ones through termios2).
  /// `low_latency` asks the driver for ASYNC_LOW_LATENCY (ignored where unsupported).
  bool open(const std::string& device, int baud, bool low_latency, std::string& error);
  void close();
  bool isOpen() const { return fd_ >= 0; }
  /// Discards what is in the buffers.
  void flush();
  bool write(const std::uint8_t* data, std::size_t size, std::string& error);
  /// Reads what arrives within `timeout` [s]: bytes, 0 on a timeout, -1 when the port is gone.
  long read(std::uint8_t* data, std::size_t size, double timeout, std::string& error);
  int baud() const { return baud_; }
  const std::string& device() const { return device_; }
  /// Seconds to transmit n bytes at the port's rate (10 bits a byte).
  double byteTime(std::size_t n) const { return baud_ > 0 ? 10.0 * n / baud_ : 0.0; }

 private:
  int fd_ = -1, baud_ = 0;
  std::string device_;
};

/// Outcome of one transaction.
enum class TxResult { Ok, Timeout, BadPacket, PortError, NotSent };
const char* txResultName(TxResult r);

/// Counters of the bus.
struct BusCounters {
  unsigned long transactions = 0, ok = 0, timeouts = 0, bad_packets = 0, garbage_bytes = 0, port_errors = 0,
                hardware_error_replies = 0;
  double successRate() const { return transactions ? static_cast<double>(ok) / transactions : 1.0; }
};

/// One Dynamixel bus on a port.
class Bus {
 public:
  Bus(PortHandler& port, Protocol protocol) : port_(port), protocol_(protocol), parser_(protocol, true) {}

  /// Sends an instruction and, unless `expect_status` is false, waits for the
  /// status packet of `id` for up to `timeout` [s] beyond the transmit time.
  TxResult transact(std::uint8_t id, std::uint8_t instruction, const std::vector<std::uint8_t>& params,
                    Packet* status, double timeout, bool expect_status = true);

  /// Ping: the model number (2.0 reports it; 1.0 needs a read).
  TxResult ping(std::uint8_t id, std::uint16_t* model, std::uint8_t* error, double timeout = 0.05);
  /// Reads registers [addr, addr + len); values are little-endian bytes.
  TxResult read(std::uint8_t id, std::uint16_t addr, std::uint16_t len, std::vector<std::uint8_t>& data,
                std::uint8_t* error, double timeout = 0.05);
  TxResult readReg(std::uint8_t id, const Reg& r, std::uint32_t& value, std::uint8_t* error, double timeout = 0.05);
  /// Writes registers; waits for the status packet when `ack`.
  TxResult write(std::uint8_t id, std::uint16_t addr, const std::vector<std::uint8_t>& data, std::uint8_t* error,
                 bool ack = true, double timeout = 0.05);
  TxResult writeReg(std::uint8_t id, const Reg& r, std::uint32_t value, std::uint8_t* error, bool ack = true,
                    double timeout = 0.05);
  /// Reboot (2.0 only).
  TxResult reboot(std::uint8_t id, std::uint8_t* error, double timeout = 0.05);
  /// Sync write: one register of several servos in one packet (no status packets).
  TxResult syncWrite(const Reg& reg, const std::vector<std::pair<std::uint8_t, std::uint32_t>>& values);
  /// Sync read (2.0 only): one register of several servos; `values` gets the ones that answered.
  TxResult syncRead(const Reg& reg, const std::vector<std::uint8_t>& ids,
                    std::vector<std::pair<std::uint8_t, std::uint32_t>>& values, double timeout = 0.05);
  /// Bulk read: a register of each servo (any address and size each); `values` gets the ones that answered.
  TxResult bulkRead(const std::vector<std::pair<std::uint8_t, Reg>>& requests,
                    std::vector<std::pair<std::uint8_t, std::uint32_t>>& values, double timeout = 0.05);

  Protocol protocol() const { return protocol_; }
  const BusCounters& counters() const { return counters_; }
  void resetParser() { parser_.clear(); }

 private:
  /// Feeds what arrives within `timeout` [s] to the parser; false when the port is gone.
  bool receive(double timeout);
  /// Status packets of `ids` (in that order) after a broadcast read; Ok only when all came.
  TxResult collect(const std::vector<std::uint8_t>& ids, const std::vector<std::uint16_t>& sizes,
                   std::vector<std::pair<std::uint8_t, std::uint32_t>>& values, double timeout);
  PortHandler& port_;
  Protocol protocol_;
  PacketParser parser_;
  BusCounters counters_;
  std::size_t last_garbage_ = 0, last_bad_ = 0;
};

/// Monotonic time [s].
double monotonicNow();

}  // namespace dynamixel
}  // namespace tilt_laser_perception
