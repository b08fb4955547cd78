/**
 * @file in_halves.hpp
 * @brief A loop over [0, n) in two halves on two threads. ROS-free.
 */
#pragma once

#include <cstddef>
#include <thread>

namespace tilt_laser_perception {
namespace core {

/// f(begin, end, half) over [0, n): in two halves, the second (half 1) on a
/// thread of its own, when `two`; else at once (half 0). The thread is
/// joined before an exception of the first half leaves.
template <class F>
void inHalves(std::size_t n, bool two, F&& f) {
  if (!two) {
    f(std::size_t{0}, n, 0);
    return;
  }
  const std::size_t mid = n / 2;
  std::thread second([&] { f(mid, n, 1); });
  try {
    f(std::size_t{0}, mid, 0);
  } catch (...) {
    second.join();
    throw;
  }
  second.join();
}

}  // namespace core
}  // namespace tilt_laser_perception
