// The emulated UTM-30LX-EW over TCP and the emulated MX-64 over a pseudo
// terminal, driven the way a driver would, with every fault triggered.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "tilt_laser_perception/scip/codec.hpp"
#include "tilt_laser_perception/sim/mx64_emulator.hpp"
#include "tilt_laser_perception/sim/utm_emulator.hpp"
#include "sim_room.hpp"

using namespace tilt_laser_perception;
using namespace tilt_laser_perception::sim;

namespace {

/// A plain TCP client of the emulated sensor.
class Client {
 public:
  explicit Client(std::uint16_t port) { connectTo(port); }
  ~Client() { if (fd_ >= 0) ::close(fd_); }
  bool connectTo(std::uint16_t port) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    ::inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    return ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0;
  }
  void send(const std::string& s) { ASSERT_EQ(::send(fd_, s.data(), s.size(), MSG_NOSIGNAL), static_cast<ssize_t>(s.size())); }
  /// Next reply within `timeout` [s]; `closed` set when the peer closed the connection.
  std::optional<scip::Response> next(double timeout, bool* closed = nullptr) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
    for (;;) {
      if (auto r = reader_.next()) return r;
      const int ms = static_cast<int>(std::chrono::duration<double, std::milli>(end - std::chrono::steady_clock::now()).count());
      if (ms <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, ms) <= 0) continue;
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof(buf), 0);
      if (n <= 0) {
        if (closed) *closed = true;
        return std::nullopt;
      }
      reader_.feed(buf, static_cast<std::size_t>(n));
    }
  }
  std::optional<scip::Response> command(const std::string& c, double timeout = 1.0) {
    send(c + "\n");
    return next(timeout);
  }

 private:
  int fd_ = -1;
  scip::ResponseReader reader_;
};

using tilt_laser_perception::test::Room;

}  // namespace

namespace {
/// A scan source of known echoes: every beam at 2 m, beam 100 a mixed pixel
/// at 2.98 m with the far surface at 3.34 m behind it, beam 200 three
/// echoes, beam 300 no return, beam 400 at 5 m (beyond MS's 4095 mm).
ScanSource knownEchoes() {
  return [](double t0, SimScan& out) {
    out.stamp = t0;
    out.ranges.assign(1081, 2.0f);
    out.intensities.assign(1081, 1000.0f);
    out.echoes.assign(1081, BeamEchoes());
    for (auto& e : out.echoes) {
      e.count = 1;
      e.range[0] = 2.0f;
      e.intensity[0] = 1000.0f;
    }
    const auto set = [&](int i, std::initializer_list<float> r) {
      BeamEchoes& e = out.echoes[i];
      e.count = 0;
      for (float x : r) {
        e.range[e.count] = x;
        e.intensity[e.count] = 500.0f + e.count;
        ++e.count;
      }
      out.ranges[i] = e.range[0];
      out.intensities[i] = e.intensity[0];
    };
    set(100, {2.98f, 3.34f});
    set(200, {0.8f, 2.5f, 7.25f});
    set(400, {5.0f});
    out.ranges[300] = std::numeric_limits<float>::infinity();
    out.echoes[300].count = 0;
  };
}

scip::ScanData scanOf(Client& c, const std::string& cmd, const std::string& status) {
  scip::ScanRequest req;
  EXPECT_EQ(scip::parseScanRequest(cmd, 1080, req), "00");
  auto r = c.command(cmd, 1.0);
  EXPECT_TRUE(r.has_value()) << cmd;
  if (!r) return {};
  EXPECT_EQ(r->status, req.continuous() ? "00" : status) << cmd;
  if (req.continuous()) r = c.next(0.5);  // the first scan after the echo of the command
  EXPECT_TRUE(r.has_value()) << cmd;
  scip::ScanData d;
  if (r) {
    EXPECT_EQ(scip::decodeScan(*r, req, d), scip::DecodeError::None) << cmd;
  }
  return d;
}
}  // namespace

