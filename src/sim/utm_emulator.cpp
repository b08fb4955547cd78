#include "tilt_laser_perception/sim/utm_emulator.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "tilt_laser_perception/scip/codec.hpp"

namespace tilt_laser_perception {
namespace sim {

double hostNow() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

namespace {
constexpr double kPeriod = 0.025;  // one revolution on the sensor's clock [s]
constexpr int kMaxStep = 1080;

std::string statusLine(const char* st) {
  std::string s = st;
  s.push_back(scip::checksum(s));
  s.push_back('\n');
  return s;
}
void infoLine(const std::string& kv, std::string& out) {
  out += kv;
  out += ';';
  out.push_back(scip::checksum(kv));
  out += '\n';
}
std::uint32_t toMillimetres(float r) {
  if (std::isnan(r)) return 3;          // measurement error
  if (!std::isfinite(r)) return r > 0 ? 1 : 4;  // no object in range / too near
  const long mm = std::lround(r * 1000.0);
  if (mm < 23) return 4;
  return static_cast<std::uint32_t>(std::min<long>(mm, 60000));
}
}  // namespace

UtmEmulator::UtmEmulator(ScanSource source, const UtmOptions& options)
    : source_(std::move(source)), options_(options) {}

UtmEmulator::~UtmEmulator() { stop(); }

void UtmEmulator::powerUp(double t, double clock_ms) {
  std::lock_guard<std::mutex> l(clock_mutex_);
  boot_time_ = t;
  boot_clock_ms_ = clock_ms;
}

double UtmEmulator::sensorMillis(double host_t) const {
  std::lock_guard<std::mutex> l(clock_mutex_);
  return boot_clock_ms_ + (host_t - boot_time_) * 1000.0 * (1.0 + options_.drift_ppm * 1e-6);
}

double UtmEmulator::scanStart(long k) const {
  std::lock_guard<std::mutex> l(clock_mutex_);
  return boot_time_ + k * kPeriod * (1.0 + options_.motor_ppm * 1e-6) / (1.0 + options_.drift_ppm * 1e-6);
}

bool UtmEmulator::openListener() {
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
  if (listen_fd_ < 0) return false;
  const int one = 1;
  ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port_);
  ::inet_pton(AF_INET, options_.address.c_str(), &addr.sin_addr);
  if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) < 0 || ::listen(listen_fd_, 4) < 0) {
    closeListener();
    return false;
  }
  socklen_t len = sizeof(addr);
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
  return true;
}

void UtmEmulator::closeListener() {
  if (listen_fd_ >= 0) ::close(listen_fd_);
  listen_fd_ = -1;
}

void UtmEmulator::start() {
  sockaddr_in addr{};
  if (::inet_pton(AF_INET, options_.address.c_str(), &addr.sin_addr) != 1)
    throw std::runtime_error("bad address " + options_.address);
  port_ = options_.port;
  if (!openListener())
    throw std::runtime_error("cannot listen on " + options_.address + ":" + std::to_string(options_.port) + ": " +
                             std::strerror(errno));
  powerUp(hostNow(), options_.clock_offset_ms);
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

void UtmEmulator::stop() {
  running_ = false;
  if (thread_.joinable()) thread_.join();
  closeClient();
  closeListener();
}

void UtmEmulator::closeClient() {
  if (client_fd_ >= 0) ::close(client_fd_);
  client_fd_ = -1;
  rx_.clear();
  streaming_ = false;
  laser_on_ = false;
  time_adjust_ = false;
}

bool UtmEmulator::sendAll(const std::string& s) {
  if (client_fd_ < 0 || silent_.load()) return client_fd_ >= 0;
  std::size_t off = 0;
  while (off < s.size()) {
    const ssize_t n = ::send(client_fd_, s.data() + off, s.size() - off, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) {
        pollfd p{client_fd_, POLLOUT, 0};
        ::poll(&p, 1, 100);
        continue;
      }
      closeClient();
      return false;
    }
    off += static_cast<std::size_t>(n);
  }
  return true;
}

