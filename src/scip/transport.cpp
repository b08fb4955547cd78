#include "tilt_laser_perception/scip/transport.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace tilt_laser_perception {
namespace scip {
namespace {

class FdTransport : public Transport {
 public:
  ~FdTransport() override { FdTransport::close(); }
  void close() override {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  bool isOpen() const override { return fd_ >= 0; }
  bool write(const std::string& data, std::string& error) override {
    std::size_t off = 0;
    while (off < data.size()) {
      if (fd_ < 0) {
        error = "not connected";
        return false;
      }
      const ssize_t n = writeSome(data.data() + off, data.size() - off);
      if (n < 0) {
        if (errno == EINTR) continue;
        if (errno == EAGAIN || errno == EWOULDBLOCK) {
          pollfd p{fd_, POLLOUT, 0};
          if (::poll(&p, 1, 500) <= 0) {
            error = "write timed out";
            close();
            return false;
          }
          continue;
        }
        error = std::string("write failed: ") + std::strerror(errno);
        close();
        return false;
      }
      off += static_cast<std::size_t>(n);
    }
    return true;
  }
  long read(char* buffer, std::size_t size, double timeout, std::string& error) override {
    if (fd_ < 0) {
      error = "not connected";
      return -1;
    }
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(timeout * 1000.0));
    if (r == 0) return 0;
    if (r < 0) {
      if (errno == EINTR) return 0;
      error = std::string("poll failed: ") + std::strerror(errno);
      close();
      return -1;
    }
    const ssize_t n = ::read(fd_, buffer, size);
    if (n > 0) return n;
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return 0;
    error = n == 0 ? "connection closed by the sensor" : std::string("read failed: ") + std::strerror(errno);
    close();
    return -1;
  }

 protected:
  virtual ssize_t writeSome(const char* p, std::size_t n) { return ::write(fd_, p, n); }
  int fd_ = -1;
};

class TcpTransport : public FdTransport {
 public:
  TcpTransport(std::string host, std::uint16_t port) : host_(std::move(host)), port_(port) {}
  bool open(double timeout, std::string& error) override {
    close();
    addrinfo hints{};
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* res = nullptr;
    if (::getaddrinfo(host_.c_str(), std::to_string(port_).c_str(), &hints, &res) != 0 || !res) {
      error = "cannot resolve " + host_;
      return false;
    }
    fd_ = ::socket(res->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd_ < 0) {
      ::freeaddrinfo(res);
      error = std::string("socket: ") + std::strerror(errno);
      return false;
    }
    int rc = ::connect(fd_, res->ai_addr, res->ai_addrlen);
    ::freeaddrinfo(res);
    if (rc < 0 && errno != EINPROGRESS) {
      error = std::string("connect: ") + std::strerror(errno);
      close();
      return false;
    }
    if (rc < 0) {
      pollfd p{fd_, POLLOUT, 0};
      if (::poll(&p, 1, static_cast<int>(timeout * 1000.0)) <= 0) {
        error = "connect timed out";
        close();
        return false;
      }
      int err = 0;
      socklen_t len = sizeof(err);
      ::getsockopt(fd_, SOL_SOCKET, SO_ERROR, &err, &len);
      if (err != 0) {
        error = std::string("connect: ") + std::strerror(err);
        close();
        return false;
      }
    }
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    return true;
  }
  std::string describe() const override { return "tcp " + host_ + ":" + std::to_string(port_); }

 protected:
  ssize_t writeSome(const char* p, std::size_t n) override { return ::send(fd_, p, n, MSG_NOSIGNAL); }

 private:
  std::string host_;
  std::uint16_t port_;
};

class SerialTransport : public FdTransport {
 public:
  SerialTransport(std::string device, int baud) : device_(std::move(device)), baud_(baud) {}
  bool open(double, std::string& error) override {
    close();
    fd_ = ::open(device_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) {
      error = "cannot open " + device_ + ": " + std::strerror(errno);
      return false;
    }
    termios t{};
    if (::tcgetattr(fd_, &t) == 0) {
      ::cfmakeraw(&t);
      const speed_t s = baud_ >= 115200 ? B115200 : baud_ >= 57600 ? B57600 : B19200;
      ::cfsetispeed(&t, s);
      ::cfsetospeed(&t, s);
      t.c_cflag |= CLOCAL | CREAD;
      ::tcsetattr(fd_, TCSANOW, &t);
    }
    ::tcflush(fd_, TCIOFLUSH);
    return true;
  }
  std::string describe() const override { return "serial " + device_; }

 private:
  std::string device_;
  int baud_;
};

}  // namespace

std::unique_ptr<Transport> makeTcpTransport(const std::string& host, std::uint16_t port) {
  return std::make_unique<TcpTransport>(host, port);
}
std::unique_ptr<Transport> makeSerialTransport(const std::string& device, int baud) {
  return std::make_unique<SerialTransport>(device, baud);
}

}  // namespace scip
}  // namespace tilt_laser_perception
