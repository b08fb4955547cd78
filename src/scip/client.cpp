#include "tilt_laser_perception/scip/client.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

namespace tilt_laser_perception {
namespace scip {

double wallNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

UtmClient::UtmClient(std::unique_ptr<Transport> transport, const UtmClientOptions& options)
    : transport_(std::move(transport)), opt_(options) {}

UtmClient::~UtmClient() { stop(); }

bool UtmClient::readSome(double timeout, std::string& error) {
  char buf[8192];
  const long n = transport_->read(buf, sizeof(buf), timeout, error);
  if (n < 0) return false;
  if (n > 0) {
    const double t = wallNow();
    reader_.feed(buf, static_cast<std::size_t>(n));
    while (auto r = reader_.next()) pending_.emplace_back(std::move(*r), t);
    if (reader_.pending() > (1u << 20)) {  // a stream with no reply ends in 1 MB: garbage
      reader_.clear();
      error = "no reply terminator in 1 MB of data";
      transport_->close();
      return false;
    }
  }
  return true;
}

bool UtmClient::command(const std::string& cmd, Response& reply, std::string& error, double* arrival) {
  if (!transport_->write(cmd + "\n", error)) return false;
  const double end = wallNow() + opt_.command_timeout;
  for (;;) {
    for (auto it = pending_.begin(); it != pending_.end(); ++it) {
      if (it->first.echo == cmd) {
        reply = std::move(it->first);
        if (arrival) *arrival = it->second;
        pending_.erase(it);
        return true;
      }
    }
    pending_.clear();  // replies to something else (scans still in flight after QT)
    const double left = end - wallNow();
    if (left <= 0) {
      error = "no reply to " + cmd + " within " + std::to_string(opt_.command_timeout) + " s";
      return false;
    }
    if (!readSome(std::min(left, 0.05), error)) return false;
  }
}

bool UtmClient::syncClock(std::string& error) {
  Response r;
  if (!command("TM0", r, error)) return false;
  if (r.status != "00" && r.status != "02") {
    error = "TM0 refused with status " + r.status;
    return false;
  }
  std::vector<TmSample> samples;
  std::uniform_int_distribution<int> dither(0, 1000);
  for (int i = 0; i < opt_.tm_samples; ++i) {
    // Random pauses: the replies sample the sensor's millisecond at random phases.
    std::this_thread::sleep_for(std::chrono::microseconds(500 + dither(rng_)));
    const double send = wallNow();
    double recv = 0.0;
    if (!command("TM1", r, error, &recv)) return false;
    if (r.status != "00" || r.lines.empty() || r.lines[0].size() != 5) continue;
    const auto t = decode(r.lines[0].data(), 4);
    if (!t || checksum(r.lines[0].data(), r.lines[0].data() + 4) != r.lines[0][4]) continue;
    samples.push_back({send, recv, *t});
  }
  if (!command("TM2", r, error)) return false;
  clock_.reset();
  if (!clock_.calibrate(samples)) {
    error = "time synchronisation failed: " + std::to_string(samples.size()) + " usable TM1 replies";
    return false;
  }
  return true;
}

bool UtmClient::start(std::string& error) {
  streaming_ = false;
  reader_.clear();
  pending_.clear();
  if (!transport_->open(opt_.connect_timeout, error)) {
    ++counters_.connect_failures;
    return false;
  }
  ++counters_.connects;
  const auto fail = [&](const std::string& what) {
    error = what;
    transport_->close();
    return false;
  };
  Response r;
  // Stop whatever a previous client left running; then a clean state.
  if (!command("QT", r, error)) return fail("no reply to QT: " + error);
  if (!command("RS", r, error)) return fail("no reply to RS: " + error);
  if (!syncClock(error)) return fail(error);
  if (!command("VV", r, error)) return fail(error);
  for (const auto& kv : parseInfo(r)) {
    if (kv.first == "VEND") info_.vendor = kv.second;
    if (kv.first == "PROD") info_.product = kv.second;
    if (kv.first == "FIRM") info_.firmware = kv.second;
    if (kv.first == "PROT") info_.protocol = kv.second;
    if (kv.first == "SERI") info_.serial = kv.second;
  }
  if (!command("PP", r, error)) return fail(error);
  for (const auto& kv : parseInfo(r)) {
    const int v = std::atoi(kv.second.c_str());
    if (kv.first == "MODL") info_.model = kv.second;
    if (kv.first == "DMIN") info_.dmin = v;
    if (kv.first == "DMAX") info_.dmax = v;
    if (kv.first == "ARES") info_.ares = v;
    if (kv.first == "AMIN") info_.amin = v;
    if (kv.first == "AMAX") info_.amax = v;
    if (kv.first == "AFRT") info_.afrt = v;
    if (kv.first == "SCAN") info_.scan_rpm = v;
  }
  if (info_.ares <= 0 || info_.scan_rpm <= 0 || info_.amax <= info_.amin) return fail("PP reply makes no sense");
  if (!command("II", r, error)) return fail(error);
  for (const auto& kv : parseInfo(r))
    if (kv.first == "STAT") info_.status = kv.second;

  // Steps from the angle limits.
  const double step_angle = 2.0 * M_PI / info_.ares;
  const int start_step = std::clamp(static_cast<int>(std::ceil(opt_.angle_min / step_angle - 1e-4)) + info_.afrt,
                                    info_.amin, info_.amax);
  const int end_step = std::clamp(static_cast<int>(std::floor(opt_.angle_max / step_angle + 1e-4)) + info_.afrt,
                                  start_step, info_.amax);
  const auto request = [&](bool multi, std::string& cmd) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%c%c%04d%04d%02d%01d00", multi ? 'N' : 'M', opt_.intensity ? 'E' : 'D',
                  start_step, end_step, std::clamp(opt_.cluster, 1, 99), std::clamp(opt_.skip, 0, 9));
    cmd = buf;
    return parseScanRequest(cmd, info_.amax, request_) == "00";
  };
  std::string cmd;
  if (!request(opt_.multi_echo, cmd)) return fail("bad scan request " + cmd);
  if (!command(cmd, r, error)) return fail(error);
  if (r.status != "00" && opt_.multi_echo) {
    // A UTM-30LX without -EW knows no ND/NE ("0E", undefined command).
    warning_ = cmd + " refused with status " + r.status + " (" + info_.product +
               " has no multi-echo?): streaming single echoes";
    if (!request(false, cmd)) return fail("bad scan request " + cmd);
    if (!command(cmd, r, error)) return fail(error);
  }
  if (r.status != "00") return fail(cmd + " refused with status " + r.status);
  streaming_ = true;
  last_scan_time_ = wallNow();
  next_ii_ = last_scan_time_ + opt_.ii_period;
  return true;
}

