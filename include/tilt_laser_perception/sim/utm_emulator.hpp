/**
 * @file utm_emulator.hpp
 * @brief An emulated Hokuyo UTM-30LX-EW: a SCIP 2.0 server on a loopback TCP
 *        port, scanning a simulated scene every 25 ms with its own drifting
 *        24-bit millisecond clock, and faults on demand. ROS-free.
 *
 * Commands: VV, PP, II, BM, QT, RS, RT, RB (twice), TM0/TM1/TM2, MD/MS/ME
 * and the -EW's multi-echo ND/NE (cluster, skip, scan count, string
 * characters), GD/GS/GE and HD/HE, SCIP2.0. Returns without a measurement are
 * sent as the UTM-30LX's error code 1, and so are ranges beyond the 4095 mm
 * that MS/GS's two characters hold. After RB (or reboot()) nothing listens
 * for `reboot_time`: a connection is refused, as a sensor that is booting
 * cannot be reached.
 */
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "tilt_laser_perception/sim/lidar_sim.hpp"

namespace tilt_laser_perception {
namespace sim {

/// Host wall-clock time [s] (the clock ROS stamps with).
double hostNow();

/// Produces the scan whose beam 0 is at host time t0 [s] (called from the emulator's thread).
using ScanSource = std::function<void(double t0, SimScan& out)>;

struct UtmOptions {
  std::string address = "127.0.0.1";
  std::uint16_t port = 0;            ///< 0: any free port (see UtmEmulator::port())
  double clock_offset_ms = 123456.0; ///< sensor clock at power-up [ms]
  double drift_ppm = 0.0;            ///< sensor clock rate error [1e-6]
  /// Motor speed error against the sensor's own clock [1e-6]: the revolution is
  /// regulated to 2400 rpm, not locked to the time stamp counter, so it is not
  /// a whole number of milliseconds and the stamps' floors walk across the millisecond.
  double motor_ppm = 400.0;
  /// The sensor is unreachable this long after RB [s]: the UTM-30LX's start-up
  /// time, "within 10 sec" (its specification); tests of other things set less.
  double reboot_time = 10.0;
  std::string serial = "H1102345";
  /// The -EW's multi-echo (ND, NE, HD, HE); false: a UTM-30LX, which answers
  /// them "0E" (undefined command).
  bool multi_echo = true;
};

/// Counts of what the emulator did.
struct UtmStats {
  std::atomic<unsigned long> connections{0}, commands{0}, scans_sent{0}, corrupted{0}, truncated{0}, reboots{0},
      drops{0};
};

class UtmEmulator {
 public:
  UtmEmulator(ScanSource source, const UtmOptions& options = UtmOptions());
  ~UtmEmulator();
  UtmEmulator(const UtmEmulator&) = delete;
  UtmEmulator& operator=(const UtmEmulator&) = delete;

  /// Binds and starts serving; throws std::runtime_error when the port cannot be bound.
  void start();
  void stop();
  std::uint16_t port() const { return port_; }
  std::string address() const { return options_.address + ":" + std::to_string(port_); }

  /// The sensor clock [ms] at host time t (not wrapped), and its 24-bit time stamp.
  double sensorMillis(double host_t) const;
  std::uint32_t sensorStamp(double host_t) const { return static_cast<std::uint32_t>(sensorMillis(host_t)) & 0xFFFFFF; }
  /// Host time of the start (beam 0) of scan k of the current power cycle.
  double scanStart(long k) const;

  // ---- faults ----
  void dropConnection() { drop_.store(true); }          ///< close the client's connection now
  void setSilent(bool s) { silent_.store(s); }          ///< stay connected, send nothing
  void corruptNextScans(int n) { corrupt_.store(n); }   ///< flip a data line's sum in the next n scans
  void truncateNextScans(int n) { truncate_.store(n); } ///< send only half of the next n scans
  void setReplyDelay(double s) { delay_.store(s); }     ///< delay replies to commands [s]
  void reboot() { reboot_.store(true); }                ///< power cycle: drop, unreachable, clock restarts at 0

  const UtmStats& stats() const { return stats_; }

 private:
  void run();
  void handleCommand(const std::string& line, std::string& reply);
  void sendScan(long k, double now);
  void closeClient();
  void powerUp(double t, double clock_ms);
  bool sendAll(const std::string& s);
  const char* model() const { return options_.multi_echo ? "UTM-30LX-EW" : "UTM-30LX"; }
  bool openListener();  ///< on port_ (0: any free port, then port_ is set)
  void closeListener();

  ScanSource source_;
  UtmOptions options_;
  std::uint16_t port_ = 0;
  int listen_fd_ = -1, client_fd_ = -1;
  std::thread thread_;
  std::atomic<bool> running_{false};
  mutable std::mutex clock_mutex_;
  double boot_time_ = 0.0, boot_clock_ms_ = 0.0;

  // sensor state (emulator thread only)
  bool laser_on_ = false, time_adjust_ = false, streaming_ = false;
  double rb_first_ = -10.0;
  std::string request_line_;
  int req_start_ = 0, req_end_ = 1080, req_cluster_ = 1, req_skip_ = 0, req_remaining_ = 0, req_enc_ = 3;
  bool req_intensity_ = false, req_infinite_ = true, req_multi_ = false;
  std::string req_cmd_, req_tag_;
  long next_scan_ = 0;
  int skip_count_ = 0;
  std::string rx_;
  SimScan scan_;

  std::atomic<bool> drop_{false}, silent_{false}, reboot_{false};
  std::atomic<int> corrupt_{0}, truncate_{0};
  std::atomic<double> delay_{0.0};
  UtmStats stats_;
};

}  // namespace sim
}  // namespace tilt_laser_perception