TEST(UtmEmulator, MultiEchoAndTwoCharacterRangesAsTheProtocolDefinesThem) {
  UtmEmulator utm(knownEchoes());
  utm.start();
  Client c(utm.port());
  ASSERT_EQ(c.command("BM")->status, "00");
  // HD: every echo; the single-echo commands give the first.
  for (const std::string cmd : {"HD0000108000", "HE0000108000", "ND0000108000001"}) {
    const scip::ScanData d = scanOf(c, cmd, "00");
    ASSERT_EQ(d.echo_count.size(), 1081u) << cmd;
    EXPECT_EQ(d.echo_count[0], 1);
    EXPECT_EQ(d.echo_count[100], 2);
    EXPECT_EQ(d.echo_ranges[100 * scip::kMaxEchoes + 0], 2980u);
    EXPECT_EQ(d.echo_ranges[100 * scip::kMaxEchoes + 1], 3340u);
    EXPECT_EQ(d.echo_count[200], 3);
    EXPECT_EQ(d.echo_ranges[200 * scip::kMaxEchoes + 2], 7250u);
    EXPECT_EQ(d.echo_count[300], 1);
    EXPECT_EQ(d.ranges[300], 1u);  // no return: error code 1, one value
    if (cmd[1] == 'E') {
      EXPECT_EQ(d.echo_intensities[200 * scip::kMaxEchoes + 1], 501u);
    }
  }
  ASSERT_EQ(c.command("BM")->status, "00");  // ND with one scan turned the laser off
  const scip::ScanData gd = scanOf(c, "GD0000108000", "00");
  EXPECT_TRUE(gd.echo_count.empty());
  EXPECT_EQ(gd.ranges[100], 2980u);
  EXPECT_EQ(gd.ranges[400], 5000u);
  // A cluster of two: the step with the nearer first echo, with its echoes.
  const scip::ScanData hd2 = scanOf(c, "HD0000108002", "00");
  ASSERT_EQ(hd2.ranges.size(), 541u);
  EXPECT_EQ(hd2.echo_count[100], 3);  // steps 200 and 201: 200's 0.8 m
  EXPECT_EQ(hd2.echo_ranges[100 * scip::kMaxEchoes], 800u);
  // GS: 5000 mm does not fit 12 bits: error code 1, not 5000 mod 4096 = 904.
  const scip::ScanData gs = scanOf(c, "GS0000108000", "00");
  EXPECT_EQ(gs.ranges[400], 1u);
  EXPECT_EQ(gs.ranges[0], 2000u);
}

TEST(UtmEmulator, AUtm30lxWithoutEwAnswersMultiEchoAsUndefined) {
  UtmOptions opt;
  opt.multi_echo = false;
  UtmEmulator utm(knownEchoes(), opt);
  utm.start();
  Client c(utm.port());
  for (const char* cmd : {"ND0000108000000", "NE0000108000000", "HD0000108000", "HE0000108000"})
    EXPECT_EQ(c.command(cmd)->status, "0E") << cmd;
  EXPECT_EQ(c.command("MD0000108000001")->status, "00");
}

