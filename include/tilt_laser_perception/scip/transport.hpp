/**
 * @file transport.hpp
 * @brief Byte transports for SCIP 2.0: TCP (UTM-30LX-EW) and serial (USB
 *        UTM-30LX, a CDC-ACM device). Every call has a timeout. ROS-free.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace tilt_laser_perception {
namespace scip {

class Transport {
 public:
  virtual ~Transport() = default;
  /// Opens the connection within `timeout` [s]; on failure returns false with a message.
  virtual bool open(double timeout, std::string& error) = 0;
  virtual void close() = 0;
  virtual bool isOpen() const = 0;
  /// Writes all bytes; false (and closes) on an error.
  virtual bool write(const std::string& data, std::string& error) = 0;
  /// Reads what is there within `timeout` [s]: bytes read, 0 on a timeout, -1 when the
  /// connection is closed or broken (with a message).
  virtual long read(char* buffer, std::size_t size, double timeout, std::string& error) = 0;
  /// "tcp 192.168.0.10:10940" or "serial /dev/ttyACM0".
  virtual std::string describe() const = 0;
};

std::unique_ptr<Transport> makeTcpTransport(const std::string& host, std::uint16_t port);
std::unique_ptr<Transport> makeSerialTransport(const std::string& device, int baud = 115200);

}  // namespace scip
}  // namespace tilt_laser_perception
