#include "tilt_laser_perception/driver/laser_driver.hpp"

#include <cmath>

#include <chrono>
#include <deque>

namespace tilt_laser_perception {
namespace driver {

LaserDriver::LaserDriver(const LaserDriverOptions& options, ScanCallback on_scan, LogCallback log)
    : opt_(options), on_scan_(std::move(on_scan)), log_(std::move(log)) {
  auto transport = opt_.serial_device.empty()
                       ? scip::makeTcpTransport(opt_.host, static_cast<std::uint16_t>(opt_.port))
                       : scip::makeSerialTransport(opt_.serial_device);
  client_ = std::make_unique<scip::UtmClient>(std::move(transport), opt_.client);
  status_.endpoint = client_->describe();
}

LaserDriver::~LaserDriver() { stop(); }

void LaserDriver::start() {
  if (running_) return;
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

void LaserDriver::stop() {
  if (!running_) return;
  running_ = false;
  if (thread_.joinable()) thread_.join();
  client_->stop();
}

LaserStatus LaserDriver::status() const {
  std::lock_guard<std::mutex> l(status_mutex_);
  return status_;
}

void LaserDriver::run() {
  double backoff = opt_.backoff_min;
  std::deque<double> arrivals;
  scip::UtmScan scan;
  bool was_streaming = false, check_boot = false;
  double boot = 0.0;  // host time at which the sensor's 24-bit clock read 0 (modulo its wrap)
  while (running_) {
    std::string err;
    if (!client_->streaming()) {
      if (was_streaming) {
        std::lock_guard<std::mutex> l(status_mutex_);
        ++status_.reconnects;
      }
      if (!client_->start(err)) {
        {
          std::lock_guard<std::mutex> l(status_mutex_);
          status_.streaming = false;
          status_.last_error = err;
          status_.counters = client_->counters();
        }
        if (log_) log_(Level::Warn, "laser " + client_->describe() + " not available (" + err + "); retrying in " +
                                        std::to_string(backoff).substr(0, 4) + " s");
        const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(backoff);
        while (running_ && std::chrono::steady_clock::now() < until)
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        backoff = std::min(opt_.backoff_max, backoff * 2.0);
        continue;
      }
      backoff = opt_.backoff_min;
      check_boot = was_streaming;  // the first scan tells whether the sensor restarted meanwhile
      was_streaming = true;
      const scip::SensorInfo& i = client_->info();
      if (log_)
        log_(Level::Info, "laser " + i.model + " serial " + i.serial + " firmware " + i.firmware + " (" +
                              std::to_string(i.amax - i.amin + 1) + " steps, " + std::to_string(i.scan_rpm) +
                              " rpm) streaming from " + client_->describe());
      if (opt_.client.multi_echo && !client_->multiEcho() && log_) log_(Level::Warn, "laser: " + client_->lastWarning());
      std::lock_guard<std::mutex> l(status_mutex_);
      status_.streaming = true;
      status_.multi_echo = client_->multiEcho();
      status_.info = i;
      status_.last_error.clear();
    }
    const unsigned long bad_before = client_->counters().checksum_errors + client_->counters().truncated +
                                     client_->counters().bad_scans + client_->counters().error_status;
    const auto r = client_->poll(scan, 0.1, err);
    const auto& c = client_->counters();
    if (c.checksum_errors + c.truncated + c.bad_scans + c.error_status != bad_before && log_)
      log_(Level::Warn, "laser: " + client_->lastWarning());
    if (r == scip::UtmClient::Result::Error) {
      if (log_) log_(Level::Error, "laser " + client_->describe() + ": " + err + "; reconnecting");
      std::lock_guard<std::mutex> l(status_mutex_);
      status_.streaming = false;
      status_.last_error = err;
      status_.counters = c;
      continue;
    }
    if (r != scip::UtmClient::Result::Scan) continue;
    // A rebooted sensor's clock starts again near 0: its zero moves by the
    // former uptime, where a plain reconnection keeps it.
    const double wrap = 16777.216;  // 2^24 ms
    const double b = std::fmod(scan.stamp - scan.sensor_stamp * 1e-3, wrap);
    if (check_boot) {
      const double d = std::abs(std::remainder(b - boot, wrap));
      check_boot = false;
      if (d > 0.5) {
        {
          std::lock_guard<std::mutex> l(status_mutex_);
          ++status_.sensor_restarts;
        }
        if (log_) log_(Level::Warn, "laser: its clock started again (the sensor rebooted or lost power)");
      }
    }
    boot = b;
    if (on_scan_) on_scan_(scan);
    arrivals.push_back(scan.receive_time);
    while (!arrivals.empty() && arrivals.front() < scan.receive_time - 1.0) arrivals.pop_front();
    std::lock_guard<std::mutex> l(status_mutex_);
    status_.counters = c;
    status_.scan_rate = static_cast<double>(arrivals.size());
    status_.stamp_delay = scan.receive_time - scan.stamp;
    status_.clock_offset = client_->clock().offset();
    status_.clock_drift_ppm = client_->clock().driftPpm();
    status_.clock_samples = client_->clock().clockSamples();
    status_.clock_rejected = client_->clock().rejectedSamples();
    status_.last_rejected_rtt = client_->clock().lastRejectedRtt();
    status_.delayed_scans = client_->clock().delayedScans();
    status_.impossible_stamps = client_->clock().impossibleStamps();
  }
}

}  // namespace driver
}  // namespace tilt_laser_perception
