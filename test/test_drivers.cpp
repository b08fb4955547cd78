// The driver loops against the emulated head: joint states at their rate
// following the true tilt, sweeps, and recovery from every servo and laser fault.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>
#include <unistd.h>

#include "tilt_laser_perception/driver/laser_driver.hpp"
#include "tilt_laser_perception/driver/servo_driver.hpp"
#include "tilt_laser_perception/sim/mx64_emulator.hpp"
#include "tilt_laser_perception/sim/utm_emulator.hpp"
#include "sim_room.hpp"

using namespace tilt_laser_perception;
using namespace std::chrono_literals;

namespace {
struct Recorder {
  std::mutex m;
  std::vector<driver::JointSample> joints;
  std::vector<std::pair<core::Sweep, bool>> sweeps;
  std::vector<std::string> logs;
  driver::ServoDriver::JointCallback joint() {
    return [this](const driver::JointSample& s) {
      std::lock_guard<std::mutex> l(m);
      joints.push_back(s);
    };
  }
  driver::ServoDriver::SweepCallback sweep() {
    return [this](const core::Sweep& s, bool complete) {
      std::lock_guard<std::mutex> l(m);
      sweeps.emplace_back(s, complete);
    };
  }
  driver::ServoDriver::LogCallback log() {
    return [this](driver::ServoDriver::Level, const std::string& msg) {
      std::lock_guard<std::mutex> l(m);
      logs.push_back(msg);
    };
  }
  std::size_t count() {
    std::lock_guard<std::mutex> l(m);
    return joints.size();
  }
};

driver::ServoDriverOptions options(dynamixel::Protocol p, const std::string& device) {
  driver::ServoDriverOptions o;
  o.device = device;
  o.protocol = p;
  o.rate = 200.0;
  o.profile.min_angle = 0.2;
  o.profile.max_angle = 0.7;
  o.profile.speed = 1.0;
  o.backoff_min = 0.05;
  o.backoff_max = 0.2;
  o.recover_after = 0.3;
  return o;
}
}  // namespace

// The test's protocol (the parameter: 1 or 2), and an emulated MX-64 on it
// (on a stable link path when asked), started.
class ServoDriverTest : public ::testing::TestWithParam<int> {
 protected:
  dynamixel::Protocol proto() const { return GetParam() == 1 ? dynamixel::Protocol::V1 : dynamixel::Protocol::V2; }
  struct EmulatedServo {
    EmulatedServo(dynamixel::Protocol p, const std::string& link) : emu(servo, mx64Options(p, link)) { emu.start(); }
    static sim::Mx64Options mx64Options(dynamixel::Protocol p, const std::string& link) {
      sim::Mx64Options mo;
      mo.protocol = p;
      mo.link_path = link;
      return mo;
    }
    sim::ServoModel servo{0.3, sim::hostNow()};
    sim::Mx64Emulator emu;
  };
};

TEST_P(ServoDriverTest, JointStatesFollowTheTrueTiltAt200Hz) {
  EmulatedServo es(proto(), "");
  sim::ServoModel& servo = es.servo;
  Recorder rec;
  driver::ServoDriver drv(options(proto(), es.emu.devicePath()), rec.joint(), rec.sweep(), rec.log());
  const double t0 = sim::hostNow();
  drv.start();
  std::this_thread::sleep_for(2500ms);
  drv.stop();
  std::lock_guard<std::mutex> l(rec.m);
  ASSERT_GT(rec.joints.size(), 100u);
  const double span = rec.joints.back().stamp - rec.joints.front().stamp;
  const double rate = (rec.joints.size() - 1) / span;
  EXPECT_GE(rate, 150.0);
  double max_err = 0.0, max_v = 0.0;
  for (const auto& j : rec.joints) {
    max_err = std::max(max_err, std::abs(j.position - servo.positionAt(j.stamp)));
    max_v = std::max(max_v, std::abs(j.velocity));
  }
  std::printf("protocol %d: %zu joint states at %.0f Hz, max error against the true tilt %.3f deg\n",
              GetParam(), rec.joints.size(), rate, max_err * 180 / M_PI);
  // 4096 steps a turn: the position is quantised to 0.088 deg; the midpoint stamp adds little.
  EXPECT_LT(max_err * 180.0 / M_PI, 0.2);
  EXPECT_NEAR(max_v, 1.0, 0.1);
  // 0.5 rad at 1 rad/s: a sweep about every 0.55 s after reaching the first end.
  int complete = 0;
  for (const auto& s : rec.sweeps) complete += s.second;
  EXPECT_GE(complete, 2);
  (void)t0;
}

