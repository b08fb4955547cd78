// The scan clock on a synthetic sensor: drifting clock, 24-bit wrap, a motor
// whose revolution is not a whole number of milliseconds, arrival jitter.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tilt_laser_perception/scip/time_sync.hpp"

using namespace tilt_laser_perception::scip;

namespace {
struct FakeSensor {
  double drift_ppm, clock0_ms, host0, motor_ppm;
  double sensorMs(double host) const { return clock0_ms + (host - host0) * 1000.0 * (1.0 + drift_ppm * 1e-6); }
  double hostOf(double sensor_ms) const { return host0 + (sensor_ms - clock0_ms) / (1000.0 * (1.0 + drift_ppm * 1e-6)); }
  std::uint32_t stamp(double host) const {
    return static_cast<std::uint32_t>(std::floor(sensorMs(host))) & 0xFFFFFF;
  }
};

struct Result {
  double max_abs = 0.0, rms = 0.0;
  int n = 0;
};

Result run(double drift_ppm, double clock0_ms, double motor_ppm, double jitter_ms, unsigned seed, ScanClock& clock,
           double seconds = 12.0, double warmup = 3.0, double delay_from = -1.0, double delay_to = -1.0) {
  FakeSensor s{drift_ppm, clock0_ms, 1000.0, motor_ppm};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::exponential_distribution<double> jitter(1.0 / (jitter_ms * 1e-3));
  // TM calibration: 20 round trips of 0.2 ms at random moments.
  std::vector<TmSample> tm;
  double h = 1000.0;
  for (int i = 0; i < 20; ++i) {
    h += 0.002 + 0.001 * uni(rng);
    const double rtt = 0.0002;
    const double reply = h + rtt * uni(rng);
    tm.push_back({h, h + rtt, s.stamp(reply)});
  }
  EXPECT_TRUE(clock.calibrate(tm));
  // Scans: step 0 of revolution k at sensor time phase0 + k * 25 ms * (1 + motor_ppm).
  const double phase0 = s.sensorMs(h + 0.1) + 0.37;
  Result r;
  double sum2 = 0.0, next_ii = h + 0.2;
  for (int k = 0;; ++k) {
    const double sigma = phase0 + k * 25.0 * (1.0 + motor_ppm * 1e-6);
    const double t0 = s.hostOf(sigma);
    if (t0 > h + seconds) break;
    double arrival = t0 + 0.025 + 0.0003 + jitter(rng);
    // Replies held 300 ms (the emulator's delay fault): scans come in bursts
    // every 0.33 s, clock readings take 300 ms.
    const bool delayed = arrival - h > delay_from && arrival - h < delay_to;
    if (delayed) arrival = h + delay_from + 0.33 * std::ceil((arrival - h - delay_from) / 0.33);
    if (arrival > next_ii) {  // an II request at 5 Hz, sent at a random moment
      const double send = arrival + 0.02 * uni(rng);
      const double reply = send + 0.0002 * uni(rng);
      clock.addClockSample({send, send + (delayed ? 0.3 : 0.0003), s.stamp(reply)});
      next_ii += 0.2;
    }
    const double stamped = clock.stamp(static_cast<std::uint32_t>(std::floor(sigma)) & 0xFFFFFF, arrival);
    if (t0 - h < warmup) continue;
    const double err = (stamped - t0) * 1e3;
    r.max_abs = std::max(r.max_abs, std::abs(err));
    sum2 += err * err;
    ++r.n;
  }
  r.rms = std::sqrt(sum2 / r.n);
  return r;
}
}  // namespace

TEST(ScanClock, StampsWithinAMillisecondWhileTheClockDrifts) {
  for (double drift : {-1000.0, 0.0, 1000.0}) {
    ScanClock clock;
    const Result r = run(drift, 123456.7, 400.0, 0.3, 1, clock);
    EXPECT_LT(r.max_abs, 1.0) << drift;
    EXPECT_LT(r.rms, 0.2) << drift;
    EXPECT_NEAR(clock.driftPpm(), drift, 30.0);
    EXPECT_NEAR(clock.latency(), 0.0256, 0.0005);
    std::printf("drift %+.0f ppm: max %.3f ms, rms %.3f ms over %d scans\n", drift, r.max_abs, r.rms, r.n);
  }
}

TEST(ScanClock, DelayedRepliesAreSeenAndDoNotBendTheModel) {
  // Issue 20: with replies delayed 300 ms the stamps were 27 ms off at the
  // median and the drift read -121 ppm, while nothing said so. Delayed for
  // 20 s of a 40 s stream (the 30 s arrival window full of bursts).
  ScanClock clock;
  const Result r = run(200.0, 777777.0, 400.0, 0.3, 4, clock, 40.0, 3.0, 8.0, 28.0);
  std::printf("delayed 20 s: max %.3f ms, rms %.3f ms, drift %.1f ppm, %lu scans late, %lu clock readings left out\n",
              r.max_abs, r.rms, clock.driftPpm(), clock.delayedScans(), clock.rejectedSamples());
  EXPECT_GT(clock.delayedScans(), 400u);  // of 800 in the delay (those held 0.1-0.33 s)
  EXPECT_GT(clock.rejectedSamples(), 90u);
  EXPECT_NEAR(clock.lastRejectedRtt(), 0.3, 1e-6);
  EXPECT_EQ(clock.impossibleStamps(), 0u);
  EXPECT_LT(r.max_abs, 1.0);
  EXPECT_NEAR(clock.driftPpm(), 200.0, 30.0);
}

TEST(ScanClock, HandlesThe24BitWrap) {
  ScanClock clock;
  // 16777216 ms wrap 4 s into the stream.
  const Result r = run(500.0, 16777216.0 - 4200.0, 400.0, 0.3, 2, clock);
  EXPECT_EQ(clock.jumps(), 0u);
  EXPECT_LT(r.max_abs, 1.0);
  EXPECT_LT(r.rms, 0.2);
}

TEST(ScanClock, ALockedMotorStillStaysWithinAMillisecond) {
  // A revolution of exactly 25 ms leaves the phase within the millisecond unseen: about 0.5 ms off at most.
  ScanClock clock;
  const Result r = run(-300.0, 5000.2, 0.0, 0.3, 3, clock);
  EXPECT_LT(r.max_abs, 1.0);
}

TEST(ScanClock, AJumpBackwardsResetsTheModel) {
  ScanClock clock;
  clock.stamp(100000, 10.0);
  clock.stamp(100025, 10.025);
  clock.stamp(100050, 10.050);
  EXPECT_EQ(clock.missed(), 0u);
  clock.stamp(100100, 10.100);  // one revolution missed
  EXPECT_EQ(clock.missed(), 1u);
  clock.stamp(12, 10.125);  // rebooted
  EXPECT_EQ(clock.jumps(), 1u);
  EXPECT_FALSE(clock.calibrated());
  // Without clock samples a scan is stamped at its arrival minus the nominal latency.
  EXPECT_NEAR(clock.stamp(37, 10.150), 10.150 - 0.025, 1e-9);
  // A clock sample with a long round trip is left out.
  EXPECT_FALSE(clock.addClockSample({20.0, 20.010, 500}));
  EXPECT_EQ(clock.rejectedSamples(), 1u);
}
