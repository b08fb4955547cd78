#include "tilt_laser_perception/sim/mx64_emulator.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "tilt_laser_perception/sim/utm_emulator.hpp"

namespace tilt_laser_perception {
namespace sim {

using dynamixel::Protocol;
namespace inst = dynamixel::inst;

Mx64Emulator::Mx64Emulator(ServoModel& servo, const Mx64Options& options)
    : servo_(servo), options_(options), table_(dynamixel::mx64Table(options.protocol)) {
  resetTable();
}

Mx64Emulator::~Mx64Emulator() { stop(); }

void Mx64Emulator::resetTable() {
  mem_.assign(table_.size, 0);
  set(table_.model_number, table_.model);
  set(table_.firmware, options_.protocol == Protocol::V1 ? 39 : 41);
  set(table_.id, options_.id);
  set(table_.baud_rate, options_.protocol == Protocol::V1 ? 34 : 1);  // 57600 bps
  set(table_.return_delay, 250);                                     // 500 us
  set(table_.status_return_level, 2);
  set(table_.torque_enable, 0);
  if (options_.protocol == Protocol::V1) {
    set(table_.max_torque, 1023);
    set(table_.goal_position, dynamixel::kCenter);
    set(table_.present_current, 2048);
  }
  registered_.clear();
}

std::uint32_t Mx64Emulator::get(const dynamixel::Reg& r) const {
  return r.valid() ? dynamixel::getLE(mem_.data() + r.addr, r.size) : 0;
}

void Mx64Emulator::set(const dynamixel::Reg& r, std::uint32_t v) {
  if (!r.valid()) return;
  for (int i = 0; i < r.size; ++i) mem_[r.addr + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

std::uint32_t Mx64Emulator::reg(const dynamixel::Reg& r) {
  std::lock_guard<std::recursive_mutex> l(mutex_);
  refresh(hostNow());
  return get(r);
}

void Mx64Emulator::start() {
  openPort();
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

void Mx64Emulator::stop() {
  running_ = false;
  if (thread_.joinable()) thread_.join();
  closePort();
}

void Mx64Emulator::openPort() {
  std::lock_guard<std::recursive_mutex> l(mutex_);
  char name[256];
  termios tio{};
  cfmakeraw(&tio);
  if (::openpty(&master_fd_, &slave_fd_, name, &tio, nullptr) < 0)
    throw std::runtime_error(std::string("openpty: ") + std::strerror(errno));
  slave_name_ = name;
  // Keep our own slave descriptor open: a driver that closes and reopens the
  // port then finds it as before (the master would report a hang-up otherwise).
  ::fcntl(master_fd_, F_SETFL, ::fcntl(master_fd_, F_GETFL) | O_NONBLOCK);
  if (!options_.link_path.empty()) {
    ::unlink(options_.link_path.c_str());
    if (::symlink(slave_name_.c_str(), options_.link_path.c_str()) < 0)
      throw std::runtime_error("cannot link " + options_.link_path + ": " + std::strerror(errno));
  }
  port_open_ = true;
}

void Mx64Emulator::closePort() {
  std::lock_guard<std::recursive_mutex> l(mutex_);
  port_open_ = false;
  if (!options_.link_path.empty()) ::unlink(options_.link_path.c_str());
  if (master_fd_ >= 0) ::close(master_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
  master_fd_ = slave_fd_ = -1;
}

void Mx64Emulator::vanish() { closePort(); }
void Mx64Emulator::reappear() {
  if (!port_open_) openPort();
}

std::string Mx64Emulator::devicePath() const {
  return options_.link_path.empty() ? slave_name_ : options_.link_path;
}

void Mx64Emulator::setHardwareError(std::uint8_t bits) {
  std::lock_guard<std::recursive_mutex> l(mutex_);
  hw_error_ = bits;
  if (bits & (0x04 | 0x20)) {  // overheating or overload: shutdown
    servo_.setTorque(hostNow(), false);
    set(table_.torque_enable, 0);
  }
}

void Mx64Emulator::refresh(double t) {
  const ServoModel::State s = servo_.state(t);
  const bool v1 = options_.protocol == Protocol::V1;
  set(table_.present_position, static_cast<std::uint32_t>(dynamixel::radToPosition(servo_.reading(t))));
  const double rpm_unit = dynamixel::velocityUnitRpm(options_.protocol) * 2.0 * M_PI / 60.0;
  const long vraw = std::lround(s.velocity / rpm_unit);
  if (v1) {
    set(table_.present_speed, static_cast<std::uint32_t>(std::min<long>(std::labs(vraw), 1023) | (vraw < 0 ? 0x400 : 0)));
    const long load = std::lround(std::min(1.0, std::abs(s.velocity) * 0.02) * 1000.0);
    set(table_.present_load, static_cast<std::uint32_t>(load | (vraw < 0 ? 0x400 : 0)));
    set(table_.present_current, static_cast<std::uint32_t>(2048 + load / 4));
    set(table_.present_voltage, static_cast<std::uint32_t>(std::lround(options_.voltage * 10)));
  } else {
    set(table_.present_speed, static_cast<std::uint32_t>(static_cast<std::int32_t>(vraw)));
    set(table_.present_current, static_cast<std::uint32_t>(static_cast<std::uint16_t>(std::lround(s.velocity * 10))));
    set(table_.present_voltage, static_cast<std::uint32_t>(std::lround(options_.voltage * 10)));
    set(table_.hardware_error, hw_error_);
  }
  set(table_.present_temperature, static_cast<std::uint32_t>(std::lround(options_.temperature + ((hw_error_ & 0x04) ? 40 : 0))));
  set(table_.moving, s.moving ? 1 : 0);
}

void Mx64Emulator::applyWrite(std::uint16_t addr, const std::vector<std::uint8_t>& data, double t) {
  for (std::size_t i = 0; i < data.size() && addr + i < mem_.size(); ++i) mem_[addr + i] = data[i];
  const auto touched = [&](const dynamixel::Reg& r) {
    return r.valid() && addr < r.addr + r.size && addr + data.size() > r.addr;
  };
  const Protocol p = options_.protocol;
  if (touched(table_.torque_enable)) {
    const bool on = get(table_.torque_enable) != 0 && !(hw_error_ & (0x04 | 0x20));
    set(table_.torque_enable, on);
    servo_.setTorque(t, on);
  }
  if (touched(table_.moving_speed)) {
    const std::uint32_t v = get(table_.moving_speed) & 0x3FF;
    servo_.setVelocityLimit(t, v == 0 ? 0.0 : dynamixel::velocityToRadPerSec(p, v));
  }
  if (touched(table_.profile_velocity)) {
    const std::uint32_t v = get(table_.profile_velocity);
    servo_.setVelocityLimit(t, v == 0 ? 0.0 : dynamixel::velocityToRadPerSec(p, v));
  }
  if (touched(table_.goal_acceleration))
    servo_.setAccelerationLimit(t, dynamixel::accelerationToRadPerSec2(p, get(table_.goal_acceleration)));
  if (touched(table_.profile_acceleration))
    servo_.setAccelerationLimit(t, dynamixel::accelerationToRadPerSec2(p, get(table_.profile_acceleration)));
  if (touched(table_.goal_position) && get(table_.torque_enable))
    servo_.setGoal(t, dynamixel::positionToRad(static_cast<std::int32_t>(get(table_.goal_position))));
  if (touched(table_.id)) options_.id = static_cast<std::uint8_t>(get(table_.id));
}

void Mx64Emulator::reply(std::uint8_t error, const std::vector<std::uint8_t>& params, bool is_ping) {
  const std::uint32_t level = get(table_.status_return_level);
  if (!is_ping && level == 0) return;
  if (no_reply_.load()) return;
  const std::uint32_t delay_us = get(table_.return_delay) * 2;
  if (delay_us > 0) std::this_thread::sleep_for(std::chrono::microseconds(delay_us));
  std::vector<std::uint8_t> bytes;
  if (garbage_.load() > 0) {
    --garbage_;
    bytes = {0x00, 0xFF, 0x13, 0xFD, 0x42};
  }
  std::vector<std::uint8_t> pkt = dynamixel::statusPacket(options_.protocol, options_.id, error, params);
  if (corrupt_.load() > 0) {
    --corrupt_;
    pkt.back() ^= 0x5A;
  }
  bytes.insert(bytes.end(), pkt.begin(), pkt.end());
  if (master_fd_ >= 0) {
    std::size_t off = 0;
    while (off < bytes.size()) {
      const ssize_t n = ::write(master_fd_, bytes.data() + off, bytes.size() - off);
      if (n <= 0) {
        if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
          std::this_thread::sleep_for(std::chrono::microseconds(200));
          continue;
        }
        break;
      }
      off += static_cast<std::size_t>(n);
    }
  }
  ++stats_.replies;
}

void Mx64Emulator::handle(const dynamixel::Packet& p) {
  const bool v1 = options_.protocol == Protocol::V1;
  const double t = hostNow();
  const std::uint8_t id = options_.id;
  const bool for_us = p.id == id;
  const bool broadcast = p.id == dynamixel::kBroadcastId;
  if (!for_us && !broadcast) return;
  ++stats_.packets;
  // Error byte: 1.0 carries the hardware bits; 2.0 sets the alert bit when the hardware error register is non-zero.
  const std::uint8_t hw = v1 ? hw_error_ : (hw_error_ ? 0x80 : 0x00);
  const auto error = [&](std::uint8_t v1_bit, std::uint8_t v2_code) {
    return static_cast<std::uint8_t>(v1 ? (hw | v1_bit) : (hw | v2_code));
  };
  const std::vector<std::uint8_t>& a = p.params;
  switch (p.instruction) {
    case inst::kPing: {
      if (broadcast && v1) return;
      std::vector<std::uint8_t> params;
      if (!v1) {
        dynamixel::putLE(params, table_.model, 2);
        params.push_back(static_cast<std::uint8_t>(get(table_.firmware)));
      }
      reply(hw, params, true);
      return;
    }
    case inst::kRead: {
      if (broadcast) return;
      const std::size_t need = v1 ? 2 : 4;
      if (a.size() != need) return reply(error(0x40, 5), {});
      const std::uint16_t addr = v1 ? a[0] : static_cast<std::uint16_t>(dynamixel::getLE(a.data(), 2));
      const std::uint16_t len = v1 ? a[1] : static_cast<std::uint16_t>(dynamixel::getLE(a.data() + 2, 2));
      if (addr + len > mem_.size() || len == 0) return reply(error(0x08, 4), {});
      refresh(t);
      if (get(table_.status_return_level) >= 1)
        reply(hw, std::vector<std::uint8_t>(mem_.begin() + addr, mem_.begin() + addr + len));
      return;
    }
    case inst::kWrite:
    case inst::kRegWrite: {
      const std::size_t head = v1 ? 1 : 2;
      if (a.size() <= head) return reply(error(0x40, 5), {});
      const std::uint16_t addr = v1 ? a[0] : static_cast<std::uint16_t>(dynamixel::getLE(a.data(), 2));
      const std::vector<std::uint8_t> data(a.begin() + static_cast<long>(head), a.end());
      if (addr + data.size() > mem_.size()) return reply(error(0x08, 4), {});
      if (p.instruction == inst::kWrite) {
        applyWrite(addr, data, t);
      } else {
        registered_ = a;
      }
      if (!broadcast && get(table_.status_return_level) >= 2) reply(hw, {});
      return;
    }
    case inst::kAction: {
      if (!registered_.empty()) {
        const std::size_t head = v1 ? 1 : 2;
        const std::uint16_t addr =
            v1 ? registered_[0] : static_cast<std::uint16_t>(dynamixel::getLE(registered_.data(), 2));
        applyWrite(addr, std::vector<std::uint8_t>(registered_.begin() + static_cast<long>(head), registered_.end()), t);
        registered_.clear();
      }
      if (!broadcast && get(table_.status_return_level) >= 2) reply(hw, {});
      return;
    }
    case inst::kFactoryReset:
      if (!broadcast) reply(hw, {});
      resetTable();
      servo_.setTorque(t, false);
      return;
    case inst::kReboot:
      if (v1) return reply(error(0x40, 2), {});
      if (!broadcast) reply(hw, {});
      hw_error_ = 0;
      set(table_.torque_enable, 0);
      servo_.setTorque(t, false);
      return;
    case inst::kSyncWrite: {
      const std::size_t head = v1 ? 2 : 4;
      if (a.size() < head) return;
      const std::uint16_t addr = v1 ? a[0] : static_cast<std::uint16_t>(dynamixel::getLE(a.data(), 2));
      const std::uint16_t len = v1 ? a[1] : static_cast<std::uint16_t>(dynamixel::getLE(a.data() + 2, 2));
      for (std::size_t i = head; i + 1 + len <= a.size(); i += 1 + len)
        if (a[i] == id) applyWrite(addr, std::vector<std::uint8_t>(a.begin() + i + 1, a.begin() + i + 1 + len), t);
      return;
    }
    case inst::kSyncRead: {
      if (v1 || a.size() < 4) return;
      const std::uint16_t addr = static_cast<std::uint16_t>(dynamixel::getLE(a.data(), 2));
      const std::uint16_t len = static_cast<std::uint16_t>(dynamixel::getLE(a.data() + 2, 2));
      for (std::size_t i = 4; i < a.size(); ++i) {
        if (a[i] != id) continue;
        if (addr + len > mem_.size()) return reply(error(0x08, 4), {});
        refresh(t);
        reply(hw, std::vector<std::uint8_t>(mem_.begin() + addr, mem_.begin() + addr + len));
      }
      return;
    }
    case inst::kBulkRead: {
      // 1.0: 0x00, then [len, id, addr]...; 2.0: [id, addr L, addr H, len L, len H]...
      const std::size_t start = v1 ? 1 : 0, step = v1 ? 3 : 5;
      for (std::size_t i = start; i + step <= a.size(); i += step) {
        const std::uint8_t rid = v1 ? a[i + 1] : a[i];
        if (rid != id) continue;
        const std::uint16_t addr = v1 ? a[i + 2] : static_cast<std::uint16_t>(dynamixel::getLE(a.data() + i + 1, 2));
        const std::uint16_t len = v1 ? a[i] : static_cast<std::uint16_t>(dynamixel::getLE(a.data() + i + 3, 2));
        if (addr + len > mem_.size()) return reply(error(0x08, 4), {});
        refresh(t);
        reply(hw, std::vector<std::uint8_t>(mem_.begin() + addr, mem_.begin() + addr + len));
      }
      return;
    }
    default:
      if (!broadcast) reply(error(0x40, 2), {});
  }
}

void Mx64Emulator::run() {
  dynamixel::PacketParser parser(options_.protocol, false);
  std::uint8_t buf[512];
  while (running_) {
    int fd;
    {
      std::lock_guard<std::recursive_mutex> l(mutex_);
      fd = master_fd_;
    }
    if (fd < 0) {
      parser.clear();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      continue;
    }
    pollfd pfd{fd, POLLIN, 0};
    if (::poll(&pfd, 1, 20) <= 0) continue;
    std::lock_guard<std::recursive_mutex> l(mutex_);
    if (master_fd_ != fd) continue;
    const ssize_t n = ::read(fd, buf, sizeof(buf));
    if (n <= 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    parser.feed(buf, static_cast<std::size_t>(n));
    dynamixel::Packet p;
    while (parser.next(p)) handle(p);
    stats_.bad_packets = parser.badChecksums();
    stats_.garbage_bytes = parser.garbageBytes();
  }
}

}  // namespace sim
}  // namespace tilt_laser_perception
