/**
 * @file options.hpp
 * @brief The simulator's command line values, parsed alike by every tool.
 */
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

namespace tilt_laser_perception {
namespace sim {

/// The whole of `text` as a finite number; std::invalid_argument naming `option` otherwise.
inline double optionNumber(const std::string& option, const std::string& text) {
  std::size_t used = 0;
  double x = 0.0;
  try {
    x = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(x)) throw std::invalid_argument(option + ": not a number: '" + text + "'");
  return x;
}

/// x, or std::invalid_argument naming `option` when it is negative.
inline double nonNegativeOption(const std::string& option, double x) {
  if (x < 0.0) throw std::invalid_argument(option + " must not be negative");
  return x;
}

}  // namespace sim
}  // namespace tilt_laser_perception
