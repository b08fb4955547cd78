#include "tilt_laser_perception/core/polyline_split.hpp"
#include "tilt_laser_perception/core/in_halves.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <thread>

#include <Eigen/Eigenvalues>

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

/// The moments of the run's points [a, b] relative to the origin (a run's
/// points all have a return).
Moments3 runMoments(const SplitWork& w, int a, int b) {
  Moments3 m;
  for (int i = a; i <= b; ++i) m.add(Eigen::Vector3d(w.x[i], w.y[i], w.z[i]));
  return m;
}

/// A line through the moments' points: centroid, unit direction and the
/// points' sum of squares along it.
void lineThrough(const Moments3& m, Eigen::Vector3d& c, Eigen::Vector3d& d, double& along) {
  c = m.mean();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(m.ss - m.n * c * c.transpose());
  d = es.eigenvectors().col(2);
  along = es.eigenvalues()(2);
}

/// Neighbouring pieces merged again as the 2D split merges them
/// (ScanSplitter::mergeable, piecesMeet): their union within d_T of its
/// least-squares line, the second not folding back over the first along it,
/// and the shorter one's mean on the longer one's line within what the two
/// fits leave uncertain.
void mergePieces(SplitWork& w, const SplitParams& p) {
  if (w.pieces.size() < 2) return;
  const auto point = [&](int i) { return Eigen::Vector3d(w.x[i], w.y[i], w.z[i]); };
  const auto mergeable = [&](int a, int split, int b) {
    Moments3 ml = runMoments(w, a, split), ms = runMoments(w, split + 1, b);
    Moments3 mu = ml;
    mu += ms;
    Eigen::Vector3d c, d;
    double along = 0.0;
    lineThrough(mu, c, d, along);
    if (d.dot(point(b) - point(a)) < 0.0) d = -d;
    double reach = -std::numeric_limits<double>::infinity();
    for (int i = a; i <= b; ++i) {
      const Eigen::Vector3d q = point(i) - c;
      if ((q - d * d.dot(q)).norm() > p.threshold(w.r[i])) return false;
      if (i <= split) reach = std::max(reach, d.dot(point(i)));
      else if (reach - d.dot(point(i)) > p.threshold(w.r[i])) return false;
    }
    if (ml.n < 3.0 || ms.n < 3.0) return true;
    if (ms.n > ml.n) std::swap(ml, ms);
    lineThrough(ml, c, d, along);
    const Eigen::Vector3d q = ms.mean() - c;
    const double t = d.dot(q);
    return onOneLine((q - d * t).norm(), t, ml.n, along, ms.n, p.threshold(ms.mean().norm()));
  };
  std::size_t k = 0;
  for (std::size_t i = 1; i < w.pieces.size(); ++i) {
    if (mergeable(w.pieces[k].first, w.pieces[k].second, w.pieces[i].second)) w.pieces[k].second = w.pieces[i].second;
    else w.pieces[++k] = w.pieces[i];
  }
  w.pieces.resize(k + 1);
}
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
  }
  // The ranges, several an instruction; a point with a NaN or an infinite
  // coordinate has none (NaN).
  Eigen::Map<Eigen::ArrayXf> r(w.r.data(), n);
  r = (w.x.square() + w.y.square() + w.z.square()).sqrt();
  r = (r < std::numeric_limits<float>::infinity()).select(r, std::numeric_limits<float>::quiet_NaN());
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
      if (p.merge) mergePieces(w, p);
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

namespace {
/// The median angle [rad] between neighbouring points (i - di, j - dj) and
/// (i, j) as seen from `o`, over points sampled every `stride` rows and
/// columns; 0 when fewer than 100 such pairs have both a return.
double medianNeighbourAngle(const std::vector<Eigen::Vector3f>& points, int width, int height, int di, int dj,
                            const Eigen::Vector3f& o, int stride) {
  // A point's direction, or none (no return, or the origin itself).
  const auto dir = [&](std::size_t i, Eigen::Vector3f& u) {
    const float r = points[i].allFinite() ? (points[i] - o).norm() : 0.0f;
    if (!(r > 0.0f) || !std::isfinite(r)) return false;
    u = (points[i] - o) / r;
    return true;
  };
  // The chord between the two directions, which grows with the angle: the
  // median chord gives the median angle.
  std::vector<float> e;
  Eigen::Vector3f ua, ub;
  for (int i = di; i < height; i += stride)
    for (int j = dj; j < width; j += stride)
      if (dir(static_cast<std::size_t>(i - di) * width + (j - dj), ua) && dir(static_cast<std::size_t>(i) * width + j, ub))
        e.push_back((ua - ub).norm());
  if (e.size() < 100) return 0.0;
  auto mid = e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2);
  std::nth_element(e.begin(), mid, e.end());
  return 2.0 * std::asin(std::min(1.0, 0.5 * static_cast<double>(*mid)));
}

