#include "tilt_laser_perception/core/load_count.hpp"

#include <chrono>
#include <map>
#include <mutex>

namespace tilt_laser_perception {
namespace core {

namespace {
const std::chrono::steady_clock::time_point g_started = std::chrono::steady_clock::now();
std::mutex g_mutex;
std::map<std::string, int>& loads() {
  static std::map<std::string, int> m;
  return m;
}
}  // namespace

int countLoad(const std::string& name) {
  std::lock_guard<std::mutex> lock(g_mutex);
  return ++loads()[name];
}

double processUptime() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - g_started).count();
}

}  // namespace core
}  // namespace tilt_laser_perception