// A spinning head: the servo in wheel mode (1.0: CW and CCW Angle Limit 0)
// or velocity control (2.0: Operating Mode 1) at the profile's speed, the
// joint angle counted on past each turn (1.0 reports one turn), a sweep each
// half turn. A servo left in wheel mode by it and started again nodding is
// put back in joint / position mode.
TEST_P(ServoDriverTest, SpinsAtTheProfilesSpeedAndCountsTheTurns) {
  EmulatedServo es(proto(), "");
  sim::ServoModel& servo = es.servo;
  Recorder rec;
  driver::ServoDriverOptions o = options(proto(), es.emu.devicePath());
  o.profile.mode = core::TiltProfileParams::Mode::Spin;
  o.profile.speed = 4.0;  // rad/s: more than a turn in the test's time
  driver::ServoDriver drv(o, rec.joint(), rec.sweep(), rec.log());
  drv.start();
  std::this_thread::sleep_for(3000ms);
  drv.stop();
  {
    std::lock_guard<std::mutex> l(rec.m);
    ASSERT_GT(rec.joints.size(), 300u);
    // Against the true angle turned through (the model's is unwrapped): within
    // the encoder's step, less the start's offset of whole turns (none here).
    double max_err = 0.0;
    for (const auto& j : rec.joints) max_err = std::max(max_err, std::abs(j.position - servo.positionAt(j.stamp)));
    const double turned = rec.joints.back().position - rec.joints.front().position;
    std::printf("protocol %d spinning: turned %.2f rad, max error %.3f deg, %zu sweeps\n", GetParam(), turned,
                max_err * 180 / M_PI, rec.sweeps.size());
    // Within an encoder step plus what the speed makes of a stamp's allowed
    // uncertainty (reads delayed more are not published): 0.32 deg at 4 rad/s
    // (a sanitizer build's slow reads reached 0.21).
    EXPECT_LT(max_err, dynamixel::kRadPerStep + o.profile.speed * o.max_stamp_uncertainty);
    EXPECT_GT(turned, 2.0 * M_PI + 1.0);  // past a turn: counted, not wrapped
    EXPECT_NEAR(rec.joints.back().velocity, 4.0, 0.1);
    // A sweep each half turn, cut where the angle passes a multiple of pi.
    ASSERT_GE(rec.sweeps.size(), 2u);
    for (const auto& sw : rec.sweeps) {
      EXPECT_TRUE(sw.second);
      EXPECT_NEAR(std::remainder(sw.first.end_angle, M_PI), 0.0, 1e-9);
      EXPECT_NEAR(sw.first.end_angle - sw.first.start_angle, M_PI, 1e-9);
    }
  }
  // Nodding again on the same servo: back in joint / position mode, within the tilt range.
  Recorder nod;
  driver::ServoDriver again(options(proto(), es.emu.devicePath()), nod.joint(), nod.sweep(), nod.log());
  again.start();
  std::this_thread::sleep_for(2500ms);
  again.stop();
  std::lock_guard<std::mutex> l(nod.m);
  ASSERT_GT(nod.joints.size(), 100u);
  const double last = servo.positionAt(nod.joints.back().stamp);
  EXPECT_NEAR(std::remainder(last - 0.45, 2.0 * M_PI), 0.0, 0.3);  // within the 0.2..0.7 range (modulo the turns made)
}