TEST(UtmEmulator, ARebootIsUnreachableForItsBootTime) {
  UtmOptions opt;
  opt.reboot_time = 1.0;
  UtmEmulator utm(knownEchoes(), opt);
  utm.start();
  Client c(utm.port());
  ASSERT_EQ(c.command("RB")->status, "01");
  ASSERT_EQ(c.command("RB")->status, "00");
  const auto t0 = std::chrono::steady_clock::now();
  const auto since = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  int refused = 0;
  while (since() < 0.8) {
    refused += !c.connectTo(utm.port());  // nothing listens: refused, not accepted and closed
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_GE(refused, 6);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_TRUE(c.connectTo(utm.port()));
  EXPECT_EQ(c.command("VV")->status, "00");
}

TEST(UtmEmulator, InfoCommandsAndTimeAdjust) {
  Room room;
  UtmOptions opt;
  opt.clock_offset_ms = 5000.0;
  UtmEmulator utm(room.source(), opt);
  utm.start();
  Client c(utm.port());
  auto vv = c.command("VV");
  ASSERT_TRUE(vv.has_value());
  EXPECT_EQ(vv->status, "00");
  int bad = -1;
  auto info = scip::parseInfo(*vv, &bad);
  EXPECT_EQ(bad, 0);
  ASSERT_EQ(info.size(), 5u);
  EXPECT_EQ(info[4].first, "SERI");
  auto pp = c.command("PP");
  ASSERT_TRUE(pp.has_value());
  info = scip::parseInfo(*pp);
  bool amax = false;
  for (const auto& kv : info) amax = amax || (kv.first == "AMAX" && kv.second == "1080");
  EXPECT_TRUE(amax);
  EXPECT_EQ(c.command("TM1")->status, "04");  // not in adjust mode
  EXPECT_EQ(c.command("TM0")->status, "00");
  EXPECT_EQ(c.command("TM0")->status, "02");
  const double t_req = hostNow();
  auto tm = c.command("TM1");
  ASSERT_TRUE(tm.has_value());
  ASSERT_EQ(tm->lines.size(), 1u);
  const auto stamp = scip::decode(tm->lines[0].data(), 4);
  ASSERT_TRUE(stamp.has_value());
  EXPECT_NEAR(static_cast<double>(*stamp), utm.sensorMillis(t_req), 20.0);
  EXPECT_EQ(c.command("TM2")->status, "00");
  EXPECT_EQ(c.command("GD0000108001")->status, "10");  // laser off
  EXPECT_EQ(c.command("BM")->status, "00");
  EXPECT_EQ(c.command("BM")->status, "02");
  auto gd = c.command("GD0000108001");
  ASSERT_TRUE(gd.has_value());
  scip::ScanRequest req;
  scip::parseScanRequest("GD0000108001", 1080, req);
  scip::ScanData data;
  EXPECT_EQ(scip::decodeScan(*gd, req, data), scip::DecodeError::None);
  EXPECT_EQ(data.ranges.size(), 1081u);
  EXPECT_EQ(c.command("XX")->status, "0E");
}

TEST(UtmEmulator, StreamsWholeScansAt40HzWithCorrectChecksums) {
  Room room;
  UtmOptions opt;
  opt.drift_ppm = 1000.0;
  UtmEmulator utm(room.source(), opt);
  utm.start();
  Client c(utm.port());
  auto ack = c.command("MD0000108000000");
  ASSERT_TRUE(ack.has_value());
  EXPECT_EQ(ack->status, "00");
  scip::ScanRequest req;
  scip::parseScanRequest("MD0000108000000", 1080, req);
  std::vector<double> arrival;
  std::vector<std::uint32_t> stamps;
  const auto t_end = std::chrono::steady_clock::now() + std::chrono::milliseconds(1500);
  int good = 0, bad = 0;
  while (std::chrono::steady_clock::now() < t_end) {
    auto r = c.next(0.2);
    if (!r) continue;
    scip::ScanData d;
    if (scip::decodeScan(*r, req, d) == scip::DecodeError::None && d.ranges.size() == 1081) {
      ++good;
      arrival.push_back(hostNow());
      stamps.push_back(d.timestamp);
    } else {
      ++bad;
    }
  }
  EXPECT_EQ(bad, 0);
  ASSERT_GE(good, 50);
  const double rate = (arrival.size() - 1) / (arrival.back() - arrival.front());
  EXPECT_NEAR(rate, 40.0, 2.0);
  // Sensor time stamps 25 ms apart on the sensor's clock.
  for (std::size_t i = 1; i < stamps.size(); ++i) {
    const std::uint32_t dt = (stamps[i] - stamps[i - 1]) & 0xFFFFFF;
    EXPECT_TRUE(dt == 24 || dt == 25 || dt == 26) << dt;
  }
  // +1000 ppm: 10 s of host time are 10.010 s on the sensor.
  EXPECT_NEAR(utm.sensorMillis(100.0) - utm.sensorMillis(90.0), 10010.0, 1e-6);
  EXPECT_EQ(c.command("QT")->status, "00");
}

TEST(UtmEmulator, ScanDataMatchesTheSimulation) {
  Room room;
  UtmEmulator utm(room.source());
  utm.start();
  Client c(utm.port());
  ASSERT_EQ(c.command("ME0000108001001")->status, "00");  // one scan with intensities
  auto r = c.next(1.0);
  ASSERT_TRUE(r.has_value());
  scip::ScanRequest req;
  scip::parseScanRequest("ME0000108001001", 1080, req);
  scip::ScanData d;
  ASSERT_EQ(scip::decodeScan(*r, req, d), scip::DecodeError::None);
  EXPECT_EQ(d.remaining, 0);
  ASSERT_EQ(d.intensities.size(), 1081u);
  // The room's walls are between 1 and 7.3 m: every beam returns, in millimetres.
  for (std::size_t i = 0; i < d.ranges.size(); i += 60) {
    EXPECT_GT(d.ranges[i], 500u);
    EXPECT_LT(d.ranges[i], 7400u);
    EXPECT_GT(d.intensities[i], 0u);
  }
  EXPECT_FALSE(c.next(0.2).has_value());  // only one scan was asked for
}

TEST(UtmEmulator, FaultsCanBeTriggeredAndSeen) {
  Room room;
  UtmOptions opt;
  opt.reboot_time = 0.5;  // (the real 10 s: ARebootIsUnreachableForItsBootTime's kind of check)
  UtmEmulator utm(room.source(), opt);
  utm.start();
  Client c(utm.port());
  scip::ScanRequest req;
  scip::parseScanRequest("MD0000108000000", 1080, req);
  ASSERT_EQ(c.command("MD0000108000000")->status, "00");
  ASSERT_TRUE(c.next(0.5).has_value());

  utm.corruptNextScans(1);
  bool checksum_seen = false;
  for (int i = 0; i < 5 && !checksum_seen; ++i) {
    auto r = c.next(0.5);
    scip::ScanData d;
    checksum_seen = r && scip::decodeScan(*r, req, d) == scip::DecodeError::Checksum;
  }
  EXPECT_TRUE(checksum_seen);

  utm.truncateNextScans(1);
  bool truncated_seen = false;
  for (int i = 0; i < 5 && !truncated_seen; ++i) {
    auto r = c.next(0.5);
    scip::ScanData d;
    truncated_seen = r && scip::decodeScan(*r, req, d) == scip::DecodeError::Truncated;
  }
  EXPECT_TRUE(truncated_seen);

  utm.setSilent(true);
  c.next(0.1);  // what was already on its way
  bool closed = false;
  EXPECT_FALSE(c.next(0.3, &closed).has_value());
  EXPECT_FALSE(closed);  // silent, but connected
  utm.setSilent(false);
  EXPECT_TRUE(c.next(0.5).has_value());

  utm.dropConnection();
  closed = false;
  for (int i = 0; i < 10 && !closed; ++i) c.next(0.1, &closed);
  EXPECT_TRUE(closed);

  ASSERT_TRUE(c.connectTo(utm.port()));
  utm.setReplyDelay(0.15);
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(c.command("VV", 2.0).has_value());
  EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 0.15);
  utm.setReplyDelay(0.0);

  utm.reboot();
  closed = false;
  for (int i = 0; i < 10 && !closed; ++i) c.next(0.1, &closed);
  EXPECT_TRUE(closed);
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  ASSERT_TRUE(c.connectTo(utm.port()));
  ASSERT_EQ(c.command("TM0")->status, "00");
  auto tm = c.command("TM1");
  ASSERT_TRUE(tm.has_value());
  const auto stamp = scip::decode(tm->lines.at(0).data(), 4);
  ASSERT_TRUE(stamp.has_value());
  EXPECT_LT(*stamp, 2000u);  // the clock restarted
  EXPECT_EQ(utm.stats().reboots.load(), 1u);
}