void UtmClient::stop() {
  if (transport_->isOpen()) {
    std::string err;
    transport_->write("QT\n", err);
    transport_->close();
  }
  streaming_ = false;
}

void UtmClient::handleScan(const Response& r, double recv, UtmScan& out, bool& got) {
  ScanData d;
  const DecodeError e = decodeScan(r, request_, d);
  if (e != DecodeError::None) {
    if (e == DecodeError::Checksum) ++counters_.checksum_errors;
    else if (e == DecodeError::Truncated) ++counters_.truncated;
    else if (e == DecodeError::Status) ++counters_.error_status;
    else ++counters_.bad_scans;
    warning_ = std::string("scan dropped: ") + decodeErrorName(e) + (e == DecodeError::Status ? " " + r.status : "");
    return;
  }
  const unsigned long jumps = clock_.jumps();
  const double t0 = clock_.stamp(d.timestamp, recv);
  if (clock_.jumps() != jumps) {
    ++counters_.clock_jumps;
    warning_ = "the sensor's clock jumped back (a reboot?): clock model reset";
  }
  const double rev = 60.0 / info_.scan_rpm;
  const double step_time = rev / info_.ares;
  const double step_angle = 2.0 * M_PI / info_.ares;
  out.stamp = t0 + request_.start_step * step_time + opt_.time_offset;
  out.receive_time = recv;
  out.sensor_stamp = d.timestamp;
  out.angle_min = static_cast<float>((request_.start_step - info_.afrt) * step_angle);
  out.angle_increment = static_cast<float>(request_.cluster * step_angle);
  out.angle_max = static_cast<float>(out.angle_min + (d.ranges.size() - 1) * out.angle_increment);
  out.time_increment = static_cast<float>(request_.cluster * step_time);
  out.scan_time = static_cast<float>(rev * (request_.skip + 1));
  out.range_min = info_.dmin * 1e-3f;
  out.range_max = info_.dmax * 1e-3f;
  out.ranges.resize(d.ranges.size());
  for (std::size_t i = 0; i < d.ranges.size(); ++i)
    out.ranges[i] = rangeToMeters(d.ranges[i], static_cast<std::uint32_t>(info_.dmin), static_cast<std::uint32_t>(info_.dmax));
  out.intensities.assign(d.intensities.begin(), d.intensities.end());
  out.echo_count = d.echo_count;
  out.echo_ranges.resize(d.echo_ranges.size());
  out.echo_intensities.resize(d.echo_intensities.size());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t k = 0; k < d.echo_ranges.size(); ++k) {
    const bool there = static_cast<int>(k % kMaxEchoes) < d.echo_count[k / kMaxEchoes];
    out.echo_ranges[k] = there ? rangeToMeters(d.echo_ranges[k], static_cast<std::uint32_t>(info_.dmin),
                                               static_cast<std::uint32_t>(info_.dmax))
                               : nan;
    if (!d.echo_intensities.empty()) out.echo_intensities[k] = there ? static_cast<float>(d.echo_intensities[k]) : nan;
  }
  ++counters_.scans;
  last_scan_time_ = recv;
  got = true;
}

