// The SCIP 2.0 client against the emulated UTM-30LX-EW: time stamps against
// the emulator's truth while its clock drifts, ranges against the simulation,
// and every fault seen and survived.
#include <gtest/gtest.h>

#include <cmath>
#include <mutex>

#include "tilt_laser_perception/scip/client.hpp"
#include "tilt_laser_perception/sim/utm_emulator.hpp"
#include "sim_room.hpp"

using namespace tilt_laser_perception;

namespace {
using test::Room;

struct StampStats {
  double max_abs = 0, rms = 0;
  int n = 0;
};

StampStats measure(double drift_ppm, double seconds, double warmup) {
  Room room;
  sim::UtmOptions o;
  o.drift_ppm = drift_ppm;
  sim::UtmEmulator utm(room.source(), o);
  utm.start();
  scip::UtmClientOptions co;
  scip::UtmClient client(scip::makeTcpTransport("127.0.0.1", utm.port()), co);
  std::string err;
  EXPECT_TRUE(client.start(err)) << err;
  const double t_start = sim::hostNow();
  const double period_host = utm.scanStart(1) - utm.scanStart(0);
  StampStats s;
  double sum2 = 0;
  scip::UtmScan scan;
  while (sim::hostNow() - t_start < seconds) {
    const auto r = client.poll(scan, 0.1, err);
    EXPECT_NE(r, scip::UtmClient::Result::Error) << err;
    if (r != scip::UtmClient::Result::Scan) continue;
    const long k = std::lround((scan.stamp - utm.scanStart(0)) / period_host);
    const double e = (scan.stamp - utm.scanStart(k)) * 1e3;
    if (sim::hostNow() - t_start < warmup) continue;
    s.max_abs = std::max(s.max_abs, std::abs(e));
    sum2 += e * e;
    ++s.n;
  }
  s.rms = s.n ? std::sqrt(sum2 / s.n) : 0;
  std::printf("drift %+.0f ppm: %d scans after %.0f s, stamp error max %.3f ms, rms %.3f ms, clock drift %.1f ppm\n",
              drift_ppm, s.n, warmup, s.max_abs, s.rms, client.clock().driftPpm());
  EXPECT_NEAR(client.clock().driftPpm(), drift_ppm, 100.0);
  return s;
}
}  // namespace

TEST(UtmClient, StampsFollowTheTrueTimeOfTheFirstBeamWhileTheClockDrifts) {
#ifdef TLP_SANITIZED
  GTEST_SKIP() << "stamp precision is not measured under a sanitizer: it slows the client several times";
#endif
  for (double drift : {1000.0, -1000.0}) {
    const StampStats s = measure(drift, 7.0, 3.0);
    EXPECT_GT(s.n, 140);
    EXPECT_LT(s.max_abs, 1.0);
    EXPECT_LT(s.rms, 0.3);  // 0.03-0.07 ms on an idle machine; the rostests' limit, for a busy one (CI saw 0.26)
  }
}

TEST(UtmClient, ReadsTheSensorAndItsRanges) {
  Room room;
  sim::UtmEmulator utm(room.source());
  utm.start();
  scip::UtmClientOptions co;
  co.intensity = true;
  scip::UtmClient client(scip::makeTcpTransport("127.0.0.1", utm.port()), co);
  std::string err;
  ASSERT_TRUE(client.start(err)) << err;
  EXPECT_EQ(client.info().serial, "H1102345");
  EXPECT_EQ(client.info().ares, 1440);
  EXPECT_EQ(client.info().afrt, 540);
  scip::UtmScan scan;
  ASSERT_EQ(client.poll(scan, 1.0, err), scip::UtmClient::Result::Scan) << err;
  ASSERT_EQ(scan.ranges.size(), 1081u);
  EXPECT_EQ(scan.intensities.size(), 1081u);
  EXPECT_NEAR(scan.angle_min, -135.0 * M_PI / 180.0, 1e-6);
  EXPECT_NEAR(scan.angle_increment, 0.25 * M_PI / 180.0, 1e-7);
  EXPECT_NEAR(scan.time_increment, 0.025 / 1440, 1e-9);
  // The scan just decoded is the last one the emulator simulated: ranges within 1 mm (sent as millimetres).
  std::lock_guard<std::mutex> l(room.m);
  for (std::size_t i = 0; i < 1081; i += 10) EXPECT_NEAR(scan.ranges[i], room.last.ranges[i], 0.0006) << i;
}