namespace {

/// A host-side serial port on the emulated servo's pseudo terminal.
class Port {
 public:
  Port(const std::string& path, dynamixel::Protocol p) : parser_(p, true), protocol_(p) {
    fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY);
    if (fd_ >= 0) {
      termios t{};
      ::tcgetattr(fd_, &t);
      ::cfmakeraw(&t);
      ::tcsetattr(fd_, TCSANOW, &t);
    }
  }
  ~Port() { if (fd_ >= 0) ::close(fd_); }
  bool ok() const { return fd_ >= 0; }
  /// Sends an instruction; the status packet if one arrives within `timeout` [s].
  std::optional<dynamixel::Packet> transact(std::uint8_t inst, const std::vector<std::uint8_t>& params, double timeout = 0.2) {
    return sendRaw(dynamixel::instructionPacket(protocol_, 1, inst, params), timeout);
  }
  /// Sets the line's baud rate (as a host's port would be set).
  void setSpeed(speed_t speed) {
    termios t{};
    ::tcgetattr(fd_, &t);
    ::cfsetspeed(&t, speed);
    ::tcsetattr(fd_, TCSANOW, &t);
  }
  /// Sends these bytes; the status packet if one arrives within `timeout` [s].
  std::optional<dynamixel::Packet> sendRaw(const std::vector<std::uint8_t>& pkt, double timeout = 0.2) {
    if (::write(fd_, pkt.data(), pkt.size()) != static_cast<ssize_t>(pkt.size())) return std::nullopt;
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
    dynamixel::Packet p;
    while (std::chrono::steady_clock::now() < end) {
      if (parser_.next(p)) return p;
      pollfd pf{fd_, POLLIN, 0};
      if (::poll(&pf, 1, 5) <= 0) continue;
      std::uint8_t buf[256];
      const ssize_t n = ::read(fd_, buf, sizeof(buf));
      if (n <= 0) { last_read_failed_ = true; return std::nullopt; }
      parser_.feed(buf, static_cast<std::size_t>(n));
    }
    return parser_.next(p) ? std::optional<dynamixel::Packet>(p) : std::nullopt;
  }
  std::vector<std::uint8_t> addr(std::uint16_t a) const {
    std::vector<std::uint8_t> v;
    dynamixel::putLE(v, a, protocol_ == dynamixel::Protocol::V1 ? 1 : 2);
    return v;
  }
  std::optional<dynamixel::Packet> write(const dynamixel::Reg& r, std::uint32_t value) {
    auto p = addr(r.addr);
    dynamixel::putLE(p, value, r.size);
    return transact(dynamixel::inst::kWrite, p);
  }
  std::optional<std::uint32_t> read(const dynamixel::Reg& r) {
    auto p = addr(r.addr);
    dynamixel::putLE(p, r.size, protocol_ == dynamixel::Protocol::V1 ? 1 : 2);
    auto s = transact(dynamixel::inst::kRead, p);
    if (!s || s->params.size() != r.size) return std::nullopt;
    return dynamixel::getLE(s->params.data(), r.size);
  }
  dynamixel::PacketParser parser_;
  dynamixel::Protocol protocol_;
  int fd_ = -1;
  bool last_read_failed_ = false;
};

}  // namespace