/// A grid stride that samples about n of the points.
int strideFor(std::size_t points, double n) {
  return std::max(1, static_cast<int>(std::sqrt(static_cast<double>(points) / n)));
}
}  // namespace

int organizedLineStep(const std::vector<Eigen::Vector3f>& points, int width, int height, bool rows,
                      const Eigen::Vector3d& origin, double line_spacing) {
  const int lines = rows ? height : width;
  if (!(line_spacing > 0.0) || lines < 3) return 1;
  // Across the lines, from about 2,000 pairs.
  const double across = medianNeighbourAngle(points, width, height, rows ? 1 : 0, rows ? 0 : 1, origin.cast<float>(),
                                             strideFor(points.size(), 2000.0));
  if (!(across > 0.0)) return 1;
  // 1 % of slack: 0.5 degrees over lines 0.1 degrees apart is 5 lines.
  return std::clamp(static_cast<int>(std::floor(1.01 * line_spacing / across)), 1, (lines - 1) / 2);
}

namespace {
/// Joins a thread when it goes out of scope: before the stack the thread
/// uses unwinds, should the code beside it throw (segmentOrganized's
/// splitter, which runs beside the grouping).
struct Joiner {
  std::thread& t;
  ~Joiner() {
    if (t.joinable()) t.join();
  }
};

/// The points first..end-1 of a line between two grouped ones whose column
/// neighbours there are of planes a and b: each joins the nearer of the two
/// (a when as near; the plane of label 0 is infinitely far), if within the
/// distance max(min2, ratio2 * R^2) (squared); a point with no return (NaN)
/// compares false and joins nothing. One pair of planes, no branch: the
/// loop runs several points an instruction. Points xyz at pts + 3 * i *
/// stride (kStride, when not 0, is stride known at compile time); labels at
/// out + i * stride. The points that joined a and b.
template <int kStride, bool kOnePlane>
std::pair<int, int> joinRun(const float* pts, std::uint32_t* out, int first, int end, std::size_t stride,
                            std::uint32_t a, std::uint32_t b, const Eigen::Vector4f& pa, const Eigen::Vector4f& pb,
                            float ox, float oy, float oz, float min2, float ratio2) {
  const std::size_t st = kStride ? static_cast<std::size_t>(kStride) : stride;
  int na = 0, nb = 0;
  for (int i = first; i < end; ++i) {
    const float* pt = pts + 3 * st * static_cast<std::size_t>(i);
    const float x = pt[0] - ox, y = pt[1] - oy, z = pt[2] - oz;
    const float ea = pa[0] * x + pa[1] * y + pa[2] * z - pa[3];
    const float eb = kOnePlane ? ea : pb[0] * x + pb[1] * y + pb[2] * z - pb[3];
    const float da = ea * ea, db = eb * eb;
    const bool near_b = db < da;
    const bool in = std::min(da, db) <= std::max(min2, ratio2 * (x * x + y * y + z * z));
    out[st * static_cast<std::size_t>(i)] = in ? (near_b ? b : a) : 0u;
    na += in & !near_b;
    nb += in & near_b;
  }
  return {na, nb};
}
}  // namespace