void UtmEmulator::run() {
  double unreachable_until = 0.0;
  while (running_) {
    double now = hostNow();
    if (reboot_.exchange(false)) {
      closeClient();
      ++stats_.reboots;
      unreachable_until = now + options_.reboot_time;
      powerUp(unreachable_until, 0.37);  // the clock restarts near 0 once it is back
      // Powered down and booting: nothing listens (a connection is refused),
      // where the old emulator accepted and closed at once.
      closeListener();
    }
    if (listen_fd_ < 0) {
      if (now < unreachable_until || !openListener()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        continue;
      }
    }
    if (drop_.exchange(false) && client_fd_ >= 0) {
      closeClient();
      ++stats_.drops;
    }
    // Wake when the next scan is complete, to the microsecond (a millisecond
    // timeout would add a saw-tooth to the arrival times that no sensor has).
    double wait = 0.02;
    if (streaming_) wait = std::clamp(scanStart(next_scan_) + kPeriod - now, 0.0, 0.02);
    timespec ts;
    ts.tv_sec = 0;
    ts.tv_nsec = static_cast<long>(wait * 1e9);
    pollfd fds[2] = {{listen_fd_, POLLIN, 0}, {client_fd_, POLLIN, 0}};
    const nfds_t nfds = client_fd_ >= 0 ? 2 : 1;
    ::ppoll(fds, nfds, &ts, nullptr);
    now = hostNow();
    if (fds[0].revents & POLLIN) {
      const int fd = ::accept(listen_fd_, nullptr, nullptr);
      if (fd >= 0) {
        closeClient();  // the sensor serves one client: a new connection replaces the old one
        client_fd_ = fd;
        const int one = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
        ++stats_.connections;
      }
    }
    if (nfds == 2 && client_fd_ >= 0 && (fds[1].revents & (POLLIN | POLLHUP | POLLERR))) {
      char buf[512];
      const ssize_t n = ::recv(client_fd_, buf, sizeof(buf), 0);
      if (n <= 0) {
        closeClient();
      } else {
        rx_.append(buf, static_cast<std::size_t>(n));
        std::size_t pos;
        while ((pos = rx_.find_first_of("\r\n")) != std::string::npos) {
          const std::string line = rx_.substr(0, pos);
          rx_.erase(0, pos + 1);
          if (line.empty()) continue;
          ++stats_.commands;
          std::string reply;
          handleCommand(line, reply);
          const double d = delay_.load();
          if (d > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(d));
          sendAll(reply);
          if (reboot_.load()) break;
        }
      }
    }
    while (streaming_ && client_fd_ >= 0 && scanStart(next_scan_) + kPeriod <= hostNow()) {
      const long k = next_scan_++;
      if (skip_count_++ % (req_skip_ + 1) != 0) continue;
      sendScan(k, now);
    }
  }
}