class Mx64EmulatorTest : public ::testing::TestWithParam<int> {};

TEST_P(Mx64EmulatorTest, MovesToTheGoalAtTheCommandedSpeed) {
  const auto proto = GetParam() == 1 ? dynamixel::Protocol::V1 : dynamixel::Protocol::V2;
  const auto& tab = dynamixel::mx64Table(proto);
  ServoModel servo(0.0, hostNow());
  Mx64Options opt;
  opt.protocol = proto;
  Mx64Emulator emu(servo, opt);
  emu.start();
  Port port(emu.devicePath(), proto);
  ASSERT_TRUE(port.ok());
  auto ping = port.transact(dynamixel::inst::kPing, {});
  ASSERT_TRUE(ping.has_value());
  EXPECT_EQ(ping->error, 0);
  if (proto == dynamixel::Protocol::V2) {
    ASSERT_EQ(ping->params.size(), 3u);
    EXPECT_EQ(dynamixel::getLE(ping->params.data(), 2), 311u);
  }
  EXPECT_EQ(port.read(tab.model_number).value_or(0), tab.model);
  ASSERT_TRUE(port.write(tab.torque_enable, 1).has_value());
  const double speed = 1.0;  // rad/s
  const dynamixel::Reg& vreg = proto == dynamixel::Protocol::V1 ? tab.moving_speed : tab.profile_velocity;
  ASSERT_TRUE(port.write(vreg, dynamixel::radPerSecToVelocity(proto, speed)).has_value());
  ASSERT_TRUE(port.write(tab.goal_position, static_cast<std::uint32_t>(dynamixel::radToPosition(1.0))).has_value());
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  const double t1 = hostNow();
  const auto p1 = port.read(tab.present_position);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const double t2 = hostNow();
  const auto p2 = port.read(tab.present_position);
  ASSERT_TRUE(p1 && p2);
  const double measured = (dynamixel::positionToRad(static_cast<std::int32_t>(*p2)) -
                           dynamixel::positionToRad(static_cast<std::int32_t>(*p1))) / (t2 - t1);
  // The commanded speed, rounded to the protocol's unit (0.114 / 0.229 rpm).
  EXPECT_NEAR(measured, speed, 0.1 * speed);
  EXPECT_EQ(port.read(tab.moving).value_or(0), 1u);
  const auto v = port.read(tab.present_speed);
  ASSERT_TRUE(v.has_value());
  EXPECT_NEAR(dynamixel::velocityToRadPerSec(proto, *v), speed, 0.05);
  // Status return level 1: writes get no status packet, reads still do.
  port.write(tab.status_return_level, 1);  // from now on (this write included) no status for writes
  EXPECT_FALSE(port.write(tab.led, 1).has_value());
  EXPECT_TRUE(port.read(tab.present_position).has_value());
}

