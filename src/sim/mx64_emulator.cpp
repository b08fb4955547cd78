#include "tilt_laser_perception/sim/mx64_emulator.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "tilt_laser_perception/sim/utm_emulator.hpp"

namespace tilt_laser_perception {
namespace dynamixel {
int lineBaud(int fd);  // termios2.cpp
}
namespace sim {

using dynamixel::Protocol;
namespace inst = dynamixel::inst;
namespace err1 = dynamixel::err1;
namespace err2 = dynamixel::err2;

namespace {
/// A register's value as the signed or unsigned number its range says.
std::int64_t valueOf(const std::vector<std::uint8_t>& mem, const dynamixel::RegisterInfo& r) {
  const std::uint32_t u = dynamixel::getLE(mem.data() + r.addr, r.size);
  if (r.min >= 0) return u;
  const int shift = 32 - 8 * r.size;
  return static_cast<std::int32_t>(u << shift) >> shift;
}
}  // namespace

Mx64Emulator::Mx64Emulator(ServoModel& servo, const Mx64Options& options)
    : servo_(servo), options_(options), table_(dynamixel::mx64Table(options.protocol)) {
  resetTable();
}

Mx64Emulator::~Mx64Emulator() { stop(); }

void Mx64Emulator::resetTable(bool eeprom_too) {
  const bool v1 = options_.protocol == Protocol::V1;
  if (eeprom_too) mem_.assign(table_.size, 0);
  for (const auto& r : dynamixel::mx64Registers(options_.protocol)) {
    if (r.eeprom && !eeprom_too) continue;
    const std::int64_t v = r.initial == dynamixel::kNoInitial ? 0 : r.initial;
    for (int i = 0; i < r.size; ++i) mem_[r.addr + i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(v) >> (8 * i));
  }
  if (eeprom_too) {
    set(table_.firmware, v1 ? 39 : 41);
    set(table_.id, options_.id);
    if (options_.limit_lo <= options_.limit_hi) {
      set(v1 ? table_.cw_angle_limit : table_.min_position_limit, static_cast<std::uint32_t>(options_.limit_lo));
      set(v1 ? table_.ccw_angle_limit : table_.max_position_limit, static_cast<std::uint32_t>(options_.limit_hi));
    }
  }
  set(table_.goal_position, dynamixel::kCenter);
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
  std::int32_t raw = dynamixel::radToPosition(servo_.reading(t));
  // 1.0 reports one turn (0..4095) but in multi-turn mode; 2.0 the position
  // turned through (its velocity and extended position modes go on past a turn).
  if (v1 && !(get(table_.cw_angle_limit) == 4095 && get(table_.ccw_angle_limit) == 4095)) raw = ((raw % 4096) + 4096) % 4096;
  set(table_.present_position, static_cast<std::uint32_t>(raw));
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

bool Mx64Emulator::lacks(std::uint16_t a) const {
  const auto& u = options_.undefined_addresses;
  return std::find(u.begin(), u.end(), a) != u.end();
}

bool Mx64Emulator::lacksAny(std::uint16_t addr, std::uint16_t len) const {
  for (const std::uint16_t a : options_.undefined_addresses)
    if (a >= addr && a < addr + len) return true;
  return false;
}

int Mx64Emulator::indirectTarget(std::uint16_t a) const {
  if (options_.protocol != Protocol::V2) return -1;
  int at = -1;  // the Indirect Address register of this data byte
  if (a >= 224 && a <= 251) at = 168 + 2 * (a - 224);
  if (a >= 634 && a <= 661) at = 578 + 2 * (a - 634);
  return at < 0 ? -1 : static_cast<int>(dynamixel::getLE(mem_.data() + at, 2));
}

std::vector<std::uint8_t> Mx64Emulator::readBytes(std::uint16_t addr, std::uint16_t len) const {
  std::vector<std::uint8_t> out(mem_.begin() + addr, mem_.begin() + addr + len);
  for (std::uint16_t i = 0; i < len; ++i) {
    const int to = indirectTarget(static_cast<std::uint16_t>(addr + i));
    if (to >= 0 && to < static_cast<int>(mem_.size()) && indirectTarget(static_cast<std::uint16_t>(to)) < 0)
      out[i] = mem_[to];
  }
  return out;
}

std::uint8_t Mx64Emulator::checkWrite(std::uint16_t addr, const std::vector<std::uint8_t>& data) const {
  const Protocol p = options_.protocol;
  const bool v1 = p == Protocol::V1;
  const auto fail = [&](std::uint8_t e1, std::uint8_t e2) { return v1 ? e1 : e2; };
  if (data.empty()) return fail(err1::kInstruction, err2::kDataLength);
  if (addr + data.size() > mem_.size()) return fail(err1::kRange, err2::kAccess);
  std::vector<std::uint8_t> next(mem_);  // the table as the write would leave it
  std::copy(data.begin(), data.end(), next.begin() + addr);
  bool goal = false, goal_velocity = false, goal_current = false, goal_pwm = false;
  for (std::size_t i = 0; i < data.size();) {
    const dynamixel::RegisterInfo* r = dynamixel::mx64RegisterAt(p, static_cast<std::uint16_t>(addr + i));
    // Undefined (reserved) or read-only: 2.0 "Access Error"; 1.0 has no such bit: range.
    if (!r || !r->writable || lacks(r->addr)) return fail(err1::kRange, err2::kAccess);
    // 2.0: "Data in the EEPROM Area can only be written when Torque Enable is 0".
    if (!v1 && r->eeprom && get(table_.torque_enable)) return err2::kAccess;
    // 1.0 Lock (47) = 1: only addresses 24..35 can be written.
    if (v1 && get(table_.lock) && (r->addr < 24 || r->addr > 35)) return err1::kRange;
    // 2.0: a part of a register is a "Data Length Error" (1.0 takes single bytes).
    const bool whole = r->addr >= addr && r->addr + r->size <= addr + data.size();
    if (!whole && !v1) return err2::kDataLength;
    const std::int64_t v = valueOf(next, *r);
    if (v < r->min || v > r->max) return fail(err1::kRange, err2::kDataRange);
    goal = goal || r->addr == table_.goal_position.addr;
    goal_velocity = goal_velocity || (!v1 && r->addr == 104);
    goal_current = goal_current || (!v1 && r->addr == 102);
    goal_pwm = goal_pwm || (!v1 && r->addr == 100);
    i = r->addr + r->size - addr;
  }
  const auto at = [&](std::uint16_t a) { return valueOf(next, *dynamixel::mx64RegisterAt(p, a)); };
  if (goal && v1) {
    // Joint mode: the goal within CW..CCW Angle Limit (both 0: wheel mode;
    // both 4095: multi-turn), else the angle limit error bit.
    const std::int64_t cw = at(6), ccw = at(8), g = at(30);
    const bool joint = !(cw == 0 && ccw == 0) && !(cw == 4095 && ccw == 4095);
    if (joint && (g < cw || g > ccw)) return err1::kAngleLimit;
  }
  if (goal && !v1) {
    // Position Control Mode (3): 0..4095 is the range, Min..Max Position Limit the limit.
    // (Extended position modes take the register's whole range.)
    const std::int64_t g = at(116);
    if (at(11) == 3) {
      if (g < 0 || g > 4095) return err2::kDataRange;
      if (g < at(52) || g > at(48)) return err2::kDataLimit;
    }
  }
  if (goal_velocity && std::abs(at(104)) > at(44)) return err2::kDataLimit;
  if (goal_current && std::abs(at(102)) > at(38)) return err2::kDataLimit;
  if (goal_pwm && std::abs(at(100)) > at(36)) return err2::kDataLimit;
  return 0;
}

void Mx64Emulator::applyWrite(std::uint16_t addr, const std::vector<std::uint8_t>& data, double t) {
  // Indirect data bytes write the bytes their Indirect Address names.
  std::vector<std::uint16_t> written;
  for (std::size_t i = 0; i < data.size() && addr + i < mem_.size(); ++i) {
    const auto a = static_cast<std::uint16_t>(addr + i);
    mem_[a] = data[i];
    written.push_back(a);
    const int to = indirectTarget(a);
    if (to >= 0 && to < static_cast<int>(mem_.size()) && indirectTarget(static_cast<std::uint16_t>(to)) < 0) {
      mem_[to] = data[i];
      written.push_back(static_cast<std::uint16_t>(to));
    }
  }
  const auto touched = [&](const dynamixel::Reg& r) {
    if (!r.valid()) return false;
    for (const std::uint16_t a : written)
      if (a >= r.addr && a < r.addr + r.size) return true;
    return false;
  };
  const Protocol p = options_.protocol;
  if (touched(table_.torque_enable)) {
    const bool on = get(table_.torque_enable) != 0 && !(hw_error_ & (0x04 | 0x20));
    set(table_.torque_enable, on);
    servo_.setTorque(t, on);
  }
  // Velocity control: 1.0's wheel mode (CW and CCW Angle Limit both 0: the
  // Moving Speed's bit 10 says CW), 2.0's Operating Mode 1 (the Goal Velocity).
  const bool v1 = p == Protocol::V1;
  const bool wheel = v1 ? get(table_.cw_angle_limit) == 0 && get(table_.ccw_angle_limit) == 0
                        : get(table_.operating_mode) == 1;
  const bool mode_touched = v1 ? touched(table_.cw_angle_limit) || touched(table_.ccw_angle_limit)
                               : touched(table_.operating_mode);
  if (wheel && (mode_touched || touched(table_.torque_enable) || touched(v1 ? table_.moving_speed : table_.goal_velocity))) {
    const std::uint32_t raw = get(v1 ? table_.moving_speed : table_.goal_velocity);
    servo_.setGoalVelocity(t, get(table_.torque_enable) ? dynamixel::velocityToRadPerSec(p, raw) : 0.0);
  } else if (!wheel && mode_touched) {
    servo_.wrapToOneTurn(t);  // position control again: the turns made are forgotten
  }
  if (!wheel && touched(table_.moving_speed)) {
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
  if (touched(table_.goal_position) && get(table_.torque_enable) && !wheel)
    servo_.setGoal(t, dynamixel::positionToRad(static_cast<std::int32_t>(get(table_.goal_position))));
  if (touched(table_.id)) options_.id = static_cast<std::uint8_t>(get(table_.id));
}

void Mx64Emulator::reply(std::uint8_t error, const std::vector<std::uint8_t>& params, bool is_ping) {
  const std::uint32_t level = get(table_.status_return_level);
  if (!is_ping && level == 0) return;
  if (no_reply_.load()) return;
  if (dynamixel::refusal(options_.protocol, error)) ++stats_.error_replies;
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
  if (t < silent_until_) return;  // booting
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
      if (a.size() != need) return reply(error(err1::kInstruction, err2::kDataLength), {});
      const std::uint16_t addr = v1 ? a[0] : static_cast<std::uint16_t>(dynamixel::getLE(a.data(), 2));
      const std::uint16_t len = v1 ? a[1] : static_cast<std::uint16_t>(dynamixel::getLE(a.data() + 2, 2));
      // Past the table: 2.0 "Access Error" (an address not defined), 1.0 range.
      if (addr + len > mem_.size() || len == 0 || lacksAny(addr, len))
        return reply(error(err1::kRange, err2::kAccess), {});
      refresh(t);
      if (get(table_.status_return_level) >= 1) reply(hw, readBytes(addr, len));
      return;
    }
    case inst::kWrite:
    case inst::kRegWrite: {
      const std::size_t head = v1 ? 1 : 2;
      if (a.size() <= head) return reply(error(err1::kInstruction, err2::kDataLength), {});
      const std::uint16_t addr = v1 ? a[0] : static_cast<std::uint16_t>(dynamixel::getLE(a.data(), 2));
      const std::vector<std::uint8_t> data(a.begin() + static_cast<long>(head), a.end());
      const std::uint8_t bad = checkWrite(addr, data);
      if (bad) return broadcast ? void() : reply(error(bad, bad), {});
      if (p.instruction == inst::kWrite) {
        applyWrite(addr, data, t);
      } else {
        registered_ = a;
        set(table_.registered, 1);
      }
      if (!broadcast && get(table_.status_return_level) >= 2) reply(hw, {});
      return;
    }
    case inst::kAction: {
      // "Instruction Error: ... Action without Reg Write".
      if (registered_.empty()) return broadcast ? void() : reply(error(err1::kInstruction, err2::kInstruction), {});
      const std::size_t head = v1 ? 1 : 2;
      const std::uint16_t addr =
          v1 ? registered_[0] : static_cast<std::uint16_t>(dynamixel::getLE(registered_.data(), 2));
      applyWrite(addr, std::vector<std::uint8_t>(registered_.begin() + static_cast<long>(head), registered_.end()), t);
      registered_.clear();
      set(table_.registered, 0);
      if (!broadcast && get(table_.status_return_level) >= 2) reply(hw, {});
      return;
    }
    case inst::kFactoryReset:
      if (!broadcast) reply(hw, {});
      resetTable();
      servo_.setTorque(t, false);
      return;
    case inst::kReboot:
      if (v1) return reply(error(err1::kInstruction, err2::kInstruction), {});
      if (!broadcast) reply(hw, {});
      hw_error_ = 0;
      resetTable(false);  // the RAM area starts again from its initial values
      servo_.setTorque(t, false);
      silent_until_ = t + options_.reboot_time;
      return;
    case inst::kSyncWrite: {
      const std::size_t head = v1 ? 2 : 4;
      if (a.size() < head) return;
      const std::uint16_t addr = v1 ? a[0] : static_cast<std::uint16_t>(dynamixel::getLE(a.data(), 2));
      const std::uint16_t len = v1 ? a[1] : static_cast<std::uint16_t>(dynamixel::getLE(a.data() + 2, 2));
      for (std::size_t i = head; i + 1 + len <= a.size(); i += 1 + len) {
        if (a[i] != id) continue;
        const std::vector<std::uint8_t> data(a.begin() + i + 1, a.begin() + i + 1 + len);
        if (!checkWrite(addr, data)) applyWrite(addr, data, t);  // (no status packet to carry an error)
      }
      return;
    }
    case inst::kBulkWrite: {
      // 2.0: [id, addr L, addr H, len L, len H, data...]... ; no status packets.
      if (v1) return broadcast ? void() : reply(error(err1::kInstruction, err2::kInstruction), {});
      for (std::size_t i = 0; i + 5 <= a.size();) {
        const std::uint8_t rid = a[i];
        const auto addr = static_cast<std::uint16_t>(dynamixel::getLE(a.data() + i + 1, 2));
        const std::size_t len = dynamixel::getLE(a.data() + i + 3, 2);
        if (i + 5 + len > a.size()) break;
        const std::vector<std::uint8_t> data(a.begin() + static_cast<long>(i + 5),
                                             a.begin() + static_cast<long>(i + 5 + len));
        if (rid == id && !checkWrite(addr, data)) applyWrite(addr, data, t);
        i += 5 + len;
      }
      return;
    }
    case inst::kSyncRead: {
      if (v1 || a.size() < 4) return;
      const std::uint16_t addr = static_cast<std::uint16_t>(dynamixel::getLE(a.data(), 2));
      const std::uint16_t len = static_cast<std::uint16_t>(dynamixel::getLE(a.data() + 2, 2));
      for (std::size_t i = 4; i < a.size(); ++i) {
        if (a[i] != id) continue;
        if (addr + len > mem_.size()) return reply(error(err1::kRange, err2::kAccess), {});
        refresh(t);
        reply(hw, readBytes(addr, len));
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
        if (addr + len > mem_.size()) return reply(error(err1::kRange, err2::kAccess), {});
        refresh(t);
        reply(hw, readBytes(addr, len));
      }
      return;
    }
    default:
      if (!broadcast) reply(error(err1::kInstruction, err2::kInstruction), {});
  }
}

bool Mx64Emulator::lineBaudMatches() const {
  const int line = dynamixel::lineBaud(master_fd_);
  const int want = dynamixel::baudRateOf(options_.protocol, get(table_.baud_rate));
  if (line <= 0 || want <= 0) return true;  // (a line without a rate: not judged)
  return std::abs(line - want) <= 0.03 * want;  // a UART takes about 3 % of error
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
    if (!lineBaudMatches()) {  // bits at another rate: nothing the servo can read
      stats_.wrong_baud_bytes += static_cast<unsigned long>(n);
      continue;
    }
    parser.feed(buf, static_cast<std::size_t>(n));
    dynamixel::Packet p;
    const std::size_t bad_before = parser.badChecksums();
    while (parser.next(p)) handle(p);
    // A packet for this servo whose checksum / CRC is wrong: 1.0 checksum bit, 2.0 "CRC Error".
    if (parser.badChecksums() != bad_before && parser.lastBadId() == options_.id && hostNow() >= silent_until_)
      reply(options_.protocol == Protocol::V1 ? err1::kChecksum : err2::kCrc, {});
    stats_.bad_packets = parser.badChecksums();
    stats_.garbage_bytes = parser.garbageBytes();
  }
}

}  // namespace sim
}  // namespace tilt_laser_perception