void segmentOrganized(const std::vector<Eigen::Vector3f>& points, int width, int height, bool rows,
                      const Eigen::Vector3d& origin, const SplitParams& split, const GroupingParams& grouping,
                      std::vector<Plane>& planes, std::vector<std::uint32_t>& labels, int line_step,
                      OrganizedTimes* times, int threads) {
  using Clock = std::chrono::steady_clock;
  const auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  OrganizedTimes local;
  OrganizedTimes& tm = times ? *times : local;
  tm = OrganizedTimes();
  const int lines = rows ? height : width;
  const int length = rows ? width : height;
  const int step = std::clamp(line_step, 1, std::max(1, lines - 1));
  const auto index = [&](int line, int i) {
    return rows ? static_cast<std::size_t>(line) * width + i : static_cast<std::size_t>(i) * width + line;
  };
  // The lines grouped: every step-th and the last; the grouper numbers them 0, 1, ...
  std::vector<int> grouped;
  for (int l = 0; l < lines; l += step) grouped.push_back(l);
  if (grouped.back() != lines - 1) grouped.push_back(lines - 1);
  const int n_grouped = static_cast<int>(grouped.size());
  ScanLineGrouper g(grouping);
  g.reset(origin);
  g.setThreads(threads >= 2 ? 2 : 1);
  // Each line's points kept: finish() cuts the segments that cross a crease by them.
  std::vector<std::vector<Eigen::Vector3f>> line_pts(n_grouped);
  std::vector<std::vector<Segment3>> line_segs(n_grouped);
  const auto splitLine = [&](int j) {
    line_pts[j].resize(length);
    for (int i = 0; i < length; ++i) line_pts[j][i] = points[index(grouped[j], i)];
    splitPolyline(line_pts[j], origin, split, j, line_segs[j]);
  };
  // Two threads: one splits the lines, then clears the labels while the
  // finish runs; the other adds each line as soon as it is split.
  const bool two = threads >= 2 && n_grouped >= 4;
  std::thread splitter;
  std::atomic<int> ready{0};  // the lines split
  const Joiner join_splitter{splitter};
  if (two) {
    splitter = std::thread([&] {
      const auto t0 = Clock::now();
      for (int j = 0; j < n_grouped; ++j) {
        splitLine(j);
        ready.store(j + 1, std::memory_order_release);
      }
      tm.split = since(t0);
      labels.assign(points.size(), 0);
    });
    const auto t1 = Clock::now();
    for (int j = 0; j < n_grouped; ++j) {
      while (ready.load(std::memory_order_acquire) <= j) std::this_thread::yield();
      g.addLine(line_segs[j]);
    }
    tm.add = since(t1);
  } else {
    for (int j = 0; j < n_grouped; ++j) {
      const auto t0 = Clock::now();
      splitLine(j);
      const auto t1 = Clock::now();
      g.addLine(line_segs[j]);
      tm.split += std::chrono::duration<double>(t1 - t0).count();
      tm.add += since(t1);
    }
    labels.assign(points.size(), 0);
  }
  const auto t2 = Clock::now();
  g.finish(planes, [&](int j) { return &line_pts[j]; });
  tm.finish = since(t2);
  if (splitter.joinable()) splitter.join();
  // A line's i-th point at base(line) + i * stride.
  const std::size_t stride = rows ? 1 : static_cast<std::size_t>(width);
  const auto base = [&](int line) { return index(line, 0); };
  const std::vector<Segment3>& segs = g.segments();
  for (const Plane& p : planes) {
    const auto label = static_cast<std::uint32_t>(p.id + 1);
    for (int m : p.members) {
      const Segment3& s = segs[m];
      std::uint32_t* out = labels.data() + base(grouped[s.line]);
      for (int i = s.first; i <= s.last; ++i) out[i * stride] = label;
    }
  }
  if (step == 1) return;
  const auto t3 = Clock::now();
  // The lines between two grouped ones: a point joins the plane of the
  // grouped point before or after it in its column that it lies within the
  // grouping's distance of (the nearer of two), as a segment joins a plane.
  // Planes as n . q = offset, q relative to the origin; by label. Label 0,
  // none, is infinitely far from every point.
  std::uint32_t max_label = 0;
  for (const Plane& p : planes) max_label = std::max(max_label, static_cast<std::uint32_t>(p.id + 1));
  std::vector<Eigen::Vector4f> plane_of(max_label + 1, Eigen::Vector4f::Zero());
  plane_of[0][3] = std::numeric_limits<float>::infinity();
  for (const Plane& p : planes)
    plane_of[p.id + 1] << p.fit.normal.cast<float>(), static_cast<float>(p.fit.normal.dot(p.fit.centroid - origin));
  const float ox = static_cast<float>(origin.x()), oy = static_cast<float>(origin.y()),
              oz = static_cast<float>(origin.z());
  const float min2 = static_cast<float>(grouping.dist_min * grouping.dist_min);
  const float ratio2 = static_cast<float>(grouping.dist_ratio * grouping.dist_ratio);
  // The lines between grouped lines j0 .. j1 - 1 and the next; the points
  // that joined each plane counted into `joined`.
  const auto joinBetween = [&](int j0, int j1, std::vector<int>& joined) {
    // The columns of two grouped lines as runs of one label pair [first, end).
    struct Run {
      int first, end;
      std::uint32_t a, b;
    };
    std::vector<Run> runs;
    for (int j = j0; j < j1; ++j) {
      const std::uint32_t* before = labels.data() + base(grouped[j]);
      const std::uint32_t* after = labels.data() + base(grouped[j + 1]);
      runs.clear();
      Run run{0, 0, 0, 0};  // the current one, kept when it holds a plane
      for (int i = 0; i < length; ++i) {
        const std::uint32_t a = before[i * stride], b = after[i * stride];
        if (a == run.a && b == run.b) continue;
        run.end = i;
        if (run.a | run.b) runs.push_back(run);
        run = {i, i, a, b};
      }
      run.end = length;
      if (run.a | run.b) runs.push_back(run);
      for (const Run& run : runs) {
        const std::uint32_t a = run.a, b = run.b;
        const Eigen::Vector4f pa = plane_of[a], pb = plane_of[b];
        for (int l = grouped[j] + 1; l < grouped[j + 1]; ++l) {
          const float* pts = points[base(l)].data();
          std::uint32_t* out = labels.data() + base(l);
          const auto [na, nb] =
              stride == 1 ? (a == b ? joinRun<1, true> : joinRun<1, false>)(pts, out, run.first, run.end, 1, a, b, pa,
                                                                            pb, ox, oy, oz, min2, ratio2)
                          : (a == b ? joinRun<0, true> : joinRun<0, false>)(pts, out, run.first, run.end, stride, a,
                                                                            b, pa, pb, ox, oy, oz, min2, ratio2);
          joined[a] += na;
          joined[b] += nb;
        }
      }
    }
  };
  // With two threads each its half of the lines: they write apart.
  std::vector<int> joined(max_label + 1, 0), joined_second(max_label + 1, 0);
  inHalves(static_cast<std::size_t>(n_grouped - 1), two, [&](std::size_t b, std::size_t e, int half) {
    joinBetween(static_cast<int>(b), static_cast<int>(e), half ? joined_second : joined);
  });
  for (std::size_t i = 0; i < joined.size(); ++i) joined[i] += joined_second[i];
  for (Plane& p : planes) p.points += joined[p.id + 1];
  tm.between = since(t3);
}