TEST_P(Mx64EmulatorTest, FaultsCanBeTriggeredAndSeen) {
  const auto proto = GetParam() == 1 ? dynamixel::Protocol::V1 : dynamixel::Protocol::V2;
  const auto& tab = dynamixel::mx64Table(proto);
  ServoModel servo(0.0, hostNow());
  Mx64Options opt;
  opt.protocol = proto;
  opt.link_path = ::testing::TempDir() + "/tlp_mx64_" + std::to_string(GetParam()) + "_" + std::to_string(::getpid());
  Mx64Emulator emu(servo, opt);
  emu.start();
  auto port = std::make_unique<Port>(opt.link_path, proto);
  ASSERT_TRUE(port->ok());
  ASSERT_TRUE(port->transact(dynamixel::inst::kPing, {}).has_value());

  emu.setNoReply(true);
  EXPECT_FALSE(port->transact(dynamixel::inst::kPing, {}, 0.1).has_value());
  emu.setNoReply(false);

  emu.corruptNextReplies(1);
  EXPECT_FALSE(port->transact(dynamixel::inst::kPing, {}, 0.1).has_value());
  EXPECT_EQ(port->parser_.badChecksums(), 1u);

  emu.garbageBeforeNextReplies(1);
  EXPECT_TRUE(port->transact(dynamixel::inst::kPing, {}).has_value());
  EXPECT_GE(port->parser_.garbageBytes(), 3u);

  emu.setHardwareError(0x20);  // overload
  auto st = port->read(tab.present_position);
  auto ping = port->transact(dynamixel::inst::kPing, {});
  ASSERT_TRUE(ping.has_value());
  if (proto == dynamixel::Protocol::V1) {
    EXPECT_EQ(ping->error & 0x20, 0x20);
  } else {
    EXPECT_EQ(ping->error & 0x80, 0x80);  // alert
    EXPECT_EQ(port->read(tab.hardware_error).value_or(0), 0x20u);
  }
  EXPECT_TRUE(st.has_value());  // data still comes with the error
  EXPECT_EQ(port->read(tab.torque_enable).value_or(1), 0u);  // shutdown
  emu.setHardwareError(0);

  emu.vanish();
  EXPECT_NE(::access(opt.link_path.c_str(), F_OK), 0);
  EXPECT_FALSE(port->transact(dynamixel::inst::kPing, {}, 0.1).has_value());
  emu.reappear();
  port = std::make_unique<Port>(opt.link_path, proto);
  ASSERT_TRUE(port->ok());
  EXPECT_TRUE(port->transact(dynamixel::inst::kPing, {}).has_value());
  emu.stop();
}

INSTANTIATE_TEST_SUITE_P(Protocols, Mx64EmulatorTest, ::testing::Values(1, 2));

