/**
 * @file laser_driver.hpp
 * @brief The laser loop: keeps a SCIP 2.0 client streaming, hands every good
 *        scan to a callback, and reconnects with backoff when the sensor is
 *        refused, lost, silent or rebooted. ROS-free; one thread of its own.
 */
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "tilt_laser_perception/scip/client.hpp"

namespace tilt_laser_perception {
namespace driver {

struct LaserDriverOptions {
  std::string host = "192.168.0.10";
  int port = 10940;
  std::string serial_device;  ///< non-empty: the USB UTM-30LX on this serial device instead of TCP
  scip::UtmClientOptions client;
  /// Reconnect waits [s]: doubling from min to max. At most 1 s, so that the
  /// stream is back within about 1 s of a fault's end (an attempt a second costs nothing).
  double backoff_min = 0.2, backoff_max = 1.0;
};

/// A snapshot for diagnostics.
struct LaserStatus {
  bool streaming = false;
  bool multi_echo = false;     ///< streaming ND/NE
  scip::SensorInfo info;
  scip::UtmCounters counters;
  double scan_rate = 0.0;      ///< scans per second over the last second [Hz]
  double stamp_delay = 0.0;    ///< arrival minus stamp of the last scan [s]
  double clock_offset = 0.0;   ///< host minus sensor time [s]
  double clock_drift_ppm = 0.0;
  std::size_t clock_samples = 0;
  unsigned long clock_rejected = 0;  ///< clock readings left out for their round trip
  double last_rejected_rtt = 0.0;    ///< round trip of the last one left out [s]
  unsigned long delayed_scans = 0;   ///< scans that arrived more than max_latency after their step 0
  unsigned long impossible_stamps = 0;  ///< scans stamped less than the scan's own duration before they arrived
  unsigned long reconnects = 0;
  /// Reconnections after which the sensor's clock had started again (the
  /// sensor rebooted or lost power): the host time at which its clock read 0
  /// moved by more than 0.5 s across the reconnection.
  unsigned long sensor_restarts = 0;
  std::string last_error, endpoint;
};

class LaserDriver {
 public:
  enum class Level { Info, Warn, Error };
  using ScanCallback = std::function<void(const scip::UtmScan&)>;
  using LogCallback = std::function<void(Level, const std::string&)>;

  LaserDriver(const LaserDriverOptions& options, ScanCallback on_scan, LogCallback log);
  ~LaserDriver();
  void start();
  /// Stops the thread (joins within about 0.2 s) and the sensor's stream.
  void stop();
  LaserStatus status() const;

 private:
  void run();
  LaserDriverOptions opt_;
  ScanCallback on_scan_;
  LogCallback log_;
  std::unique_ptr<scip::UtmClient> client_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  mutable std::mutex status_mutex_;
  LaserStatus status_;
};

}  // namespace driver
}  // namespace tilt_laser_perception
