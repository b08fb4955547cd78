#include "tilt_laser_perception/dynamixel/bus.hpp"

#include <fcntl.h>
#include <linux/serial.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace tilt_laser_perception {
namespace dynamixel {

bool setCustomBaud(int fd, int baud);  // termios2.cpp

double monotonicNow() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

namespace {
speed_t standardBaud(int baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 500000: return B500000;
    case 576000: return B576000;
    case 921600: return B921600;
    case 1000000: return B1000000;
    case 1152000: return B1152000;
    case 1500000: return B1500000;
    case 2000000: return B2000000;
    case 2500000: return B2500000;
    case 3000000: return B3000000;
    case 3500000: return B3500000;
    case 4000000: return B4000000;
    default: return 0;
  }
}
}  // namespace

bool PortHandler::open(const std::string& device, int baud, bool low_latency, std::string& error) {
  close();
  if (baud <= 0 || baud > 4500000) {
    error = "baud rate must be in (0, 4500000], got " + std::to_string(baud);
    return false;
  }
  fd_ = ::open(device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    error = "cannot open " + device + ": " + std::strerror(errno);
    return false;
  }
  termios t{};
  if (::tcgetattr(fd_, &t) != 0) {
    error = device + " is not a serial port: " + std::strerror(errno);
    close();
    return false;
  }
  ::cfmakeraw(&t);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cflag &= ~CRTSCTS;
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  const speed_t s = standardBaud(baud);
  if (s != 0) {
    ::cfsetispeed(&t, s);
    ::cfsetospeed(&t, s);
  }
  if (::tcsetattr(fd_, TCSANOW, &t) != 0) {
    error = "cannot configure " + device + ": " + std::strerror(errno);
    close();
    return false;
  }
  if (s == 0 && !setCustomBaud(fd_, baud)) {
    error = "cannot set " + std::to_string(baud) + " bps on " + device;
    close();
    return false;
  }
  if (low_latency) {
    serial_struct ss{};
    if (::ioctl(fd_, TIOCGSERIAL, &ss) == 0) {
      ss.flags |= ASYNC_LOW_LATENCY;
      ::ioctl(fd_, TIOCSSERIAL, &ss);  // a pseudo terminal has no such setting: ignored
    }
  }
  baud_ = baud;
  device_ = device;
  flush();
  return true;
}

void PortHandler::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

void PortHandler::flush() {
  if (fd_ >= 0) ::tcflush(fd_, TCIOFLUSH);
}

bool PortHandler::write(const std::uint8_t* data, std::size_t size, std::string& error) {
  std::size_t off = 0;
  const double end = monotonicNow() + 0.1 + byteTime(size);
  while (off < size) {
    if (fd_ < 0) {
      error = "port closed";
      return false;
    }
    const ssize_t n = ::write(fd_, data + off, size - off);
    if (n > 0) {
      off += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR) && monotonicNow() < end) {
      pollfd p{fd_, POLLOUT, 0};
      ::poll(&p, 1, 5);
      continue;
    }
    error = std::string("write to ") + device_ + " failed: " + (n < 0 ? std::strerror(errno) : "timeout");
    return false;
  }
  return true;
}

long PortHandler::read(std::uint8_t* data, std::size_t size, double timeout, std::string& error) {
  if (fd_ < 0) {
    error = "port closed";
    return -1;
  }
  pollfd p{fd_, POLLIN, 0};
  const int r = ::poll(&p, 1, static_cast<int>(timeout * 1000.0 + 0.999));
  if (r == 0) return 0;
  if (r < 0) {
    if (errno == EINTR) return 0;
    error = std::string("poll failed: ") + std::strerror(errno);
    return -1;
  }
  if (p.revents & (POLLHUP | POLLERR | POLLNVAL)) {
    error = device_ + " hung up (unplugged?)";
    return -1;
  }
  const ssize_t n = ::read(fd_, data, size);
  if (n > 0) return n;
  if (n < 0 && (errno == EAGAIN || errno == EINTR)) return 0;
  error = device_ + (n == 0 ? ": end of file (unplugged?)" : std::string(": read failed: ") + std::strerror(errno));
  return -1;
}

const char* txResultName(TxResult r) {
  switch (r) {
    case TxResult::Ok: return "ok";
    case TxResult::Timeout: return "no status packet (timeout)";
    case TxResult::BadPacket: return "bad status packet";
    case TxResult::PortError: return "port error";
    case TxResult::NotSent: return "not sent";
  }
  return "unknown";
}