TEST_P(Mx64EmulatorTest, TheControlTableAndItsErrorsAsTheEmanualGivesThem) {
  const auto proto = GetParam() == 1 ? dynamixel::Protocol::V1 : dynamixel::Protocol::V2;
  const bool v1 = proto == dynamixel::Protocol::V1;
  const auto& tab = dynamixel::mx64Table(proto);
  ServoModel servo(0.0, hostNow());
  Mx64Options opt;
  opt.protocol = proto;
  Mx64Emulator emu(servo, opt);
  emu.start();
  Port port(emu.devicePath(), proto);
  ASSERT_TRUE(port.ok());
  port.setSpeed(B57600);
  const auto reg = [](std::uint16_t a, std::uint8_t n) { return dynamixel::Reg{a, n}; };
  const auto errorOf = [&](const std::optional<dynamixel::Packet>& p) { return p ? static_cast<int>(p->error) : -1; };
  // The e-manual's initial values (MX-64AR/AT for 1.0, MX-64(2.0) for 2.0).
  const std::vector<std::pair<dynamixel::Reg, std::uint32_t>> initial =
      v1 ? std::vector<std::pair<dynamixel::Reg, std::uint32_t>>{
               {reg(4, 1), 34}, {reg(5, 1), 250}, {reg(6, 2), 0}, {reg(8, 2), 4095}, {reg(11, 1), 80},
               {reg(12, 1), 60}, {reg(13, 1), 240}, {reg(14, 2), 1023}, {reg(16, 1), 2}, {reg(17, 1), 36},
               {reg(18, 1), 36}, {reg(22, 1), 1}, {reg(28, 1), 32}, {reg(34, 2), 1023}, {reg(68, 2), 2048}}
         : std::vector<std::pair<dynamixel::Reg, std::uint32_t>>{
               {reg(8, 1), 1}, {reg(9, 1), 250}, {reg(11, 1), 3}, {reg(12, 1), 255}, {reg(13, 1), 2},
               {reg(24, 4), 10}, {reg(31, 1), 80}, {reg(32, 2), 160}, {reg(34, 2), 95}, {reg(36, 2), 885},
               {reg(38, 2), 1941}, {reg(40, 4), 32767}, {reg(44, 4), 435}, {reg(48, 4), 4095}, {reg(52, 4), 0},
               {reg(63, 1), 52}, {reg(68, 1), 2}, {reg(76, 2), 1920}, {reg(78, 2), 100}, {reg(84, 2), 850},
               {reg(168, 2), 224}, {reg(222, 2), 251}, {reg(578, 2), 634}, {reg(632, 2), 661}};
  for (const auto& [r, v] : initial) EXPECT_EQ(port.read(r).value_or(99999), v) << "address " << r.addr;

  // A read-only register: 2.0 access error, 1.0 range bit; nothing written.
  EXPECT_EQ(errorOf(port.write(tab.present_position, 100)), v1 ? 0x08 : 0x07);
  EXPECT_EQ(errorOf(port.write(reg(v1 ? 10 : 14, 1), 1)), v1 ? 0x08 : 0x07) << "a reserved address";
  // A goal beyond the register's range: 2.0 data range, 1.0 range bit.
  ASSERT_EQ(errorOf(port.write(tab.torque_enable, 1)), 0);
  EXPECT_EQ(errorOf(port.write(tab.goal_position, 5000)), v1 ? 0x08 : 0x04);
  EXPECT_EQ(port.read(tab.goal_position).value_or(0), 2048u);
  if (!v1) {
    // EEPROM with the torque on: access error; with it off the write is taken.
    EXPECT_EQ(errorOf(port.write(tab.max_position_limit, 3000)), 0x07);
    EXPECT_EQ(port.read(tab.max_position_limit).value_or(0), 4095u);
    ASSERT_EQ(errorOf(port.write(tab.torque_enable, 0)), 0);
    EXPECT_EQ(errorOf(port.write(tab.max_position_limit, 3000)), 0);
    ASSERT_EQ(errorOf(port.write(tab.torque_enable, 1)), 0);
    // Part of a register: data length error.
    EXPECT_EQ(errorOf(port.write(reg(116, 2), 2100)), 0x05);
    // Within the range but beyond Max Position Limit: data limit error.
    EXPECT_EQ(errorOf(port.write(tab.goal_position, 3500)), 0x06);
    // The goal velocity beyond the Velocity Limit: data limit too.
    EXPECT_EQ(errorOf(port.write(reg(104, 4), 500)), 0x06);
  } else {
    ASSERT_EQ(errorOf(port.write(tab.ccw_angle_limit, 3000)), 0);
    EXPECT_EQ(errorOf(port.write(tab.goal_position, 3500)), 0x02);  // the angle limit bit
  }
  EXPECT_EQ(port.read(tab.goal_position).value_or(0), 2048u);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_NEAR(servo.state(hostNow()).position, 0.0, 0.01) << "a refused goal does not move the horn";
  EXPECT_EQ(errorOf(port.write(tab.goal_position, 2900)), 0);  // within the limits: taken

  // Reg Write sets Registered; Action applies it and clears it; Action with nothing registered: instruction error.
  std::vector<std::uint8_t> rw = port.addr(tab.led.addr);
  rw.push_back(1);
  EXPECT_EQ(errorOf(port.transact(dynamixel::inst::kRegWrite, rw)), 0);
  EXPECT_EQ(port.read(tab.registered).value_or(9), 1u);
  EXPECT_EQ(port.read(tab.led).value_or(9), 0u);
  EXPECT_EQ(errorOf(port.transact(dynamixel::inst::kAction, {})), 0);
  EXPECT_EQ(port.read(tab.led).value_or(9), 1u);
  EXPECT_EQ(port.read(tab.registered).value_or(9), 0u);
  EXPECT_EQ(errorOf(port.transact(dynamixel::inst::kAction, {})), v1 ? 0x40 : 0x02);

  // A packet with a wrong checksum / CRC: 1.0 checksum bit, 2.0 CRC error.
  auto pkt = dynamixel::instructionPacket(proto, 1, dynamixel::inst::kPing, {});
  pkt.back() ^= 0x5A;
  EXPECT_EQ(errorOf(port.sendRaw(pkt)), v1 ? 0x10 : 0x03);
  // Past the end of the table.
  std::vector<std::uint8_t> past = port.addr(v1 ? 70 : 650);
  dynamixel::putLE(past, 20, v1 ? 1 : 2);
  EXPECT_EQ(errorOf(port.transact(dynamixel::inst::kRead, past)), v1 ? 0x08 : 0x07);
  // A line at another baud rate than the servo's: no reply.
  port.setSpeed(B115200);
  EXPECT_FALSE(port.transact(dynamixel::inst::kPing, {}, 0.1).has_value());
  port.setSpeed(B57600);
  EXPECT_TRUE(port.transact(dynamixel::inst::kPing, {}).has_value());
  EXPECT_GT(emu.stats().wrong_baud_bytes.load(), 0u);
  if (v1) return;

  // 2.0: the indirect address area. Indirect Address 1..4 = Present Position
  // (132..135): Indirect Data 1..4 (224..227) read it.
  for (int k = 0; k < 4; ++k) ASSERT_EQ(errorOf(port.write(reg(168 + 2 * k, 2), 132 + k)), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const auto direct = port.read(tab.present_position), indirect = port.read(reg(224, 4));
  ASSERT_TRUE(direct && indirect);
  EXPECT_NEAR(static_cast<double>(*indirect), static_cast<double>(*direct), 20.0);  // (it moves meanwhile)
  EXPECT_GT(*direct, 2100u);
  // Bulk Write: the LED off and a goal, no status packet.
  std::vector<std::uint8_t> bw = {1};
  dynamixel::putLE(bw, tab.led.addr, 2);
  dynamixel::putLE(bw, 1, 2);
  bw.push_back(0);
  EXPECT_FALSE(port.transact(dynamixel::inst::kBulkWrite, bw, 0.1).has_value());
  EXPECT_EQ(port.read(tab.led).value_or(9), 0u);
  // Reboot: silent for the boot time, then the RAM area at its initial values.
  ASSERT_TRUE(port.transact(dynamixel::inst::kReboot, {}).has_value());
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(port.transact(dynamixel::inst::kPing, {}, 0.2).has_value());
  std::this_thread::sleep_until(t0 + std::chrono::milliseconds(650));
  EXPECT_TRUE(port.transact(dynamixel::inst::kPing, {}).has_value());
  EXPECT_EQ(port.read(tab.torque_enable).value_or(9), 0u);
  EXPECT_EQ(port.read(tab.max_position_limit).value_or(0), 3000u) << "EEPROM kept";
  EXPECT_EQ(port.read(reg(168, 2)).value_or(0), 224u) << "RAM reset";
}

TEST_P(Mx64EmulatorTest, SyncWriteAndBulkRead) {
  const auto proto = GetParam() == 1 ? dynamixel::Protocol::V1 : dynamixel::Protocol::V2;
  const bool v1 = proto == dynamixel::Protocol::V1;
  const auto& tab = dynamixel::mx64Table(proto);
  ServoModel servo(0.0, hostNow());
  Mx64Options opt;
  opt.protocol = proto;
  Mx64Emulator emu(servo, opt);
  emu.start();
  Port port(emu.devicePath(), proto);
  ASSERT_TRUE(port.ok());
  // Sync write of torque enable to IDs 1 and 7 (7 is not there): no status packet.
  std::vector<std::uint8_t> p = port.addr(tab.torque_enable.addr);
  dynamixel::putLE(p, 1, v1 ? 1 : 2);
  p.insert(p.end(), {1, 1, 7, 1});
  EXPECT_FALSE(port.transact(dynamixel::inst::kSyncWrite, p, 0.1).has_value());
  EXPECT_EQ(emu.reg(tab.torque_enable), 1u);
  // Bulk read of the present position.
  std::vector<std::uint8_t> b;
  if (v1) {
    b = {0x00, tab.present_position.size, 1, static_cast<std::uint8_t>(tab.present_position.addr)};
  } else {
    b = {1};
    dynamixel::putLE(b, tab.present_position.addr, 2);
    dynamixel::putLE(b, tab.present_position.size, 2);
  }
  auto s = port.transact(dynamixel::inst::kBulkRead, b);
  ASSERT_TRUE(s.has_value());
  ASSERT_EQ(s->params.size(), tab.present_position.size);
  EXPECT_EQ(dynamixel::getLE(s->params.data(), tab.present_position.size), 2048u);
  if (!v1) {  // sync read of present position and velocity
    std::vector<std::uint8_t> r;
    dynamixel::putLE(r, 128, 2);
    dynamixel::putLE(r, 8, 2);
    r.push_back(1);
    auto sr = port.transact(dynamixel::inst::kSyncRead, r);
    ASSERT_TRUE(sr.has_value());
    EXPECT_EQ(sr->params.size(), 8u);
  }
}