TEST_P(ServoDriverTest, RecoversFromEveryServoFault) {
  const std::string link =
      ::testing::TempDir() + "/tlp_drv_" + std::to_string(GetParam()) + "_" + std::to_string(::getpid());
  EmulatedServo es(proto(), link);
  sim::Mx64Emulator& emu = es.emu;
  Recorder rec;
  driver::ServoDriver drv(options(proto(), link), rec.joint(), rec.sweep(), rec.log());
  drv.start();
  const auto flowing = [&] {
    const std::size_t n = rec.count();
    std::this_thread::sleep_for(200ms);
    return rec.count() > n + 10;
  };
  std::this_thread::sleep_for(300ms);
  ASSERT_TRUE(flowing());

  emu.corruptNextReplies(2);
  emu.garbageBeforeNextReplies(3);
  std::this_thread::sleep_for(100ms);
  EXPECT_TRUE(flowing());
  auto st = drv.status();
  EXPECT_GE(st.bus.bad_packets, 1u);
  EXPECT_GE(st.bus.garbage_bytes, 3u);

  // Issue 20: 20 bad checksums in a row cost 5.5 s of joint states (the port
  // reopened, pinging into the corrupt replies, backing off to 2 s). The line
  // is alive: no reopening, joint states again within 0.3 s.
  const unsigned long reopens = drv.status().reopens;
  emu.corruptNextReplies(20);
  std::this_thread::sleep_for(300ms);
  EXPECT_TRUE(flowing());
  EXPECT_EQ(drv.status().reopens, reopens);
  EXPECT_GE(drv.status().bus.bad_packets, 20u);

  emu.setNoReply(true);  // silent servo: reopened after 5 failed reads
  std::this_thread::sleep_for(400ms);
  EXPECT_GE(drv.status().reopens, 1u);
  emu.setNoReply(false);
  std::this_thread::sleep_for(400ms);
  EXPECT_TRUE(flowing());

  emu.vanish();  // unplugged
  std::this_thread::sleep_for(300ms);
  EXPECT_FALSE(drv.status().connected);
  emu.reappear();
  std::this_thread::sleep_for(600ms);
  EXPECT_TRUE(drv.status().connected);
  EXPECT_TRUE(flowing());

  emu.setHardwareError(0x20);  // overload: the servo shuts down
  std::this_thread::sleep_for(200ms);
  st = drv.status();
  EXPECT_EQ(st.hardware_error_names, "overload");
  EXPECT_GE(st.hardware_error_events, 1u);
  EXPECT_TRUE(flowing());  // joint states go on while it is in error
  if (proto() == dynamixel::Protocol::V2) {
    // The driver reboots it after recover_after and carries on.
    std::this_thread::sleep_for(800ms);
    EXPECT_EQ(drv.status().hardware_error, 0u);
  } else {
    emu.setHardwareError(0);
    std::this_thread::sleep_for(800ms);
    EXPECT_EQ(drv.status().hardware_error, 0u);
  }
  const auto before = rec.count();
  std::this_thread::sleep_for(300ms);
  EXPECT_GT(rec.count(), before + 30);
  const auto t_stop = std::chrono::steady_clock::now();
  drv.stop();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t_stop).count(), 2.0);
  std::lock_guard<std::mutex> l(rec.m);
  int aborted = 0;
  for (const auto& s : rec.sweeps) aborted += !s.second;
  EXPECT_GE(aborted, 1);  // the faults dropped sweeps in progress
}