bool Bus::receive(double timeout) {
  std::uint8_t buf[256];
  std::string err;
  const long n = port_.read(buf, sizeof(buf), timeout, err);
  if (n < 0) {
    ++counters_.port_errors;
    return false;
  }
  if (n > 0) parser_.feed(buf, static_cast<std::size_t>(n));
  return true;
}

TxResult Bus::transact(std::uint8_t id, std::uint8_t instruction, const std::vector<std::uint8_t>& params,
                       Packet* status, double timeout, bool expect_status) {
  ++counters_.transactions;
  if (!port_.isOpen()) {
    ++counters_.port_errors;
    return TxResult::NotSent;
  }
  // Stale bytes (a late reply to an earlier request) would be taken for this reply.
  std::uint8_t junk[256];
  std::string err;
  while (port_.read(junk, sizeof(junk), 0.0, err) > 0) {
  }
  parser_.clear();
  const std::vector<std::uint8_t> pkt = instructionPacket(protocol_, id, instruction, params);
  if (!port_.write(pkt.data(), pkt.size(), err)) {
    ++counters_.port_errors;
    return TxResult::PortError;
  }
  if (!expect_status) {
    ++counters_.ok;
    return TxResult::Ok;
  }
  const double end = monotonicNow() + port_.byteTime(pkt.size() + 16) + timeout;
  Packet p;
  for (;;) {
    while (parser_.next(p)) {
      if (p.id != id) continue;  // another servo's reply or an echo
      counters_.garbage_bytes += parser_.garbageBytes() - last_garbage_;
      last_garbage_ = parser_.garbageBytes();
      if (status) *status = p;
      if (p.error & (protocol_ == Protocol::V1 ? 0x7F : 0x80)) ++counters_.hardware_error_replies;
      ++counters_.ok;
      return TxResult::Ok;
    }
    // A reply whose checksum failed: this one will not come right; say so now
    // rather than after the timeout (the next request starts afresh).
    if (parser_.badChecksums() != last_bad_) break;
    const double left = end - monotonicNow();
    if (left <= 0) break;
    if (!receive(left)) return TxResult::PortError;
  }
  counters_.garbage_bytes += parser_.garbageBytes() - last_garbage_;
  last_garbage_ = parser_.garbageBytes();
  if (parser_.badChecksums() != last_bad_) {
    last_bad_ = parser_.badChecksums();
    ++counters_.bad_packets;
    return TxResult::BadPacket;
  }
  ++counters_.timeouts;
  return TxResult::Timeout;
}

TxResult Bus::ping(std::uint8_t id, std::uint16_t* model, std::uint8_t* error, double timeout) {
  Packet p;
  TxResult r = transact(id, inst::kPing, {}, &p, timeout);
  if (r != TxResult::Ok) return r;
  if (error) *error = p.error;
  if (model) {
    if (protocol_ == Protocol::V2 && p.params.size() >= 2) {
      *model = static_cast<std::uint16_t>(getLE(p.params.data(), 2));
    } else {
      std::uint32_t m = 0;
      r = readReg(id, mx64Table(protocol_).model_number, m, nullptr, timeout);
      *model = static_cast<std::uint16_t>(m);
    }
  }
  return r;
}

TxResult Bus::read(std::uint8_t id, std::uint16_t addr, std::uint16_t len, std::vector<std::uint8_t>& data,
                   std::uint8_t* error, double timeout) {
  std::vector<std::uint8_t> params;
  putLE(params, addr, protocol_ == Protocol::V1 ? 1 : 2);
  putLE(params, len, protocol_ == Protocol::V1 ? 1 : 2);
  Packet p;
  const TxResult r = transact(id, inst::kRead, params, &p, timeout);
  if (r != TxResult::Ok) return r;
  if (error) *error = p.error;
  if (p.params.size() != len) {
    ++counters_.bad_packets;
    return TxResult::BadPacket;
  }
  data = p.params;
  return r;
}

TxResult Bus::readReg(std::uint8_t id, const Reg& reg, std::uint32_t& value, std::uint8_t* error, double timeout) {
  std::vector<std::uint8_t> d;
  const TxResult r = read(id, reg.addr, reg.size, d, error, timeout);
  if (r == TxResult::Ok) value = getLE(d.data(), reg.size);
  return r;
}

