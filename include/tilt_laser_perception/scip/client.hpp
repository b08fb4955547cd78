/**
 * @file client.hpp
 * @brief SCIP 2.0 client of a Hokuyo UTM-30LX(-EW): start-up (QT, RS, time
 *        synchronisation with TM, VV, PP, II, MD or ME), continuous scans with
 *        host time stamps at their first step, clock tracking with II while
 *        streaming, and a watchdog. ROS-free; not thread-safe (one thread drives it).
 */
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tilt_laser_perception/scip/codec.hpp"
#include "tilt_laser_perception/scip/time_sync.hpp"
#include "tilt_laser_perception/scip/transport.hpp"

namespace tilt_laser_perception {
namespace scip {

struct UtmClientOptions {
  double angle_min = -2.35619449;  ///< first angle to measure [rad] (clamped to the sensor's range)
  double angle_max = 2.35619449;   ///< last angle to measure [rad]
  int cluster = 1;                 ///< adjacent steps merged into one range (1..99)
  int skip = 0;                    ///< scans skipped between those sent (0..9)
  bool intensity = false;          ///< ME (ranges and intensities) instead of MD
  /// ND/NE (the -EW's multi-echo) instead of MD/ME; a sensor that refuses them
  /// is streamed with MD/ME and lastWarning() says so.
  bool multi_echo = false;
  double watchdog = 1.0;           ///< no scan for this long means the connection is dead [s]
  double connect_timeout = 2.0;    ///< [s]
  double command_timeout = 1.0;    ///< [s]
  int tm_samples = 20;             ///< TM1 round trips for the clock offset
  double ii_period = 0.1;          ///< II requests while streaming, to track the clock [s]; 0: none
  double time_offset = 0.0;        ///< added to every stamp [s] (cable or firmware delays)
};

/// What the sensor says about itself (VV, PP, II).
struct SensorInfo {
  std::string vendor, product, firmware, protocol, serial, model, status;
  int dmin = 23, dmax = 60000, ares = 1440, amin = 0, amax = 1080, afrt = 540, scan_rpm = 2400;
};

/// A decoded scan with its host time stamp, in LaserScan terms.
struct UtmScan {
  double stamp = 0.0;          ///< host time of the first returned step [s]
  double receive_time = 0.0;   ///< host time the scan's data arrived [s]
  std::uint32_t sensor_stamp = 0;
  float angle_min = 0, angle_max = 0, angle_increment = 0, time_increment = 0, scan_time = 0, range_min = 0,
        range_max = 0;
  std::vector<float> ranges, intensities;  ///< the first echo of a multi-echo scan
  /// Multi-echo scans only: echoes per step, and echo k of step i at
  /// [i * kMaxEchoes + k] (REP 117 values; NaN where a step has fewer).
  std::vector<std::uint8_t> echo_count;
  std::vector<float> echo_ranges, echo_intensities;
};

/// Counters for diagnostics.
struct UtmCounters {
  unsigned long scans = 0, checksum_errors = 0, truncated = 0, bad_scans = 0, error_status = 0, timeouts = 0,
                connects = 0, connect_failures = 0, clock_jumps = 0;
};

class UtmClient {
 public:
  UtmClient(std::unique_ptr<Transport> transport, const UtmClientOptions& options);
  ~UtmClient();

  /// Connects and starts streaming; false with a message on failure (the connection is closed).
  bool start(std::string& error);
  /// Stops streaming (QT) and closes.
  void stop();
  bool streaming() const { return streaming_; }
  /// Streaming multi-echo scans (ND/NE).
  bool multiEcho() const { return streaming_ && request_.multiEcho(); }

  enum class Result { Scan, Idle, Error };
  /// Waits up to `max_wait` [s] for the next scan. Idle: nothing yet. Error: the
  /// connection is dead or unusable (closed; call start() again). Bad scans are
  /// counted and skipped; `warning` tells about the last one.
  Result poll(UtmScan& scan, double max_wait, std::string& error);

  const SensorInfo& info() const { return info_; }
  const ScanClock& clock() const { return clock_; }
  const UtmCounters& counters() const { return counters_; }
  /// The last bad scan's description (checksum, truncated ...), for throttled warnings.
  const std::string& lastWarning() const { return warning_; }
  std::string describe() const { return transport_->describe(); }

 private:
  bool command(const std::string& cmd, Response& reply, std::string& error, double* arrival = nullptr);
  bool readSome(double timeout, std::string& error);
  bool syncClock(std::string& error);
  void handleScan(const Response& r, double recv, UtmScan& out, bool& got);

  std::unique_ptr<Transport> transport_;
  UtmClientOptions opt_;
  SensorInfo info_;
  ScanClock clock_;
  ResponseReader reader_;
  std::vector<std::pair<Response, double>> pending_;  // complete replies with their arrival time
  ScanRequest request_;
  UtmCounters counters_;
  bool streaming_ = false;
  double last_scan_time_ = 0.0, next_ii_ = 0.0, ii_sent_ = -1.0;
  std::string warning_;
  std::mt19937 rng_{12345};
};

/// Host wall-clock time [s].
double wallNow();

}  // namespace scip
}  // namespace tilt_laser_perception