TEST_P(ServoDriverTest, SwitchesTheTorqueOnAgainWhenItWentOffWithNoError) {
  // An overload that clears itself before the driver's recovery (as a servo
  // whose power was cycled): no error left, but the torque is off and the head
  // stands still. Found by the soak (scripts/bench/soak.py): the sweeps stopped.
  EmulatedServo es(proto(), "");
  sim::Mx64Emulator& emu = es.emu;
  Recorder rec;
  auto o = options(proto(), emu.devicePath());
  o.recover_after = 5.0;  // the driver's own recovery stays out of it
  driver::ServoDriver drv(o, rec.joint(), rec.sweep(), rec.log());
  drv.start();
  std::this_thread::sleep_for(500ms);
  emu.setHardwareError(0x20);
  std::this_thread::sleep_for(100ms);
  emu.setHardwareError(0);
  std::this_thread::sleep_for(1500ms);  // the health check runs once a second
  EXPECT_EQ(drv.status().torque_restores, 1u);
  // moving again: over 0.4 s the tilt changes by more than 0.2 rad (1 rad/s)
  const auto position = [&] {
    std::lock_guard<std::mutex> l(rec.m);
    return rec.joints.back().position;
  };
  std::this_thread::sleep_for(200ms);
  double lo = 10, hi = -10;
  for (int i = 0; i < 40; ++i) {
    lo = std::min(lo, position());
    hi = std::max(hi, position());
    std::this_thread::sleep_for(10ms);
  }
  EXPECT_GT(hi - lo, 0.2);
  drv.stop();
}

TEST_P(ServoDriverTest, ReadsTheServosOwnLimitsAndSweepsOnlyWithinThem) {
  // The tilt profile asks for 0.2..0.7 rad. With the e-manual's defaults the
  // servo takes the whole turn; with its limits set to 0.3..0.5 rad (1.0:
  // CW/CCW Angle Limit; 2.0: Min/Max Position Limit) the driver reads them at
  // start, warns, and sweeps within them.
  for (const bool narrow : {false, true}) {
    EmulatedServo es(proto(), "");
    const auto& tab = dynamixel::mx64Table(proto());
    const bool v1 = proto() == dynamixel::Protocol::V1;
    if (narrow) {
      dynamixel::PortHandler port;
      std::string err;
      ASSERT_TRUE(port.open(es.emu.devicePath(), 57600, true, err)) << err;
      dynamixel::Bus bus(port, proto());
      std::uint8_t e = 0;
      const auto lo = static_cast<std::uint32_t>(dynamixel::radToPosition(0.3));
      const auto hi = static_cast<std::uint32_t>(dynamixel::radToPosition(0.5));
      ASSERT_EQ(bus.writeReg(1, v1 ? tab.cw_angle_limit : tab.min_position_limit, lo, &e), dynamixel::TxResult::Ok);
      ASSERT_EQ(e, 0);
      ASSERT_EQ(bus.writeReg(1, v1 ? tab.ccw_angle_limit : tab.max_position_limit, hi, &e), dynamixel::TxResult::Ok);
      ASSERT_EQ(e, 0);
    }
    Recorder rec;
    driver::ServoDriver drv(options(proto(), es.emu.devicePath()), rec.joint(), rec.sweep(), rec.log());
    drv.start();
    std::this_thread::sleep_for(2500ms);
    const driver::ServoStatus st = drv.status();
    drv.stop();
    std::lock_guard<std::mutex> l(rec.m);
    ASSERT_GT(rec.joints.size(), 100u);
    double lo = 10, hi = -10;
    for (const auto& j : rec.joints) {
      lo = std::min(lo, j.position);
      hi = std::max(hi, j.position);
    }
    int complete = 0;
    for (const auto& sw : rec.sweeps) complete += sw.second;
    bool warned = false;
    for (const auto& m : rec.logs) warned = warned || m.find("beyond the servo's own limits") != std::string::npos;
    std::printf("protocol %d, %s limits: %.3f..%.3f rad read, tilt %.3f..%.3f rad, %d sweeps\n", GetParam(),
                narrow ? "narrow" : "default", st.limit_min, st.limit_max, lo, hi, complete);
    EXPECT_EQ(st.refused_writes, 0u) << st.last_refusal;
    EXPECT_GE(complete, 2);
    if (!narrow) {
      EXPECT_NEAR(st.limit_min, dynamixel::positionToRad(0), 1e-9);
      EXPECT_NEAR(st.limit_max, dynamixel::positionToRad(4095), 1e-9);
      EXPECT_FALSE(warned);
      EXPECT_NEAR(lo, 0.2, 0.03);
      EXPECT_NEAR(hi, 0.7, 0.03);
    } else {
      EXPECT_NEAR(st.limit_min, 0.3, dynamixel::kRadPerStep);
      EXPECT_NEAR(st.limit_max, 0.5, dynamixel::kRadPerStep);
      EXPECT_TRUE(warned);
      EXPECT_GE(lo, 0.3 - 0.005);
      EXPECT_LE(hi, 0.5 + 0.005);
      EXPECT_LT(lo, 0.32);  // and it sweeps the whole of what is left
      EXPECT_GT(hi, 0.48);
    }
  }
}

