#include "tilt_laser_perception/core/polyline_split.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace tilt_laser_perception {
namespace core {

namespace {
/// splitPolyline's buffers, kept between calls (an organized cloud splits
/// hundreds of lines): the points relative to the origin, one array a
/// coordinate, so that a run's search runs four floats an instruction.
struct SplitWork {
  Eigen::ArrayXf x, y, z, c;
  std::vector<float> r;  // ranges; NaN: no return
  std::vector<std::pair<int, int>> stack, pieces;
};
}  // namespace

void splitPolyline(const std::vector<Eigen::Vector3f>& pts, const Eigen::Vector3d& origin, const SplitParams& p,
                   int line, std::vector<Segment3>& out) {
  thread_local SplitWork w;
  const int n = static_cast<int>(pts.size());
  w.x.resize(n);
  w.y.resize(n);
  w.z.resize(n);
  w.c.resize(n);
  w.r.resize(n);
  const Eigen::Vector3f o = origin.cast<float>();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3f d = pts[i] - o;
    w.x[i] = d.x();
    w.y[i] = d.y();
    w.z[i] = d.z();
    w.r[i] = d.allFinite() ? d.norm() : std::numeric_limits<float>::quiet_NaN();
  }
  const auto emit = [&](int a, int b) {
    Segment3 s;
    if (b - a + 1 >= p.min_points && makeSegment3(pts, w.r, line, a, b, s)) {
      s.origin = origin;
      out.push_back(s);
    }
  };
  int start = -1;
  for (int i = 0; i <= n; ++i) {
    const bool good = i < n && std::isfinite(w.r[i]);
    bool ends = start >= 0 && !good;
    if (start >= 0 && good && std::abs(w.r[i] - w.r[i - 1]) > p.jumpThreshold(std::min(w.r[i], w.r[i - 1])))
      ends = true;
    if (ends) {
      // Farthest-point split of the run [start, i - 1].
      w.stack.assign(1, {start, i - 1});
      w.pieces.clear();
      while (!w.stack.empty()) {
        const auto [a, b] = w.stack.back();
        w.stack.pop_back();
        int k = -1;
        double dmax = 0.0;
        if (b - a >= 2) {
          // Farthest point from the chord: the largest squared |cross
          // product| over the run's inner points, one root and one division
          // at the end.
          const int m = b - a - 1;
          const float ax = w.x[a], ay = w.y[a], az = w.z[a];
          const float ux = w.x[b] - ax, uy = w.y[b] - ay, uz = w.z[b] - az;
          const float len = std::sqrt(ux * ux + uy * uy + uz * uz);
          const auto px = w.x.segment(a + 1, m) - ax, py = w.y.segment(a + 1, m) - ay, pz = w.z.segment(a + 1, m) - az;
          auto c = w.c.head(m);
          if (len > 0.0f)
            c = (uy * pz - uz * py).square() + (uz * px - ux * pz).square() + (ux * py - uy * px).square();
          else
            c = px.square() + py.square() + pz.square();
          const float cmax = c.maxCoeff();
          k = a + 1 + static_cast<int>(std::find(c.data(), c.data() + m, cmax) - c.data());
          dmax = len > 0.0f ? std::sqrt(static_cast<double>(cmax)) / len : std::sqrt(static_cast<double>(cmax));
        }
        if (k >= 0 && dmax > p.threshold(w.r[k])) {
          w.stack.emplace_back(k + 1, b);
          w.stack.emplace_back(a, k);
        } else {
          w.pieces.emplace_back(a, b);
        }
      }
      for (const auto& [a, b] : w.pieces) emit(a, b);
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
