/**
 * @file time_sync.hpp
 * @brief Maps the sensor's 24-bit millisecond time stamps onto host time, so
 *        that each scan is stamped at the host time of its first step. ROS-free.
 *
 * Two kinds of evidence are combined:
 *  1. Clock samples: a TM1 reply (before streaming) or an II reply (while
 *     streaming) carries the sensor's clock, read at some moment between the
 *     host's request and the reply's arrival. Each is a floor of the clock at
 *     a random phase of its millisecond, so a line fitted to (host time,
 *     stamp + 0.5 ms) over a window gives the clocks' offset and drift below
 *     the stamp's resolution. Samples whose round trip is longer than the
 *     shortest seen (plus a margin) are left out: the reply waited somewhere.
 *  2. The scans' stamps are floors of the clock at step 0 of each revolution.
 *     The revolution does not last a whole number of milliseconds, so the
 *     floors walk across the millisecond; a line fitted to (revolution index,
 *     stamp), narrowed to the offsets every floor allows, gives each scan's
 *     sensor time of step 0 below the millisecond.
 *  3. The arrivals follow the revolutions with a constant latency plus
 *     jitter that only ever delays: the lower envelope of (revolution,
 *     arrival) gives host seconds per revolution. With the sensor
 *     milliseconds per revolution from 2 this is the clocks' rate ratio,
 *     free of the stamps' quantisation; every clock sample then measures the
 *     same offset, and their mean is used.
 * Without clock samples the arrival times stand in (minus a nominal latency).
 * The 24-bit wrap (every 4.66 h) is unwrapped; a jump backwards (a reboot)
 * resets the model.
 */
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

namespace tilt_laser_perception {
namespace scip {

/// One clock reading (TM1 or II): host times [s] of the request and of the reply, and the sensor's time stamp [ms].
struct TmSample {
  double send = 0.0, recv = 0.0;
  std::uint32_t stamp = 0;
};

class ScanClock {
 public:
  struct Options {
    double period_ms = 25.0;        ///< nominal time between scans on the sensor clock [ms]
    double scan_window = 30.0;      ///< scans used for the phase fit [s]
    double clock_window = 60.0;     ///< clock samples used for offset and drift [s]
    double max_rtt = 0.005;         ///< clock samples with a longer round trip are left out [s]
    double rtt_margin = 0.0001;     ///< ... and those this much longer than the shortest seen [s]
    double default_latency = 0.025; ///< arrival minus step 0 assumed without clock samples [s]
    /// Arrival minus step 0 can be no less: the scan's last step is measured
    /// this long after step 0 (the UTM-30LX: 1080 of 1440 steps of 25 ms) [s].
    double min_latency = 0.01875;
    /// Arrival minus step 0 beyond this: the scan waited on its way (a
    /// delayed reply, a stalled link), far beyond the sensor's few ms [s].
    double max_latency = 0.1;
  };

  ScanClock() = default;
  explicit ScanClock(const Options& o) : opt_(o) {}

  /// Forgets everything (a new connection).
  void reset();
  /// Adds a clock reading; false if its round trip was too long to use.
  bool addClockSample(const TmSample& s);
  /// Replaces the clock readings with a TM1 series (at least 3 usable); false if too few.
  bool calibrate(const std::vector<TmSample>& samples);
  /// Host time [s] of step 0 of the scan with this stamp that arrived at `recv` [s].
  double stamp(std::uint32_t stamp24, double recv);

  bool calibrated() const { return clock_.size() >= 3; }
  /// Host minus sensor time at the last scan [s] (sensor time unwrapped from its start).
  double offset() const { return offset_; }
  /// Sensor clock rate error [ppm]: positive when the sensor's clock runs fast.
  double driftPpm() const { return drift_ppm_; }
  /// Arrival minus step 0 of the last scan [s].
  double latency() const { return latency_; }
  /// Sensor time of the last scan's step 0 [ms], below the stamp's resolution (unwrapped).
  double sensorTime() const { return sensor_time_; }
  /// Scans since reset, clock jumps seen (reboots), revolutions missed (gaps in the stamps).
  unsigned long scans() const { return scans_; }
  unsigned long jumps() const { return jumps_; }
  unsigned long missed() const { return missed_; }
  /// Clock samples in use, and those left out for their round trip.
  std::size_t clockSamples() const { return clock_.size(); }
  unsigned long rejectedSamples() const { return rejected_; }
  /// Round trip of the last clock reading left out [s] (0 when none).
  double lastRejectedRtt() const { return last_rejected_rtt_; }
  /// Scans that arrived later than max_latency after their step 0 by the
  /// model (left out of the arrival envelope, so a delay does not bend the
  /// rate), and scans the model put less than min_latency before their
  /// arrival (impossible: the model is off).
  unsigned long delayedScans() const { return delayed_; }
  unsigned long impossibleStamps() const { return impossible_; }

 private:
  struct ScanSample {
    double k;  // revolution index
    double s;  // stamp [ms], unwrapped, relative to origin_
    double r;  // arrival [s]
    bool delayed = false;  // arrived late: not part of the arrival envelope
  };
  struct ClockSample {
    double h;  // host time [s], relative to host0_
    double s;  // stamp + 0.5 [ms], unwrapped, relative to origin_
  };
  double unwrap(std::uint32_t stamp24);  // absolute ms, relative to origin_
  bool fitClock(double& c, double& g) const;  // s = c + g * h

  Options opt_;
  std::deque<ScanSample> scans_win_;
  std::deque<ClockSample> clock_;
  bool have_origin_ = false, have_scan_ = false;
  std::uint32_t last24_ = 0;
  double last_abs_ = 0.0, origin_ = 0.0, host0_ = 0.0;
  std::uint32_t last_scan24_ = 0;
  double last_k_ = 0.0;
  double min_rtt_ = 1e9;
  double host_per_rev_ = 0.025;  // host seconds per revolution (arrival envelope)
  double g_stream_ = 0.0;        // sensor ms per host s from the stream (0: not yet)
  double offset_ = 0.0, drift_ppm_ = 0.0, latency_ = 0.0, sensor_time_ = 0.0;
  unsigned long scans_ = 0, jumps_ = 0, missed_ = 0, rejected_ = 0, delayed_ = 0, impossible_ = 0;
  unsigned long delayed_in_window_ = 0;  // late scans in scans_win_ (no per-scan pass over the window)
  // The phase line (sensor ms of step 0 = a + p k) as last fitted over the
  // window, and the scans since: the fits pass over the whole window, so
  // they are made every kRefitEvery scans and in between the line is
  // extrapolated, as long as it stays within the floors the new stamps allow.
  static constexpr int kRefitEvery = 8;
  double fit_a_ = 0.0, fit_p_ = 0.0;
  int since_fit_ = -1;  // -1: no fit yet
  double last_rejected_rtt_ = 0.0;
};

}  // namespace scip
}  // namespace tilt_laser_perception