CloudNoise estimateCloudNoise(const std::vector<Eigen::Vector3f>& points, int width, int height, bool lines_are_rows,
                              const Eigen::Vector3d& origin) {
  CloudNoise out;
  if (width < 3 && height < 3) return out;
  const Eigen::Vector3f o = origin.cast<float>();
  // A point's range (NaN: none), for the points sampled only.
  const auto range = [&](std::size_t i) {
    const float r = points[i].allFinite() ? (points[i] - o).norm() : 0.0f;
    return r > 0.0f && std::isfinite(r) ? r : std::numeric_limits<float>::quiet_NaN();  // the origin has no direction
  };
  // About 20,000 samples a direction are plenty for a median; a large cloud
  // is sampled on a grid.
  const int stride = strideFor(points.size(), 20000.0);
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
  const double rows = sigmaOf(0, 1), columns = sigmaOf(1, 0);
  out.sigma = std::max(rows, columns);
  out.along = lines_are_rows ? rows : columns;
  out.step = medianNeighbourAngle(points, width, height, lines_are_rows ? 0 : 1, lines_are_rows ? 1 : 0, o, stride);
  return out;
}

double estimateLineSigma(const std::vector<Eigen::Vector3f>& points, int width, int height, bool lines_are_rows,
                         const Eigen::Vector3d& origin, int step) {
  constexpr int kLines = 3, kHalf = 4;  // the plane of three lines before, over nine beams
  const int lines = lines_are_rows ? height : width, beams = lines_are_rows ? width : height;
  step = std::max(1, step);
  if (lines <= kLines * step || beams <= 2 * kHalf) return 0.0;
  const auto at = [&](int line, int beam) -> const Eigen::Vector3f& {
    return points[lines_are_rows ? static_cast<std::size_t>(line) * width + beam
                                 : static_cast<std::size_t>(beam) * width + line];
  };
  // About 300 patches give the median to about 7 % (and cost about 0.2 ms on a 500 x 500 cloud).
  const double patches = static_cast<double>(lines) * beams / 3.0;
  const int stride = std::max(1, static_cast<int>(std::sqrt(patches / 300.0)));
  std::vector<float> offset, split;
  for (int i = kLines * step; i < lines; i += stride)
    for (int j = kHalf; j + kHalf < beams; j += 3 * stride) {
      Moments3 m;
      bool ok = true;
      for (int k = 1; k <= kLines && ok; ++k)
        for (int b = j - kHalf; b <= j + kHalf && ok; ++b) {
          const Eigen::Vector3f& p = at(i - k * step, b);
          ok = p.allFinite();
          if (ok) m.add(p.cast<double>() - origin);
        }
      if (!ok) continue;
      const PlaneFit f = fitPlane(m);
      if (f.rms > 0.03 || f.spread(1) < 0.01) continue;  // an edge or a fold; lines too close to fix a normal
      // The line's nine points against that plane: their mean offset, and
      // the difference of its odd and even beams' means, in which the line's
      // own pose (common to all its points) cancels and range noise stays.
      double sum[2] = {0.0, 0.0}, range = 0.0;
      for (int b = j - kHalf; b <= j + kHalf && ok; ++b) {
        const Eigen::Vector3f& p = at(i, b);
        ok = p.allFinite();
        if (!ok) break;
        const Eigen::Vector3d q = p.cast<double>() - origin;
        sum[(b - j) & 1] += f.normal.dot(q) - f.offset;
        range += q.norm();
      }
      if (!ok || !(range > 0.0)) continue;
      range /= 2 * kHalf + 1;
      offset.push_back(static_cast<float>(std::abs(sum[0] + sum[1]) / (2 * kHalf + 1) / range));
      split.push_back(static_cast<float>(std::abs(sum[1] / kHalf - sum[0] / (kHalf + 1)) / range));
    }
  if (offset.size() < 100) return 0.0;
  const auto robustSigma = [](std::vector<float>& v) {
    auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return 1.4826 * *mid;
  };
  const double so = robustSigma(offset), sd = robustSigma(split);
  // Range noise sigma_r (relative) gives the offset sigma_r^2 (1/9 + 1/27 + 4/18): the nine points' mean against
  // the plane of 27 on three lines, extrapolated two line spacings from their middle; and the odd-even
  // difference sigma_r^2 (1/4 + 1/5).
  const double noise_share = (1.0 / 9.0 + 1.0 / 27.0 + 4.0 / 18.0) / (1.0 / 4.0 + 1.0 / 5.0);
  return std::sqrt(std::max(0.0, so * so - noise_share * sd * sd));
}