TEST(ServoDriver, StartsOnAServoWhoseTorqueIsOnAndReportsWhatTheModelLacks) {
  // 2.0: the return delay is EEPROM, refused with the torque on (a driver
  // restarted under a running head): torque off, write, torque on.
  {
    sim::ServoModel servo{0.3, sim::hostNow()};
    sim::Mx64Options mo;
    sim::Mx64Emulator emu(servo, mo);
    emu.start();
    {
      dynamixel::PortHandler port;
      std::string err;
      ASSERT_TRUE(port.open(emu.devicePath(), 57600, true, err)) << err;
      dynamixel::Bus bus(port, dynamixel::Protocol::V2);
      std::uint8_t e = 0;
      ASSERT_EQ(bus.writeReg(1, dynamixel::mx64Table(dynamixel::Protocol::V2).torque_enable, 1, &e),
                dynamixel::TxResult::Ok);
    }
    Recorder rec;
    driver::ServoDriver drv(options(dynamixel::Protocol::V2, emu.devicePath()), rec.joint(), rec.sweep(), rec.log());
    drv.start();
    std::this_thread::sleep_for(800ms);
    const driver::ServoStatus st = drv.status();
    drv.stop();
    EXPECT_TRUE(st.connected);
    EXPECT_EQ(st.refused_writes, 0u) << st.last_refusal;
    EXPECT_EQ(emu.reg(dynamixel::mx64Table(dynamixel::Protocol::V2).return_delay), 0u);
    EXPECT_GT(rec.count(), 50u);
    EXPECT_GT(emu.stats().error_replies.load(), 0u);  // the refusal did happen
  }
  // A servo without Profile Acceleration (108): an access error, reported
  // with the model number and the address; the driver does not start it.
  {
    sim::ServoModel servo{0.3, sim::hostNow()};
    sim::Mx64Options mo;
    mo.undefined_addresses = {108, 109, 110, 111};
    sim::Mx64Emulator emu(servo, mo);
    emu.start();
    Recorder rec;
    driver::ServoDriver drv(options(dynamixel::Protocol::V2, emu.devicePath()), rec.joint(), rec.sweep(), rec.log());
    drv.start();
    std::this_thread::sleep_for(500ms);
    const driver::ServoStatus st = drv.status();
    drv.stop();
    EXPECT_FALSE(st.connected);
    EXPECT_GE(st.refused_writes, 1u);
    EXPECT_NE(st.last_refusal.find("servo model 311"), std::string::npos) << st.last_refusal;
    EXPECT_NE(st.last_refusal.find("address 108"), std::string::npos) << st.last_refusal;
    EXPECT_NE(st.last_refusal.find("access error"), std::string::npos) << st.last_refusal;
    EXPECT_EQ(rec.count(), 0u);
  }
}

INSTANTIATE_TEST_SUITE_P(Protocols, ServoDriverTest, ::testing::Values(1, 2));

