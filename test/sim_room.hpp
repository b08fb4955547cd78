// Test helper: the split_room scene scanned from a fixed sensor, as a scan
// source for the emulated UTM-30LX-EW (the last scan kept for comparisons).
#pragma once

#include <mutex>

#include "tilt_laser_perception/sim/utm_emulator.hpp"

namespace tilt_laser_perception {
namespace test {

struct Room {
  sim::Scene scene = sim::loadScene("split_room");
  sim::LidarSimulator lidar{scene, sim::LidarModel(), sim::NoiseParams(), 3};
  std::mutex m;
  sim::SimScan last;
  sim::ScanSource source() {
    return [this](double t0, sim::SimScan& out) {
      std::lock_guard<std::mutex> l(m);
      lidar.scan(t0, [](double) { return Eigen::Isometry3d::Identity(); }, out);
      last = out;
    };
  }
};

}  // namespace test
}  // namespace tilt_laser_perception