UtmClient::Result UtmClient::poll(UtmScan& out, double max_wait, std::string& error) {
  if (!streaming_ || !transport_->isOpen()) {
    error = "not streaming";
    return Result::Error;
  }
  const double end = wallNow() + max_wait;
  for (;;) {
    bool got = false;
    while (!pending_.empty() && !got) {
      const auto [r, t] = std::move(pending_.front());
      pending_.erase(pending_.begin());
      const std::string c = r.command();
      if (c == "MD" || c == "ME" || c == "MS" || c == "ND" || c == "NE") {
        handleScan(r, t, out, got);
      } else if (c == "II" && ii_sent_ > 0) {
        for (const auto& kv : parseInfo(r)) {
          if (kv.first != "TIME") continue;
          std::uint32_t stamp = 0;
          bool ok = false;
          if (kv.second.size() == 6) {  // hexadecimal milliseconds
            char* e = nullptr;
            stamp = static_cast<std::uint32_t>(std::strtoul(kv.second.c_str(), &e, 16));
            ok = e && *e == '\0';
          } else if (kv.second.size() == 4) {  // 4-character encoding
            const auto v = decode(kv.second.data(), 4);
            ok = v.has_value();
            stamp = v.value_or(0);
          }
          if (ok) clock_.addClockSample({ii_sent_, t, stamp});
        }
        ii_sent_ = -1.0;
      } else if (c == "QT" || c == "RS") {
        // late replies: nothing to do
      }
    }
    if (got) return Result::Scan;
    const double now = wallNow();
    if (now - last_scan_time_ > opt_.watchdog) {
      ++counters_.timeouts;
      error = "no scan for " + std::to_string(now - last_scan_time_).substr(0, 4) + " s (watchdog)";
      transport_->close();
      streaming_ = false;
      return Result::Error;
    }
    if (opt_.ii_period > 0 && now >= next_ii_ && ii_sent_ < 0) {
      // Track the clock: II at a random moment within the next 20 ms.
      std::uniform_real_distribution<double> dither(0.0, 0.02);
      next_ii_ = now + opt_.ii_period + dither(rng_);
      ii_sent_ = wallNow();
      if (!transport_->write("II\n", error)) {
        streaming_ = false;
        return Result::Error;
      }
    } else if (ii_sent_ > 0 && now - ii_sent_ > opt_.command_timeout) {
      ii_sent_ = -1.0;  // no reply: forget it
    }
    const double left = end - now;
    if (left <= 0) return Result::Idle;
    if (!readSome(std::min(left, 0.05), error)) {
      streaming_ = false;
      return Result::Error;
    }
  }
}

}  // namespace scip
}  // namespace tilt_laser_perception