TEST(LaserDriver, ReconnectsAfterDropsAndReboots) {
  test::Room room;
  sim::UtmOptions uo;
  uo.reboot_time = 0.3;
  sim::UtmEmulator utm(room.source(), uo);
  utm.start();
  driver::LaserDriverOptions lo;
  lo.host = "127.0.0.1";
  lo.port = utm.port();
  lo.backoff_min = 0.05;
  lo.client.watchdog = 0.5;
  std::atomic<int> scans{0};
  driver::LaserDriver drv(lo, [&](const scip::UtmScan& s) { scans += s.ranges.size() == 1081; }, nullptr);
  drv.start();
  std::this_thread::sleep_for(1500ms);
  EXPECT_NEAR(drv.status().scan_rate, 40.0, 3.0);
  const auto flowing = [&] {
    const int n = scans;
    std::this_thread::sleep_for(300ms);
    return scans > n + 5;
  };
  EXPECT_TRUE(flowing());
  utm.dropConnection();
  std::this_thread::sleep_for(400ms);
  EXPECT_TRUE(flowing());
  utm.setSilent(true);
  std::this_thread::sleep_for(800ms);
  utm.setSilent(false);
  std::this_thread::sleep_for(800ms);
  EXPECT_TRUE(flowing());
  utm.reboot();
  std::this_thread::sleep_for(1500ms);
  EXPECT_TRUE(flowing());
  const auto st = drv.status();
  EXPECT_GE(st.reconnects, 3u);
  EXPECT_GE(st.counters.timeouts, 1u);
  EXPECT_EQ(st.sensor_restarts, 1u);  // the reboot only: a dropped connection keeps the sensor's clock (found by the soak)
  const auto t_stop = std::chrono::steady_clock::now();
  drv.stop();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t_stop).count(), 2.0);
}

TEST(DynamixelBus, SyncAndBulkInstructionsOnTheEmulatedServo) {
  for (auto proto : {dynamixel::Protocol::V1, dynamixel::Protocol::V2}) {
    const auto& tab = dynamixel::mx64Table(proto);
    sim::ServoModel servo(0.25, sim::hostNow());
    sim::Mx64Options mo;
    mo.protocol = proto;
    sim::Mx64Emulator emu(servo, mo);
    emu.start();
    dynamixel::PortHandler port;
    std::string err;
    ASSERT_TRUE(port.open(emu.devicePath(), 57600, true, err)) << err;  // the servo's Baud Rate (initial)
    dynamixel::Bus bus(port, proto);
    std::uint16_t model = 0;
    std::uint8_t e = 0;
    ASSERT_EQ(bus.ping(1, &model, &e), dynamixel::TxResult::Ok);
    EXPECT_EQ(model, tab.model);
    // Sync write of the LED to servos 1 and 9 (only 1 is there).
    ASSERT_EQ(bus.syncWrite(tab.led, {{1, 1}, {9, 1}}), dynamixel::TxResult::Ok);
    std::this_thread::sleep_for(20ms);
    EXPECT_EQ(emu.reg(tab.led), 1u);
    std::vector<std::pair<std::uint8_t, std::uint32_t>> values;
    ASSERT_EQ(bus.bulkRead({{1, tab.present_position}}, values), dynamixel::TxResult::Ok);
    ASSERT_EQ(values.size(), 1u);
    EXPECT_EQ(values[0].second, static_cast<std::uint32_t>(dynamixel::radToPosition(0.25)));
    if (proto == dynamixel::Protocol::V2) {
      ASSERT_EQ(bus.syncRead(tab.present_position, {1}, values), dynamixel::TxResult::Ok);
      EXPECT_EQ(values.at(0).second, static_cast<std::uint32_t>(dynamixel::radToPosition(0.25)));
      // A servo that is not there: a timeout, with what did answer.
      EXPECT_EQ(bus.syncRead(tab.present_position, {1, 9}, values, 0.02), dynamixel::TxResult::Timeout);
      EXPECT_EQ(values.size(), 1u);
    } else {
      EXPECT_EQ(bus.syncRead(tab.present_position, {1}, values), dynamixel::TxResult::NotSent);
    }
  }
}