SweepNoiseEstimate estimateSweepNoise(const SweepResult& sweep) {
  SweepNoiseEstimate out;
  std::size_t width = 0;
  for (const SweepLine& l : sweep.lines) width = std::max(width, l.points.size());
  if (width == 0) return out;
  std::vector<Eigen::Vector3f> points(width * sweep.lines.size(),
                                      Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  for (std::size_t r = 0; r < sweep.lines.size(); ++r)
    std::copy(sweep.lines[r].points.begin(), sweep.lines[r].points.end(), points.begin() + r * width);
  const int w = static_cast<int>(width), h = static_cast<int>(sweep.lines.size());
  const Eigen::Vector3d origin = meanOrigin(sweep);
  out.range = estimateCloudNoise(points, w, h, true, origin);
  if (sweep.lines.size() >= 4) out.line_sigma = estimateLineSigma(points, w, h, true, origin);
  return out;
}

double scaleTolerancesToNoise(const CloudNoise& noise, SplitParams& split, GroupingParams& grouping) {
  const double k = noise.sigma > 0.0 ? std::clamp(noise.sigma / kDefaultToleranceNoise, 0.2, 1.0) : 1.0;
  split.d_min *= k;
  const double zeta = std::min(split.zeta, std::max(k * split.zeta, 0.5 * noise.step));
  // The split leaves a segment's points up to zeta x range off its chord:
  // the grouping's distance grows with range as the split's does.
  grouping.dist_ratio = std::max(k * grouping.dist_ratio, zeta);
  split.zeta = zeta;
  grouping.dist_min *= k;
  grouping.centroid_min *= k;
  grouping.centroid_ratio *= k;
  return k;
}

}  // namespace core
}  // namespace tilt_laser_perception