void UtmEmulator::handleCommand(const std::string& line, std::string& reply) {
  const std::string echo = line + "\n";
  const std::string cmd = line.substr(0, 2);
  const double now = hostNow();
  const auto simple = [&](const char* status) { reply = echo + statusLine(status) + "\n"; };

  if (line.rfind("SCIP2.0", 0) == 0) return simple("0E");  // already in SCIP 2.0
  if (cmd == "VV") {
    reply = echo + statusLine("00");
    infoLine("VEND:Hokuyo Automatic Co.,Ltd.", reply);
    infoLine(std::string("PROD:SOKUIKI Sensor TOP-URG ") + model(), reply);
    infoLine("FIRM:1.1.4(14/Jun./2011)", reply);
    infoLine("PROT:SCIP 2.0", reply);
    infoLine("SERI:" + options_.serial, reply);
    reply += "\n";
    return;
  }
  if (cmd == "PP") {
    reply = echo + statusLine("00");
    infoLine(std::string("MODL:") + model(), reply);
    for (const char* kv : {"DMIN:23", "DMAX:60000", "ARES:1440", "AMIN:0", "AMAX:1080",
                           "AFRT:540", "SCAN:2400"})
      infoLine(kv, reply);
    reply += "\n";
    return;
  }
  if (cmd == "II") {
    reply = echo + statusLine("00");
    char t[32];
    std::snprintf(t, sizeof(t), "TIME:%06X", sensorStamp(now));
    infoLine(std::string("MODL:") + model(), reply);
    infoLine(std::string("LASR:") + (laser_on_ ? "ON" : "OFF"), reply);
    infoLine("SCSP:Initial(2400[rpm])", reply);
    infoLine(time_adjust_ ? "MESM:Time Adjust Mode" : "MESM:Measuring by Normal Mode", reply);
    infoLine("SBPS:Ethernet 100 [Mbps]", reply);
    infoLine(t, reply);
    infoLine("STAT:Sensor works well.", reply);
    reply += "\n";
    return;
  }
  if (cmd == "BM") {
    if (time_adjust_) return simple("01");
    if (laser_on_) return simple("02");
    laser_on_ = true;
    return simple("00");
  }
  if (cmd == "QT" || cmd == "RS" || cmd == "RT") {
    streaming_ = false;
    laser_on_ = false;
    if (cmd != "QT") time_adjust_ = false;
    return simple("00");
  }
  if (cmd == "RB") {
    if (now - rb_first_ > 1.0) {
      rb_first_ = now;
      return simple("01");
    }
    rb_first_ = -10.0;
    simple("00");
    reboot_.store(true);
    return;
  }
  if (cmd == "TM") {
    const char code = line.size() > 2 ? line[2] : '?';
    if (code == '0') {
      if (time_adjust_) return simple("02");
      time_adjust_ = true;
      streaming_ = false;
      laser_on_ = false;
      return simple("00");
    }
    if (code == '1') {
      if (!time_adjust_) return simple("04");
      reply = echo + statusLine("00");
      std::string ts;
      scip::encode(sensorStamp(now), 4, ts);
      scip::appendLineWithSum(ts, reply);
      reply += "\n";
      return;
    }
    if (code == '2') {
      if (!time_adjust_) return simple("03");
      time_adjust_ = false;
      return simple("00");
    }
    return simple("01");
  }
  const bool multi_cmd = cmd == "ND" || cmd == "NE" || cmd == "HD" || cmd == "HE";
  if (multi_cmd && !options_.multi_echo) return simple("0E");
  if (cmd == "MD" || cmd == "MS" || cmd == "ME" || cmd == "GD" || cmd == "GS" || cmd == "GE" || multi_cmd) {
    scip::ScanRequest req;
    const std::string status = scip::parseScanRequest(line, kMaxStep, req);
    if (status != "00") return simple(status.c_str());
    if (time_adjust_) return simple("0L");
    req_cmd_ = cmd;
    req_start_ = req.start_step;
    req_end_ = req.end_step;
    req_cluster_ = req.cluster;
    req_enc_ = req.encoding();
    req_intensity_ = req.intensity();
    req_multi_ = req.multiEcho();
    req_tag_ = req.tag;
    if (req.continuous()) {
      req_skip_ = req.skip;
      req_infinite_ = req.scans == 0;
      req_remaining_ = req.scans;
      request_line_ = line;
      laser_on_ = true;
      streaming_ = true;
      skip_count_ = 0;
      next_scan_ = static_cast<long>(std::floor((now - scanStart(0)) / (scanStart(1) - scanStart(0)))) + 1;
      return simple("00");
    }
    if (!laser_on_) return simple("10");
    // The latest complete scan.
    const long k = static_cast<long>(std::floor((now - scanStart(0)) / (scanStart(1) - scanStart(0)))) - 1;
    streaming_ = false;
    request_line_ = line;
    sendScan(k, now);
    reply.clear();
    return;
  }
  simple("0E");
}

