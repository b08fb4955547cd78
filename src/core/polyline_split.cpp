#include "tilt_laser_perception/core/polyline_split.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace tilt_laser_perception {
namespace core {

void splitPolyline(const std::vector<Eigen::Vector3f>& pts, const Eigen::Vector3d& origin, const SplitParams& p,
                   int line, std::vector<Segment3>& out) {
  const int n = static_cast<int>(pts.size());
  std::vector<double> r(n, 0.0);
  std::vector<char> ok(n, 0);
  std::vector<Eigen::Vector3d> pd(n);
  for (int i = 0; i < n; ++i) {
    ok[i] = std::isfinite(pts[i].x()) && std::isfinite(pts[i].y()) && std::isfinite(pts[i].z());
    pd[i] = pts[i].cast<double>();
    if (!ok[i]) pd[i].setConstant(std::numeric_limits<double>::quiet_NaN());
    if (ok[i]) r[i] = (pd[i] - origin).norm();
  }
  const auto P = [&](int i) { return pd[i]; };
  const auto emit = [&](int a, int b) {
    Segment3 s;
    if (b - a + 1 >= p.min_points && makeSegment3(pd, r, line, a, b, s)) {
      s.origin = origin;
      out.push_back(s);
    }
  };
  std::vector<std::pair<int, int>> stack;
  int start = -1;
  for (int i = 0; i <= n; ++i) {
    const bool good = i < n && ok[i];
    bool ends = start >= 0 && !good;
    if (start >= 0 && good && std::abs(r[i] - r[i - 1]) > p.jumpThreshold(std::min(r[i], r[i - 1]))) ends = true;
    if (ends) {
      // Farthest-point split of the run [start, i - 1].
      stack.assign(1, {start, i - 1});
      std::vector<std::pair<int, int>> pieces;
      while (!stack.empty()) {
        const auto [a, b] = stack.back();
        stack.pop_back();
        int k = -1;
        double dmax = 0.0;
        if (b - a >= 2) {
          // Farthest point from the chord: the largest squared |cross product|,
          // one root and one division at the end.
          const Eigen::Vector3d pa = P(a), ab = P(b) - pa;
          const double len = ab.norm();
          double cmax = 0.0;
          for (int j = a + 1; j < b; ++j) {
            const double c = len > 0 ? ab.cross(P(j) - pa).squaredNorm() : (P(j) - pa).squaredNorm();
            if (c > cmax) {
              cmax = c;
              k = j;
            }
          }
          dmax = len > 0 ? std::sqrt(cmax) / len : std::sqrt(cmax);
        }
        if (k >= 0 && dmax > p.threshold(r[k])) {
          stack.emplace_back(k + 1, b);
          stack.emplace_back(a, k);
        } else {
          pieces.emplace_back(a, b);
        }
      }
      for (const auto& [a, b] : pieces) emit(a, b);
      start = -1;
    }
    if (good && start < 0) start = i;
  }
}

}  // namespace core
}  // namespace tilt_laser_perception

namespace tilt_laser_perception {
namespace core {

void segmentOrganized(const std::vector<Eigen::Vector3f>& points, int width, int height, bool rows,
                      const Eigen::Vector3d& origin, const SplitParams& split, const GroupingParams& grouping,
                      std::vector<Plane>& planes, std::vector<std::uint32_t>& labels) {
  const int lines = rows ? height : width;
  const int length = rows ? width : height;
  const auto index = [&](int line, int i) {
    return rows ? static_cast<std::size_t>(line) * width + i : static_cast<std::size_t>(i) * width + line;
  };
  ScanLineGrouper g(grouping);
  g.reset(origin);
  // Each line's points kept: finish() cuts the segments that cross a crease by them.
  std::vector<std::vector<Eigen::Vector3f>> line_pts(lines, std::vector<Eigen::Vector3f>(length));
  std::vector<Segment3> segs;
  for (int l = 0; l < lines; ++l) {
    for (int i = 0; i < length; ++i) line_pts[l][i] = points[index(l, i)];
    segs.clear();
    splitPolyline(line_pts[l], origin, split, l, segs);
    g.addLine(segs);
  }
  g.finish(planes, [&](int line) { return &line_pts[line]; });
  labels.assign(points.size(), 0);
  for (const Plane& p : planes)
    for (int m : p.members) {
      const Segment3& s = g.segments()[m];
      for (int i = s.first; i <= s.last; ++i) labels[index(s.line, i)] = static_cast<std::uint32_t>(p.id + 1);
    }
}

CloudNoise estimateCloudNoise(const std::vector<Eigen::Vector3f>& points, int width, int height, bool lines_are_rows,
                              const Eigen::Vector3d& origin) {
  CloudNoise out;
  if (width < 3 && height < 3) return out;
  const Eigen::Vector3f o = origin.cast<float>();
  // A point's range (NaN: none) and direction, for the points sampled only.
  const auto range = [&](std::size_t i) {
    const float r = points[i].allFinite() ? (points[i] - o).norm() : 0.0f;
    return r > 0.0f && std::isfinite(r) ? r : std::numeric_limits<float>::quiet_NaN();  // the origin has no direction
  };
  const auto dir = [&](std::size_t i, float r) { return Eigen::Vector3f((points[i] - o) / r); };
  // About 20,000 samples a direction are plenty for a median; a large cloud
  // is sampled on a grid.
  const int stride = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(points.size()) / 20000.0)));
  std::vector<float> e;
  const auto median = [&](std::size_t min_count) {
    if (e.size() < min_count) return 0.0;
    auto mid = e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2);
    std::nth_element(e.begin(), mid, e.end());
    return static_cast<double>(*mid);
  };
  const auto at = [&](int i, int j) { return static_cast<std::size_t>(i) * width + j; };
  const auto sigmaOf = [&](int di, int dj) {
    e.clear();
    for (int i = di; i + di < height; i += stride)
      for (int j = dj; j + dj < width; j += stride) {
        const float a = range(at(i - di, j - dj)), b = range(at(i, j)), c = range(at(i + di, j + dj));
        if (std::isfinite(a) && std::isfinite(b) && std::isfinite(c)) e.push_back(std::abs(b - 0.5f * (a + c)));
      }
    return 1.4826 * median(100) / std::sqrt(1.5);
  };
  out.sigma = std::max(sigmaOf(0, 1), sigmaOf(1, 0));
  e.clear();
  const int di = lines_are_rows ? 0 : 1, dj = lines_are_rows ? 1 : 0;  // along a line
  for (int i = di; i < height; i += stride)
    for (int j = dj; j < width; j += stride) {
      const std::size_t ia = at(i - di, j - dj), ib = at(i, j);
      const float ra = range(ia), rb = range(ib);
      if (std::isfinite(ra) && std::isfinite(rb)) {
        const Eigen::Vector3f ua = dir(ia, ra), ub = dir(ib, rb);
        e.push_back(std::atan2(ua.cross(ub).norm(), ua.dot(ub)));
      }
    }
  out.step = median(100);
  return out;
}

double scaleTolerancesToNoise(const CloudNoise& noise, SplitParams& split, GroupingParams& grouping) {
  const double k = noise.sigma > 0.0 ? std::clamp(noise.sigma / kDefaultToleranceNoise, 0.2, 1.0) : 1.0;
  split.d_min *= k;
  split.zeta = std::min(split.zeta, std::max(k * split.zeta, 0.5 * noise.step));
  grouping.dist_min *= k;
  grouping.dist_ratio *= k;
  grouping.centroid_min *= k;
  grouping.centroid_ratio *= k;
  return k;
}

}  // namespace core
}  // namespace tilt_laser_perception