TxResult Bus::write(std::uint8_t id, std::uint16_t addr, const std::vector<std::uint8_t>& data, std::uint8_t* error,
                    bool ack, double timeout) {
  std::vector<std::uint8_t> params;
  putLE(params, addr, protocol_ == Protocol::V1 ? 1 : 2);
  params.insert(params.end(), data.begin(), data.end());
  Packet p;
  const TxResult r = transact(id, inst::kWrite, params, &p, timeout, ack);
  if (r == TxResult::Ok && error && ack) *error = p.error;
  return r;
}

TxResult Bus::writeReg(std::uint8_t id, const Reg& reg, std::uint32_t value, std::uint8_t* error, bool ack,
                       double timeout) {
  std::vector<std::uint8_t> d;
  putLE(d, value, reg.size);
  return write(id, reg.addr, d, error, ack, timeout);
}

TxResult Bus::syncWrite(const Reg& reg, const std::vector<std::pair<std::uint8_t, std::uint32_t>>& values) {
  std::vector<std::uint8_t> params;
  const int w = protocol_ == Protocol::V1 ? 1 : 2;
  putLE(params, reg.addr, w);
  putLE(params, reg.size, w);
  for (const auto& [id, v] : values) {
    params.push_back(id);
    putLE(params, v, reg.size);
  }
  return transact(kBroadcastId, inst::kSyncWrite, params, nullptr, 0.0, false);
}

TxResult Bus::collect(const std::vector<std::uint8_t>& ids, const std::vector<std::uint16_t>& sizes,
                      std::vector<std::pair<std::uint8_t, std::uint32_t>>& values, double timeout) {
  values.clear();
  std::size_t next = 0;
  const double end = monotonicNow() + timeout * ids.size();
  Packet p;
  while (next < ids.size()) {
    while (next < ids.size() && parser_.next(p)) {
      if (p.id != ids[next] || p.params.size() != sizes[next]) continue;
      values.emplace_back(p.id, getLE(p.params.data(), static_cast<int>(std::min<std::size_t>(4, p.params.size()))));
      ++next;
    }
    if (next == ids.size()) break;
    const double left = end - monotonicNow();
    if (left <= 0) break;
    if (!receive(left)) return TxResult::PortError;
  }
  if (next == ids.size()) {
    ++counters_.ok;
    return TxResult::Ok;
  }
  ++counters_.timeouts;
  return TxResult::Timeout;
}

TxResult Bus::syncRead(const Reg& reg, const std::vector<std::uint8_t>& ids,
                       std::vector<std::pair<std::uint8_t, std::uint32_t>>& values, double timeout) {
  if (protocol_ != Protocol::V2) return TxResult::NotSent;
  std::vector<std::uint8_t> params;
  putLE(params, reg.addr, 2);
  putLE(params, reg.size, 2);
  params.insert(params.end(), ids.begin(), ids.end());
  const TxResult r = transact(kBroadcastId, inst::kSyncRead, params, nullptr, 0.0, false);
  if (r != TxResult::Ok) return r;
  return collect(ids, std::vector<std::uint16_t>(ids.size(), reg.size), values, timeout);
}

TxResult Bus::bulkRead(const std::vector<std::pair<std::uint8_t, Reg>>& requests,
                       std::vector<std::pair<std::uint8_t, std::uint32_t>>& values, double timeout) {
  std::vector<std::uint8_t> params, ids;
  std::vector<std::uint16_t> sizes;
  if (protocol_ == Protocol::V1) params.push_back(0x00);
  for (const auto& [id, reg] : requests) {
    if (protocol_ == Protocol::V1) {
      params.insert(params.end(), {reg.size, id, static_cast<std::uint8_t>(reg.addr)});
    } else {
      params.push_back(id);
      putLE(params, reg.addr, 2);
      putLE(params, reg.size, 2);
    }
    ids.push_back(id);
    sizes.push_back(reg.size);
  }
  const TxResult r = transact(kBroadcastId, inst::kBulkRead, params, nullptr, 0.0, false);
  if (r != TxResult::Ok) return r;
  return collect(ids, sizes, values, timeout);
}

TxResult Bus::reboot(std::uint8_t id, std::uint8_t* error, double timeout) {
  if (protocol_ != Protocol::V2) return TxResult::NotSent;
  Packet p;
  const TxResult r = transact(id, inst::kReboot, {}, &p, timeout);
  if (r == TxResult::Ok && error) *error = p.error;
  return r;
}

}  // namespace dynamixel
}  // namespace tilt_laser_perception