void UtmEmulator::sendScan(long k, double /*now*/) {
  const double t0 = scanStart(k);
  source_(t0, scan_);
  const bool continuous = req_cmd_[0] == 'M' || req_cmd_[0] == 'N';
  std::string msg;
  if (continuous) {
    int remaining = 0;
    if (!req_infinite_) remaining = --req_remaining_;
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%s%04d%04d%02d%01d%02d", req_cmd_.c_str(), req_start_, req_end_, req_cluster_,
                  req_skip_, std::max(remaining, 0));
    msg = buf;
    if (!req_tag_.empty()) msg += ";" + req_tag_;
    msg += "\n";
    msg += statusLine("99");
    if (!req_infinite_ && remaining <= 0) {
      streaming_ = false;
      laser_on_ = false;
    }
  } else {
    msg = request_line_ + "\n" + statusLine("00");
  }
  std::string ts;
  scip::encode(static_cast<std::uint32_t>(std::floor(sensorMillis(t0))) & 0xFFFFFF, 4, ts);
  scip::appendLineWithSum(ts, msg);
  std::string data;
  const int cluster = std::max(1, req_cluster_);
  const int n = static_cast<int>(scan_.ranges.size());
  const int values = (req_end_ - req_start_) / cluster + 1;
  const auto intensityValue = [&](float i) {
    return static_cast<std::uint32_t>(std::clamp(i, 0.0f, 262143.0f));
  };
  for (int v = 0; v < values; ++v) {
    const int s = req_start_ + v * cluster;
    // A cluster reports its step with the nearest range (SCIP 2.0, MD: "the
    // step having minimum measurement value (excluding error)").
    std::uint32_t best = 0, err = 0;
    int best_j = -1;
    for (int j = s; j < s + cluster && j <= req_end_ && j < n; ++j) {
      const std::uint32_t mm = toMillimetres(scan_.ranges[j]);
      if (mm >= 23) {
        if (best == 0 || mm < best) {
          best = mm;
          best_j = j;
        }
      } else if (err == 0) {
        err = mm;
      }
    }
    const float inten =
        best_j >= 0 && best_j < static_cast<int>(scan_.intensities.size()) ? scan_.intensities[best_j] : 0.0f;
    scip::encodeRange(best ? best : (err ? err : 1), req_enc_, data);
    if (req_intensity_) scip::encode(intensityValue(inten), req_enc_, data);
    if (req_multi_ && best_j >= 0 && best_j < static_cast<int>(scan_.echoes.size())) {
      // Multi-echo: every further echo of that step after an '&'.
      const BeamEchoes& e = scan_.echoes[best_j];
      for (int k = 1; k < e.count; ++k) {
        data.push_back('&');
        scip::encodeRange(toMillimetres(e.range[k]), req_enc_, data);
        if (req_intensity_) scip::encode(intensityValue(e.intensity[k]), req_enc_, data);
      }
    }
  }
  std::string lines;
  scip::appendDataLines(data, lines);
  if (truncate_.load() > 0) {
    --truncate_;
    ++stats_.truncated;
    // Cut after half of the data lines: a scan that stops early.
    std::size_t cut = 0;
    const std::size_t n_lines = std::count(lines.begin(), lines.end(), '\n');
    for (std::size_t i = 0; i < n_lines / 2; ++i) cut = lines.find('\n', cut) + 1;
    lines.resize(cut);
  } else if (corrupt_.load() > 0) {
    --corrupt_;
    ++stats_.corrupted;
    const std::size_t lf = lines.find('\n');
    char& sum = lines[lf - 1];
    sum = static_cast<char>(sum == 0x6F ? 0x30 : sum + 1);
  }
  msg += lines;
  msg += "\n";
  if (sendAll(msg)) ++stats_.scans_sent;
}

}  // namespace sim
}  // namespace tilt_laser_perception
