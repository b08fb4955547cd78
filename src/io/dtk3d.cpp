// 3DTK's .3d scans as organized clouds (io/pcd.hpp), and the cloud's lines in
// the other order. No PCL: plain text.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "tilt_laser_perception/io/pcd.hpp"

namespace tilt_laser_perception {
namespace io {

OrganizedCloud read3dtk(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot open " + path);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<std::vector<Eigen::Vector3f>> lines(1);
  double last_angle = NAN;
  std::string text;
  std::size_t n = 0;
  while (std::getline(f, text)) {
    std::istringstream in(text);
    double x, y, z;
    if (!(in >> x >> y >> z)) {
      if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
      throw std::runtime_error(path + ": line " + std::to_string(n + 1) + " is not 'x y z': '" + text + "'");
    }
    ++n;
    const double r = std::sqrt(x * x + y * y + z * z);
    const bool valid = std::isfinite(r) && r > 0.0 && r <= 3276.0;
    if (valid) {
      // A line sweeps from the right (angle 0) to the left (pi) in the x-z plane; it falls back where the next begins.
      const double a = std::atan2(z, x);
      if (std::isfinite(last_angle) && a < last_angle - 1.0 && !lines.back().empty()) lines.emplace_back();
      last_angle = a;
      lines.back().emplace_back(static_cast<float>(z / 100.0), static_cast<float>(-x / 100.0),
                                static_cast<float>(y / 100.0));
    } else {
      lines.back().emplace_back(nan, nan, nan);
    }
  }
  if (n == 0) throw std::runtime_error(path + " holds no point");
  // Lines of one length (a scanner's fixed beam count): points without a
  // return at a line's start or end are put in their own line, not the one the
  // angle saw last.
  std::vector<std::size_t> sizes;
  for (const auto& l : lines) sizes.push_back(l.size());
  std::nth_element(sizes.begin(), sizes.begin() + sizes.size() / 2, sizes.end());
  const std::size_t m = sizes[sizes.size() / 2];
  if (m > 0 && n % m == 0 && n / m == lines.size()) {
    std::vector<Eigen::Vector3f> all;
    for (const auto& l : lines) all.insert(all.end(), l.begin(), l.end());
    for (std::size_t r = 0; r < lines.size(); ++r) lines[r].assign(all.begin() + r * m, all.begin() + (r + 1) * m);
  }
  OrganizedCloud c;
  c.height = static_cast<int>(lines.size());
  for (const auto& l : lines) c.width = std::max(c.width, static_cast<int>(l.size()));
  c.points.assign(static_cast<std::size_t>(c.width) * c.height, Eigen::Vector3f::Constant(nan));
  for (std::size_t r = 0; r < lines.size(); ++r)
    std::copy(lines[r].begin(), lines[r].end(), c.points.begin() + r * c.width);
  // The scanner's place: scanNNN.pose beside the scan (position in cm, 3DTK's frame).
  const std::size_t dot = path.rfind(".3d");
  if (dot != std::string::npos) {
    std::ifstream pose(path.substr(0, dot) + ".pose");
    double px, py, pz;
    if (pose >> px >> py >> pz) c.viewpoint = Eigen::Vector3d(pz / 100.0, -px / 100.0, py / 100.0);
  }
  return c;
}

OrganizedCloud readCloud(const std::string& path, const TruthField& truth) {
  const bool dtk = path.size() > 3 && path.compare(path.size() - 3, 3, ".3d") == 0;
  if (dtk && !truth.name.empty()) throw std::runtime_error(path + ": a 3DTK scan has no truth field");
  return dtk ? read3dtk(path) : readPcd(path, truth);
}

OrganizedCloud reversedLines(const OrganizedCloud& c, bool rows) {
  OrganizedCloud r = c;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const std::size_t from = static_cast<std::size_t>(y) * c.width + x;
      const std::size_t to = rows ? static_cast<std::size_t>(c.height - 1 - y) * c.width + x
                                  : static_cast<std::size_t>(y) * c.width + (c.width - 1 - x);
      r.points[to] = c.points[from];
      if (!c.truth.empty()) r.truth[to] = c.truth[from];
    }
  return r;
}

}  // namespace io
}  // namespace tilt_laser_perception