TEST(UtmClient, StreamsMultiEchoScansAndFallsBackWithoutTheEw) {
  // split_room from a fixed sensor: its depth jumps give mixed pixels with
  // the far surface as a second echo (the simulator's mixed-pixel model).
  for (const bool ew : {true, false}) {
    Room room;
    sim::UtmOptions uo;
    uo.multi_echo = ew;
    sim::UtmEmulator utm(room.source(), uo);
    utm.start();
    scip::UtmClientOptions co;
    co.multi_echo = true;
    co.intensity = true;
    scip::UtmClient client(scip::makeTcpTransport("127.0.0.1", utm.port()), co);
    std::string err;
    ASSERT_TRUE(client.start(err)) << err;
    EXPECT_EQ(client.multiEcho(), ew);
    if (!ew) {
      EXPECT_NE(client.lastWarning().find("no multi-echo"), std::string::npos) << client.lastWarning();
    }
    int second = 0, scans = 0;
    for (int k = 0; k < 20; ++k) {
      scip::UtmScan scan;
      ASSERT_EQ(client.poll(scan, 1.0, err), scip::UtmClient::Result::Scan) << err;
      ASSERT_EQ(scan.ranges.size(), 1081u);
      ++scans;
      if (!ew) {
        EXPECT_TRUE(scan.echo_count.empty());
        continue;
      }
      ASSERT_EQ(scan.echo_count.size(), 1081u);
      ASSERT_EQ(scan.echo_ranges.size(), 1081u * scip::kMaxEchoes);
      for (std::size_t i = 0; i < 1081; ++i) {
        const float* r = &scan.echo_ranges[i * scip::kMaxEchoes];
        ASSERT_GE(scan.echo_count[i], 1);
        EXPECT_TRUE(r[0] == scan.ranges[i] || (std::isinf(r[0]) && std::isinf(scan.ranges[i]))) << i;
        if (scan.echo_count[i] < 2) {
          EXPECT_TRUE(std::isnan(r[1])) << i;
          continue;
        }
        ++second;
        EXPECT_GT(r[1], r[0] + 0.29f) << i;
        EXPECT_FALSE(std::isnan(scan.echo_intensities[i * scip::kMaxEchoes + 1])) << i;
      }
    }
    EXPECT_EQ(scans, 20);
    if (ew) {
      EXPECT_GT(second, 20) << "second echoes in 20 scans";
    }
  }
}

TEST(UtmClient, CountsBadScansAndReportsDeadConnections) {
  Room room;
  sim::UtmOptions o;
  o.reboot_time = 0.3;
  sim::UtmEmulator utm(room.source(), o);
  utm.start();
  scip::UtmClientOptions co;
  co.watchdog = 0.5;
  co.ii_period = 0.0;
  scip::UtmClient client(scip::makeTcpTransport("127.0.0.1", utm.port()), co);
  std::string err;
  ASSERT_TRUE(client.start(err)) << err;
  scip::UtmScan scan;
  const auto scans = [&](int n) {
    int got = 0;
    for (int i = 0; i < 4 * n && got < n; ++i)
      if (client.poll(scan, 0.1, err) == scip::UtmClient::Result::Scan) ++got;
    return got;
  };
  ASSERT_EQ(scans(3), 3);
  utm.corruptNextScans(2);
  utm.truncateNextScans(1);
  EXPECT_EQ(scans(5), 5);  // good scans keep coming
  EXPECT_EQ(client.counters().checksum_errors, 2u);
  EXPECT_EQ(client.counters().truncated, 1u);

  utm.setSilent(true);
  scip::UtmClient::Result r = scip::UtmClient::Result::Idle;
  for (int i = 0; i < 20 && r != scip::UtmClient::Result::Error; ++i) r = client.poll(scan, 0.1, err);
  EXPECT_EQ(r, scip::UtmClient::Result::Error);
  EXPECT_NE(err.find("watchdog"), std::string::npos) << err;
  EXPECT_EQ(client.counters().timeouts, 1u);
  utm.setSilent(false);

  ASSERT_TRUE(client.start(err)) << err;  // reconnect
  ASSERT_EQ(scans(2), 2);
  utm.dropConnection();
  r = scip::UtmClient::Result::Idle;
  for (int i = 0; i < 20 && r != scip::UtmClient::Result::Error; ++i) r = client.poll(scan, 0.1, err);
  EXPECT_EQ(r, scip::UtmClient::Result::Error);

  ASSERT_TRUE(client.start(err)) << err;
  utm.reboot();
  r = scip::UtmClient::Result::Idle;
  for (int i = 0; i < 20 && r != scip::UtmClient::Result::Error; ++i) r = client.poll(scan, 0.1, err);
  EXPECT_EQ(r, scip::UtmClient::Result::Error);
  bool back = false;
  for (int i = 0; i < 20 && !back; ++i) {
    back = client.start(err);
    if (!back) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(back) << err;
  EXPECT_EQ(scans(3), 3);
  EXPECT_GE(client.counters().connects, 4u);
}

TEST(UtmClient, ConnectionRefusedIsAnErrorNotAHang) {
  scip::UtmClientOptions co;
  co.connect_timeout = 0.5;
  scip::UtmClient client(scip::makeTcpTransport("127.0.0.1", 1), co);
  std::string err;
  EXPECT_FALSE(client.start(err));
  EXPECT_FALSE(err.empty());
  EXPECT_EQ(client.counters().connect_failures, 1u);
}
