#include "tilt_laser_perception/core/grouping.hpp"
#include "tilt_laser_perception/core/in_halves.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <tuple>

namespace tilt_laser_perception {
namespace core {

namespace {
constexpr double kDeg = M_PI / 180.0;
/// Two segments seed a plane only if the shorter lies beside this much of
/// the longer at least: a short piece at a long line's end (a tread's piece
/// under a riser's first line) tilts the plane they span, and the long line
/// does better to wait for the next line. (The stairs: 13.71 -> 13.89 of 14
/// faces over 20 seeds; 0.2: 13.85, 0.45: 13.77.)
constexpr double kMinSeedOverlap = 0.3;
/// Where two planes meet a beam's ray within this of each other, the ray
/// does not tell which surface it hit [m].
constexpr double kCreaseMargin = 0.01;
/// A crease cut takes a run of beams with at least this many votes net (a
/// line's few floor points at a box side's foot: seeds 1-20 and 21-40 one
/// more face each than with 8, nothing lost).
constexpr double kMinCutVotes = 4.0;
/// A run of a plane's segment cut out to seed a plane with a lone segment
/// of the next line lies beside this much of it at least: both lines cross
/// the same face (a riser), not a corner (short pieces at a box's corner
/// span small tilted planes).
constexpr double kMinLoneCover = 0.8;

/// Area of a polygon given in the plane (u, v) coordinates of a fit.
double polygonArea(const std::vector<Eigen::Vector3d>& poly, const PlaneFit& f) {
  if (poly.size() < 3) return 0.0;
  const Eigen::Vector3d u = f.normal.unitOrthogonal();
  const Eigen::Vector3d v = f.normal.cross(u);
  double a = 0.0;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector3d& p = poly[i];
    const Eigen::Vector3d& q = poly[(i + 1) % poly.size()];
    a += p.dot(u) * q.dot(v) - q.dot(u) * p.dot(v);
  }
  return 0.5 * std::abs(a);
}

/// Area between the chords left[k]-right[k] of successive lines, strip by
/// strip, in the plane of a fit. The polygon they bound (lefts, then rights
/// back) has that area while the lines run side by side; a spinning head's
/// lines all cross where its axis meets a surface, and two chords that cross
/// bound two triangles, which the polygon's signed area would subtract.
double stripArea(const std::vector<Eigen::Vector3d>& left, const std::vector<Eigen::Vector3d>& right,
                 const PlaneFit& f) {
  const Eigen::Vector3d u = f.normal.unitOrthogonal();
  const Eigen::Vector3d v = f.normal.cross(u);
  const auto at = [&](const Eigen::Vector3d& p) { return Eigen::Vector2d(p.dot(u), p.dot(v)); };
  const auto cross = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); };
  const auto tri = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    return 0.5 * std::abs(cross(b - a, c - a));
  };
  double area = 0.0;
  Eigen::Vector2d x;
  for (std::size_t k = 0; k + 1 < left.size(); ++k) {
    const Eigen::Vector2d a0 = at(left[k]), b0 = at(right[k]), a1 = at(left[k + 1]), b1 = at(right[k + 1]);
    if (chordsCross(a0, b0, a1, b1, x)) {
      area += tri(a0, x, a1) + tri(x, b0, b1);
    } else {
      area += 0.5 * std::abs(cross(b0 - a0, b1 - a0) + cross(b1 - a0, a1 - a0));
    }
  }
  return area;
}

/// Two parallel lines share any plane through both, so segments of two lines
/// seed a plane only side by side: one overlaps the other in beam index by
/// half its own length or more. The fraction of the longer one overlapped,
/// or -1 when they are not side by side.
double sideBySide(const Segment3& a, const Segment3& b) {
  const int ov = std::min(a.last, b.last) - std::max(a.first, b.first) + 1;
  const int la = a.last - a.first + 1, lb = b.last - b.first + 1;
  if (ov < 0.5 * std::min(la, lb)) return -1.0;
  return static_cast<double>(ov) / std::max(la, lb);
}

/// A seed's score, lowest best: the next line, overlapping the whole of the
/// longer segment, coplanar (rms against the threshold `thr`).
double seedScore(int line_gap, double overlap, double rms, double thr) {
  return 2.0 * (line_gap - 1) + (1.0 - overlap) + rms / thr;
}

template <class Segs>
int countLines(const std::vector<int>& members, const Segs& segs) {
  int n = 0, last = -1;
  for (int m : members)  // sorted by index, so by line
    if (segs[m].line != last) {
      ++n;
      last = segs[m].line;
    }
  return n;
}

/// Whether two segments come within `limit` of each other, judged by their
/// end points and centroids: enough to tell neighbours from strangers.
bool near(const Segment3& a, const Segment3& b, double limit) {
  const double l2 = limit * limit;
  const auto close = [l2](const Eigen::Vector3d& x, const Eigen::Vector3d& y) { return (x - y).squaredNorm() <= l2; };
  // The ends first (neighbouring lines' ends are usually close), the centroids only if not.
  if (close(a.start, b.start) || close(a.end, b.end) || close(a.start, b.end) || close(a.end, b.start)) return true;
  const Eigen::Vector3d ca = a.moments.mean(), cb = b.moments.mean();
  return close(ca, b.start) || close(ca, b.end) || close(a.start, cb) || close(a.end, cb) || close(ca, cb);
}

/// A segment of pts[first..last] (NaN points skipped); rangeOf(i) is point i's range.
template <class Point, class RangeOf>
bool fillSegment3(const std::vector<Point>& pts, const RangeOf& rangeOf, int line, int first, int last,
                  Segment3& s) {
  s = Segment3();
  s.line = line;
  s.first = first;
  s.last = last;
  // The moments summed by hand: the symmetric half of the outer products only.
  double n = 0, sum_r = 0, x = 0, y = 0, z = 0, xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
  for (int i = first; i <= last; ++i) {
    if (!std::isfinite(pts[i].x())) continue;
    const Eigen::Vector3d p = pts[i].template cast<double>();
    n += 1.0;
    sum_r += rangeOf(i);
    x += p.x();
    y += p.y();
    z += p.z();
    xx += p.x() * p.x();
    xy += p.x() * p.y();
    xz += p.x() * p.z();
    yy += p.y() * p.y();
    yz += p.y() * p.z();
    zz += p.z() * p.z();
  }
  if (n < 2) return false;
  s.moments.n = n;
  s.moments.s = Eigen::Vector3d(x, y, z);
  s.moments.ss << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  s.range = sum_r / s.moments.n;
  int a = first, b = last;
  while (a < b && !std::isfinite(pts[a].x())) ++a;
  while (b > a && !std::isfinite(pts[b].x())) --b;
  const Eigen::Vector3d c = s.moments.mean();
  const Eigen::Vector3d pa = pts[a].template cast<double>(), pb = pts[b].template cast<double>();
  const Eigen::Vector3d d = (pb - pa).normalized();
  s.start = c + d * d.dot(pa - c);
  s.end = c + d * d.dot(pb - c);
  return true;
}
}  // namespace

template <class Point, class Range>
bool makeSegment3(const std::vector<Point>& pts, const std::vector<Range>& ranges, int line, int first, int last,
                  Segment3& s) {
  return fillSegment3(pts, [&](int i) { return static_cast<double>(ranges[i]); }, line, first, last, s);
}

namespace {
/// The piece of s made of pts[first..last], seen from where s was; its range
/// is s's (it only sets thresholds).
bool pieceOf(const Segment3& s, const std::vector<Eigen::Vector3f>& pts, int first, int last, Segment3& piece) {
  if (last < first || !fillSegment3(pts, [&](int) { return s.range; }, s.line, first, last, piece)) return false;
  piece.origin = s.origin;
  return true;
}
}  // namespace
template bool makeSegment3(const std::vector<Eigen::Vector3d>&, const std::vector<double>&, int, int, int, Segment3&);
template bool makeSegment3(const std::vector<Eigen::Vector3f>&, const std::vector<float>&, int, int, int, Segment3&);

std::pair<std::vector<int>::const_iterator, std::vector<int>::const_iterator> ScanLineGrouper::membersIn(
    const std::vector<int>& members, int line_lo, int line_hi) const {
  // Members are segment indices in increasing order, and segments come line
  // by line: the lines' bounds are bounds on the indices themselves.
  const auto lo = std::lower_bound(members.begin(), members.end(), firstSegmentOf(line_lo));
  const auto hi = std::lower_bound(lo, members.end(), firstSegmentOf(line_hi + 1));
  return {lo, hi};
}

bool ScanLineGrouper::touch(const std::vector<int>& a, const std::vector<int>& b, double limit, const Region* ra,
                            const Region* rb) const {
  if (a.empty() || b.empty()) return false;
  const bool ca = ra && tests_.confirmed(*ra), cb = rb && tests_.confirmed(*rb);
  const int gap = params().max_line_gap + 1;
  // Two segments with a segment of either's line between them that lies
  // behind both planes: that line's rays passed where the surface would go
  // on (the floor seen between a box's top and a tread at its height). One
  // in front proves nothing (a box on a floor hides the floor behind it).
  const auto seenThrough = [&](int i, int j) {
    if (!ra || !rb) return false;
    const Eigen::Vector3d ci = segs_[i].moments.mean(), d = segs_[j].moments.mean() - ci;
    const double l2 = d.squaredNorm();
    if (!(l2 > 0.0)) return false;
    for (const auto& [k, own] : {std::pair<int, int>{i - 1, i}, {i + 1, i}, {j - 1, j}, {j + 1, j}}) {
      if (k < 0 || k >= static_cast<int>(segs_.size()) || k == i || k == j || segs_[k].line != segs_[own].line) continue;
      const Eigen::Vector3d c = segs_[k].moments.mean();
      const double t = (c - ci).dot(d) / l2;
      if (t <= 0.0 || t >= 1.0) continue;
      const double tol = params().centroidTolerance(segs_[k].range);
      const auto behind = [&](const PlaneFit& f) {
        const double side = f.normal.dot(sensor()) - f.offset >= 0.0 ? 1.0 : -1.0;
        return side * (f.normal.dot(c) - f.offset) < -tol;
      };
      if (behind(ra->fit) && behind(rb->fit)) return true;
    }
    return false;
  };
  const auto [a0, a1] = membersIn(a, segs_[b.front()].line - gap, segs_[b.back()].line + gap);
  for (auto i = a0; i != a1; ++i) {
    const auto [b0, b1] = membersIn(b, segs_[*i].line - gap, segs_[*i].line + gap);
    for (auto j = b0; j != b1; ++j)
      if (near(segs_[*i], segs_[*j], limit) && ((!ca && !cb) || (ca && tests_.endsOn(segs_[*j], *ra)) ||
                                                (cb && tests_.endsOn(segs_[*i], *rb))) &&
          !seenThrough(*i, *j))
        return true;
  }
  return false;
}

bool ScanLineGrouper::touchAcrossSeam(const std::vector<int>& a, const std::vector<int>& b, double limit) const {
  if (!params().cyclic_lines || a.empty() || b.empty() || segs_.empty()) return false;
  const int gap = params().max_line_gap + 1, last = segs_.back().line;
  const auto seam = [&](const std::vector<int>& first, const std::vector<int>& end) {
    const auto [f0, f1] = membersIn(first, 0, gap - 1);
    const auto [e0, e1] = membersIn(end, last - gap + 1, last);
    for (auto i = f0; i != f1; ++i)
      for (auto j = e0; j != e1; ++j)
        if (near(segs_[*i], segs_[*j], limit)) return true;
    return false;
  };
  return seam(a, b) || seam(b, a);
}

int ScanLineGrouper::firstSegmentOf(int line) const {
  if (line <= 0) return 0;
  return line < static_cast<int>(line_start_.size()) ? line_start_[line] : static_cast<int>(segs_.size());
}

void ScanLineGrouper::indexSegments() {
  line_start_.clear();
  spans_.clear();
  for (std::size_t i = 0; i < segs_.size(); ++i) {
    while (static_cast<int>(line_start_.size()) <= segs_[i].line) line_start_.push_back(static_cast<int>(i));
    spans_.push_back({segs_[i].line, segs_[i].first, segs_[i].last});
  }
}

void ScanLineGrouper::reset(const Eigen::Vector3d& sensor) {
  tests_ = SurfaceTests(params(), sensor);
  segs_.clear();
  line_start_.clear();
  spans_.clear();
  seg_region_.clear();
  regions_.clear();
  open_.clear();
  seg_plane_.clear();
}

bool ScanLineGrouper::fits(const Region& r, const Segment3& s, double& score, bool lone) const {
  const double thr = params().threshold(s.range);
  // A neighbour: a member of the last lines is close.
  const double limit = params().seed_gap + 0.05 * s.range;
  bool neighbour = false;
  const auto [m0, m1] = membersIn(r, s.line - params().max_line_gap, s.line + params().max_line_gap);
  for (auto it = m0; it != m1 && !neighbour; ++it) neighbour = near(segs_[*it], s, limit);
  if (!neighbour) return false;
  if (tests_.planar(r)) return tests_.onPlane(r, s, lone, score);
  // A seed (a lone segment), or a strip of lines too close together to fix
  // a normal (a slow sweep, a tilt reversal): s must lie side by side with a
  // member of the lines before, and all of them on one plane.
  if (r.members.size() == 1) return segs_[r.members[0]].line < s.line && pairs(segs_[r.members[0]], s, score);
  double best = 1e300;  // seed score without the rms term
  for (auto it = m0; it != m1; ++it) {
    const Segment3& m = segs_[*it];
    if (m.line >= s.line) continue;
    const double ov = sideBySide(m, s);
    if (ov >= 0.0) best = std::min(best, seedScore(s.line - m.line, ov, 0.0, 1.0));
  }
  if (best > 1e299) return false;
  Moments3 m = r.moments;
  m += s.moments;
  const PlaneFit f = fitPlane(m);
  const double half = 0.5 * thr;
  if (f.rms > half) return false;
  score = best + f.rms / half;
  return true;
}

void ScanLineGrouper::addMember(int region, int si) {
  Region& to = regions_[region];
  const Segment3& s = segs_[si];
  const auto at = to.members.insert(std::upper_bound(to.members.begin(), to.members.end(), si), si);
  to.moments += s.moments;
  to.rays += SurfaceTests::raysOf(s);
  to.origins += SurfaceTests::originsOf(s);
  to.fit = fitPlane(to.moments);
  to.first_line = std::min(to.first_line, s.line);
  to.last_line = std::max(to.last_line, s.line);
  if (!lineShared(to.members, at - to.members.begin())) ++to.lines;
  seg_region_[si] = region;
}

int ScanLineGrouper::newRegion(int si) {
  Region r;
  const Segment3& s = segs_[si];
  if (s.origin.allFinite()) {
    const Eigen::Vector3d n = (s.start - s.origin).cross(s.end - s.origin);
    if (n.norm() > 1e-9) r.across = n.normalized();
  }
  r.moments = s.moments;
  r.rays = SurfaceTests::raysOf(s);
  r.origins = SurfaceTests::originsOf(s);
  r.members = {si};
  r.first_line = r.last_line = s.line;
  r.lines = 1;
  r.fit = fitPlane(r.moments);
  seg_region_[si] = static_cast<int>(regions_.size());
  regions_.push_back(std::move(r));
  return seg_region_[si];
}

int ScanLineGrouper::bestFit(const Segment3& s, const std::vector<int>& among, int except, int min_lines, bool lone,
                             bool beside_only) const {
  int best = -1;
  double best_score = 1e300;
  for (const int rj : among) {
    const Region& o = regions_[rj];
    if (rj == except || o.dead || o.lines < std::max(2, min_lines)) continue;
    if (s.line < o.first_line - params().max_line_gap || s.line > o.last_line + params().max_line_gap) continue;
    bool overlap = beside_only;
    const auto [m0, m1] = membersIn(o, s.line - params().max_line_gap, s.line + params().max_line_gap);
    for (auto mi = m0; mi != m1 && !overlap; ++mi)
      overlap = spans_[*mi].first <= s.last + params().beam_slack && s.first <= spans_[*mi].last + params().beam_slack;
    double score = 0.0;
    Segment3 probe = s;
    probe.line = std::min(s.line, o.last_line + 1);  // fits() looks at the lines before the segment's
    if (overlap && fits(o, probe, score, lone) && score < best_score) {
      best = rj;
      best_score = score;
    }
  }
  return best;
}

bool ScanLineGrouper::pairs(const Segment3& a, const Segment3& b, double& score) const {
  const double ov = sideBySide(a, b);
  if (ov < kMinSeedOverlap || !near(a, b, params().seed_gap + 0.05 * b.range)) return false;
  // Across a line that saw something else beside them they lie on two
  // surfaces (a tread's piece and the riser above it), not on one that a
  // line missed.
  const int lo = std::min(a.line, b.line), hi = std::max(a.line, b.line);
  if (hi - lo > 1) {
    auto it = std::lower_bound(segs_.begin(), segs_.end(), lo + 1,
                               [](const Segment3& t, int line) { return t.line < line; });
    for (; it != segs_.end() && it->line < hi; ++it)
      if (it->moments.n >= params().min_points && it->first <= b.last && b.first <= it->last) return false;
  }
  Moments3 m = a.moments;
  m += b.moments;
  const PlaneFit f = fitPlane(m);
  const double thr = 0.5 * params().threshold(b.range);
  if (f.rms > thr) return false;
  score = seedScore(std::abs(b.line - a.line), ov, f.rms, thr);
  return true;
}

void ScanLineGrouper::settlePairs() {
  // A pair whose segments a plane of three lines or more explains is two
  // lines of different surfaces (a riser's and a tread's): take it apart.
  // So is a pair whose two lines each fit a different plane of two lines
  // (it straddles the crease between them).
  std::vector<int> planes, pairs_too;  // of three lines or more; of two or more
  for (std::size_t ri = 0; ri < regions_.size(); ++ri) {
    if (regions_[ri].dead || regions_[ri].lines < 2) continue;
    pairs_too.push_back(static_cast<int>(ri));
    if (regions_[ri].lines >= 3) planes.push_back(static_cast<int>(ri));
  }
  const std::size_t n_regions = regions_.size();
  for (std::size_t ri = 0; ri < n_regions; ++ri) {
    if (regions_[ri].dead || regions_[ri].lines != 2) continue;
    const std::vector<int> members = regions_[ri].members;
    std::vector<int> to(members.size(), -1);
    bool explained = false;
    for (std::size_t k = 0; k < members.size(); ++k) {
      to[k] = bestFit(segs_[members[k]], planes, static_cast<int>(ri), 3);
      explained = explained || to[k] >= 0;
    }
    if (!explained) {
      bool all = true, apart = false;
      for (std::size_t k = 0; k < members.size() && all; ++k) {
        to[k] = bestFit(segs_[members[k]], pairs_too, static_cast<int>(ri), 2);
        all = to[k] >= 0;
        apart = apart || (all && to[k] != to[0]);
      }
      if (!all || !apart) continue;
    }
    regions_[ri].dead = true;
    regions_[ri].members.clear();
    for (std::size_t k = 0; k < members.size(); ++k) {
      if (to[k] >= 0) addMember(to[k], members[k]);
      else newRegion(members[k]);
    }
  }
  // Segments left alone pair with the best lone segment of the lines before.
  for (std::size_t si = 0; si < segs_.size(); ++si) {
    const int ri = seg_region_[si];
    const Segment3& s = segs_[si];
    if (ri < 0 || regions_[ri].dead || regions_[ri].members.size() != 1 || s.moments.n < params().min_points) continue;
    int best = -1;
    double best_score = 1e300;
    for (std::size_t ti = si; ti-- > 0;) {
      const Segment3& t = segs_[ti];
      if (t.line >= s.line) continue;
      if (t.line < s.line - params().max_line_gap) break;
      const int rt = seg_region_[ti];
      if (rt < 0 || regions_[rt].dead || regions_[rt].members.size() != 1 || t.moments.n < params().min_points)
        continue;
      double score = 0.0;
      if (pairs(t, s, score) && score < best_score) {
        best = rt;
        best_score = score;
      }
    }
    if (best >= 0) absorb(best, ri);
  }
  pairBrokenLines();
}

void ScanLineGrouper::pairBrokenLines() {
  // A lone line beside a line that the split broke into pieces at outliers
  // (a riser seen by two lines): no piece lies beside enough of it to seed,
  // but the run of lone pieces end to end in beam order does.
  const auto lone = [&](std::size_t si) {
    const int ri = seg_region_[si];
    return ri >= 0 && !regions_[ri].dead && regions_[ri].members.size() == 1 &&
           segs_[si].moments.n >= params().min_points;
  };
  for (std::size_t ti = 0; ti < segs_.size(); ++ti) {
    if (!lone(ti)) continue;
    const Segment3& t = segs_[ti];
    std::size_t si = ti + 1;
    while (si < segs_.size() && segs_[si].line == t.line) ++si;
    while (si < segs_.size() && segs_[si].line == t.line + 1) {
      // A run of lone pieces beside t, each starting where the last ended.
      const std::size_t run0 = si;
      int covered = 0;
      Moments3 m = t.moments;
      for (; si < segs_.size() && segs_[si].line == t.line + 1; ++si) {
        const Segment3& q = segs_[si];
        if (!lone(si) || q.first > t.last || q.last < t.first || !near(t, q, params().seed_gap + 0.05 * q.range) ||
            (si > run0 && q.first > segs_[si - 1].last + params().beam_slack))
          break;
        covered += std::min(q.last, t.last) - std::max(q.first, t.first) + 1;
        m += q.moments;
      }
      const std::size_t run1 = si;
      if (run1 == run0) ++si;  // not a piece of a run: the next
      if (run1 - run0 < 2 || covered < kMinSeedOverlap * (t.last - t.first + 1)) continue;
      const PlaneFit f = fitPlane(m);
      if (f.rms > 0.5 * params().threshold(t.range) || f.spread(1) <= SurfaceTests::kPlanarSpread) continue;
      for (std::size_t k = run0; k < run1; ++k) absorb(seg_region_[ti], seg_region_[k]);
      break;
    }
  }
}

bool ScanLineGrouper::lineShared(const std::vector<int>& members, std::ptrdiff_t k) const {
  const int line = spans_[members[k]].line;
  return (k > 0 && spans_[members[k - 1]].line == line) ||
         (k + 1 < static_cast<std::ptrdiff_t>(members.size()) && spans_[members[k + 1]].line == line);
}

void ScanLineGrouper::removeMember(int region, int si) {
  Region& r = regions_[region];
  const Moments3& m = segs_[si].moments;
  const auto at = std::lower_bound(r.members.begin(), r.members.end(), si);
  if (at == r.members.end() || *at != si) return;  // not a member
  if (!lineShared(r.members, at - r.members.begin())) --r.lines;
  r.members.erase(at);
  r.moments -= m;
  r.rays -= SurfaceTests::raysOf(segs_[si]);
  r.origins -= SurfaceTests::originsOf(segs_[si]);
  r.fit = fitPlane(r.moments);
  r.first_line = segs_[r.members.front()].line;
  r.last_line = segs_[r.members.back()].line;
  seg_region_[si] = -1;
}

bool ScanLineGrouper::moveCreaseSegments(const std::vector<int>& cand, std::vector<char>& moved_once) {
  // A segment on a crease fits the planes on both sides; the first to come
  // took it. Give each boundary segment to the neighbouring plane it lies
  // nearer to, if that plane accepts it.
  bool moved = false;
  std::vector<std::size_t> pos;  // per region: where the last segment looked up stands in its members
  for (std::size_t si = 0; si < segs_.size(); ++si) {
    const int ri = seg_region_[si];
    if (ri < 0 || regions_[ri].dead || regions_[ri].members.size() < 3 || moved_once[si]) continue;
    const Region& own = regions_[ri];
    const Segment3& s = segs_[si];
    // On its plane's edge: no member of the line before or of the line after
    // lies beside it (a floor's edge along a step is in the middle of the
    // floor's lines).
    // Members are sorted by index, so by line: its neighbours are next to it.
    // Segments come in index order: its place is most often right after the
    // last one looked up in its region (checked; else searched).
    if (pos.size() < regions_.size()) pos.resize(regions_.size(), 0);
    std::size_t& k = pos[ri];
    if (!(k + 1 < own.members.size() && own.members[k + 1] == static_cast<int>(si)))
      k = std::lower_bound(own.members.begin(), own.members.end(), static_cast<int>(si)) - own.members.begin();
    else
      ++k;
    const auto at = own.members.begin() + k;
    bool before = false, after = false;
    for (auto mi = at; mi != own.members.begin() && !before;) {
      const Span& m = spans_[*--mi];
      if (m.line < s.line - 1) break;
      before = m.line == s.line - 1 && m.first <= s.last && s.first <= m.last;
    }
    for (auto mi = at + 1; mi < own.members.end() && !after; ++mi) {
      const Span& m = spans_[*mi];
      if (m.line > s.line + 1) break;
      after = m.line == s.line + 1 && m.first <= s.last && s.first <= m.last;
    }
    if (before && after) continue;
    const Eigen::Vector3d c = s.moments.mean();
    const double tol = params().centroidTolerance(s.range);
    // Only a plane within the tolerance can take it: look before refitting its own.
    const auto reaches = [&](int rj) {
      const Region& o = regions_[rj];
      return rj != ri && !o.dead && o.lines >= 2 && s.line >= o.first_line - 1 && s.line <= o.last_line + 1 &&
             std::abs(o.fit.normal.dot(c) - o.fit.offset) <= tol;
    };
    // Its own plane fitted without it (it pulled that plane towards itself):
    // farther than the tolerance from it, it does not belong there (a riser's
    // foot line that tilted the tread it joined) and leaves, if the rest
    // still spans a plane (not a line and a short piece).
    const auto restFit = [&] {
      Moments3 rest = own.moments;
      rest -= s.moments;
      return fitPlane(rest);
    };
    const bool spare = own.lines >= 3 && own.members.size() >= 4;
    const auto leaves = [&](const PlaneFit& rest) {
      return spare && rest.spread(1) > SurfaceTests::kPlanarSpread && std::abs(rest.normal.dot(c) - rest.offset) > tol;
    };
    const auto leave = [&] {
      moved_once[si] = 1;
      removeMember(ri, static_cast<int>(si));
      newRegion(static_cast<int>(si));
      moved = true;
    };
    if (std::none_of(cand.begin(), cand.end(), reaches)) {
      if (spare && leaves(restFit())) leave();
      continue;
    }
    const PlaneFit rest = restFit();
    const double d_own = std::abs(rest.normal.dot(c) - rest.offset);
    // Which of two planes that meet at a crease a segment near it lies on:
    // the side of their bisector it is on, which a rig's offset of the whole
    // line along the planes' mean normal does not move (the bisector's
    // normal, the difference of the two, is square to their sum); its
    // distances to the planes, which such an offset moves alike, tell it
    // only where the planes part by more than the offset (a 5.7 degree ramp
    // and its floor: 0.3 m from the crease for 3 cm). For planes within the
    // merge angle of each other, where an offset along one normal is one
    // along the other; 0: steeper (a riser and its tread, where an offset
    // along the beam moves the distances apart), or the planes' centroids
    // are not on two sides of it (no crease between them).
    const auto bisectorSide = [&](const PlaneFit& a, const PlaneFit& b) {
      const double cos_ab = a.normal.dot(b.normal);
      if (std::abs(cos_ab) < std::cos(params().merge_angle_deg * kDeg)) return 0;
      const double sign = cos_ab >= 0.0 ? 1.0 : -1.0;
      const auto f = [&](const Eigen::Vector3d& x) {
        return (a.normal.dot(x) - a.offset) - sign * (b.normal.dot(x) - b.offset);
      };
      const double fa = f(a.centroid), fb = f(b.centroid), fc = f(c);
      if (!(fa * fb < 0.0)) return 0;
      return fc * fb > 0.0 ? 1 : -1;  // 1: on b's side
    };
    // On the crease itself (as near one plane as the other, to a quarter of
    // the tolerance) it goes to the plane of fewer lines, which it constrains
    // more (a box's front face below its top).
    int best = -1;
    double best_d = d_own;
    for (int rj : cand) {
      if (!reaches(rj)) continue;
      const Region& o = regions_[rj];
      const double d = std::abs(o.fit.normal.dot(c) - o.fit.offset);
      const bool tie = best < 0 && o.lines + 1 < own.lines && d < d_own + 0.25 * tol;
      const int side = bisectorSide(rest, o.fit);
      if (side < 0 && !tie) continue;
      if (!(best >= 0 ? d < best_d : side > 0 || d < d_own || tie)) continue;
      bool overlap = false;
      const auto [m0, m1] = membersIn(o, s.line - 1, s.line + 1);
      for (auto mi = m0; mi != m1 && !overlap; ++mi) overlap = spans_[*mi].first <= s.last && s.first <= spans_[*mi].last;
      if (overlap) {
        best = rj;
        best_d = d;
      }
    }
    if (best < 0) {
      if (leaves(rest)) leave();
      continue;
    }
    moved_once[si] = 1;  // once: refitted without it, the plane it left would call it back
    removeMember(ri, static_cast<int>(si));
    addMember(best, static_cast<int>(si));
    moved = true;
  }
  return moved;
}

void ScanLineGrouper::absorb(int into, int from) {
  Region& a = regions_[into];
  Region& b = regions_[from];
  a.moments += b.moments;
  a.rays += b.rays;
  a.origins += b.origins;
  for (int m : b.members) seg_region_[m] = into;
  a.members.insert(a.members.end(), b.members.begin(), b.members.end());
  std::sort(a.members.begin(), a.members.end());  // segment indices grow with the line
  a.first_line = std::min(a.first_line, b.first_line);
  a.last_line = std::max(a.last_line, b.last_line);
  a.lines = countLines(a.members, spans_);
  a.fit = fitPlane(a.moments);
  if (a.across.isZero()) a.across = b.across;
  b.dead = true;
  b.members.clear();
}

void ScanLineGrouper::addLine(const std::vector<Segment3>& line) {
  if (line.empty()) return;
  const int l = line.front().line;
  // Kept in beam order; matched longest first: a line that the split cut in
  // a long and a short piece pairs by the long one, whose plane is then
  // well fixed for the short one (the other way round it is not).
  const int first_idx = static_cast<int>(segs_.size());
  while (static_cast<int>(line_start_.size()) <= l) line_start_.push_back(first_idx);
  segs_.insert(segs_.end(), line.begin(), line.end());
  for (const Segment3& s : line) spans_.push_back({s.line, s.first, s.last});
  seg_region_.resize(segs_.size(), -1);
  order_.resize(line.size());
  for (std::size_t k = 0; k < line.size(); ++k) order_[k] = first_idx + static_cast<int>(k);
  std::stable_sort(order_.begin(), order_.end(), [&](int a, int b) { return segs_[a].moments.n > segs_[b].moments.n; });
  for (const int idx : order_) {
    const Segment3& s = segs_[idx];
    if (s.moments.n < params().min_points) continue;  // too few points to judge: left out
    std::vector<std::pair<double, int>>& matches = matches_;
    matches.clear();
    for (int ri : open_) {
      Region& r = regions_[ri];
      if (r.dead) continue;
      // Overlap in beam index with a member of the previous lines.
      bool overlap = false;
      for (auto it = r.members.rbegin(); it != r.members.rend() && !overlap; ++it) {
        const Span& m = spans_[*it];
        if (m.line >= l) continue;
        if (m.line < l - params().max_line_gap) break;
        overlap = m.first <= s.last + params().beam_slack && s.first <= m.last + params().beam_slack;
      }
      double score = 0.0;
      if (overlap && fits(r, s, score)) matches.emplace_back(score, ri);
    }
    if (matches.empty()) {
      open_.push_back(newRegion(idx));
      continue;
    }
    // A plane of three lines or more before a pair (which any parallel line
    // next to it fits), then the best score.
    std::sort(matches.begin(), matches.end(), [&](const std::pair<double, int>& a, const std::pair<double, int>& b) {
      const bool ca = tests_.confirmed(regions_[a.second]), cb = tests_.confirmed(regions_[b.second]);
      return ca != cb ? ca : a < b;
    });
    const int best = matches[0].second;
    Region& r = regions_[best];
    r.moments += s.moments;
    r.rays += SurfaceTests::raysOf(s);
    r.origins += SurfaceTests::originsOf(s);
    r.members.insert(std::upper_bound(r.members.begin(), r.members.end(), idx), idx);  // sorted: lines in order
    if (l > r.last_line) ++r.lines;
    r.last_line = l;
    r.fit = fitPlane(r.moments);
    seg_region_[idx] = best;
    // The segment bridges planes that agree: they are one.
    for (std::size_t k = 1; k < matches.size(); ++k) {
      const int other = matches[k].second;
      if (!regions_[other].dead && tests_.planesAgree(regions_[best], regions_[other])) absorb(best, other);
    }
  }
  const int gap = params().max_line_gap;
  open_.erase(std::remove_if(open_.begin(), open_.end(),
                             [&](int ri) { return regions_[ri].dead || regions_[ri].last_line < l - gap; }),
              open_.end());
}

void ScanLineGrouper::finish(std::vector<Plane>& planes, const LinePoints& points) {
  planes.clear();
  open_.clear();
  // The regions that can be planes: alive, two segments or more. (Most
  // regions are single segments that found no partner.)
  std::vector<int> cand;
  const auto collect = [&] {
    cand.clear();
    for (std::size_t i = 0; i < regions_.size(); ++i)
      if (!regions_[i].dead && regions_[i].members.size() >= 2) cand.push_back(static_cast<int>(i));
  };
  collect();
  // Planes that meet and agree merge (a floor cut in two by a box, a plane
  // that restarted after a gap): the pair whose union explains its parts
  // best first (the worst part's rms about the union over the threshold),
  // so that the regions' order does not choose which of a region's
  // neighbours it takes.
  std::vector<int> version(regions_.size(), 0);  // a pair judged before its regions changed is judged again
  struct Candidate {
    double score;
    int a, b, va, vb;  // a < b: b merges into a
    bool operator<(const Candidate& o) const {  // the queue's top: the least score (then the first regions)
      return std::tie(score, a, b) > std::tie(o.score, o.a, o.b);
    }
  };
  std::priority_queue<Candidate> queue;
  const auto judge = [&](int a, int b) {
    if (a > b) std::swap(a, b);
    const Region& ra = regions_[a];
    const Region& rb = regions_[b];
    const bool lines_near =
        ra.first_line <= rb.last_line + params().max_line_gap + 1 &&
        rb.first_line <= ra.last_line + params().max_line_gap + 1;
    const bool seam = params().cyclic_lines && std::min(ra.first_line, rb.first_line) <= params().max_line_gap &&
                      std::max(ra.last_line, rb.last_line) >= segs_.back().line - params().max_line_gap;
    if (!lines_near && !seam) return;
    double score = 0.0;
    if (!tests_.planesAgree(ra, rb, &score)) return;
    const double limit = params().seed_gap + 0.05 * (ra.fit.centroid - sensor()).norm();
    if (!(lines_near && touch(ra.members, rb.members, limit, &ra, &rb)) &&
        !(seam && touchAcrossSeam(ra.members, rb.members, limit)))
      return;
    queue.push({score, a, b, version[a], version[b]});
  };
  const auto mergeAgreeing = [&] {
    for (std::size_t ia = 0; ia < cand.size(); ++ia)
      for (std::size_t ib = ia + 1; ib < cand.size(); ++ib) judge(cand[ia], cand[ib]);
    while (!queue.empty()) {
      const Candidate c = queue.top();
      queue.pop();
      if (regions_[c.a].dead || regions_[c.b].dead || version[c.a] != c.va || version[c.b] != c.vb) continue;
      absorb(c.a, c.b);
      ++version[c.a];
      for (const int o : cand)
        if (o != c.a && !regions_[o].dead) judge(c.a, o);
    }
  };
  mergeAgreeing();
  settlePairs();
  collect();
  // Segments on creases, again while segments move (a move refits both
  // planes), at most a few times.
  std::vector<char> moved_once(segs_.size(), 0);
  for (int pass = 0; pass < 3; ++pass)
    if (!moveCreaseSegments(cand, moved_once)) break;

  // Late joins: pieces of a line that the split cut short (or that came before
  // their plane was seeded) join a plane of their neighbourhood that they fit.
  // So do the segments of a strip whose lines never spread enough to fix a
  // normal (it makes no plane): at a slow sweep's reversal such a strip takes
  // the floor and the wall beside it alike (all lie in one scan plane), and
  // the floor's plane, seeded beyond it, is judged against them here. Once in
  // the lines' order and once against it, so a plane takes a run of them from
  // either end (a run of short pieces before a plane's first line joins it
  // line by line backwards as after its last forwards).
  std::vector<char> strip_region(regions_.size(), 0);
  for (const int ri : cand) strip_region[ri] = tests_.spreadAcross(regions_[ri]) <= SurfaceTests::kPlanarSpread;
  const auto lateJoin = [&](std::size_t si) {
    const int ri = seg_region_[si];
    const bool alive = ri >= 0 && !regions_[ri].dead;
    const bool grouped = alive && regions_[ri].members.size() >= 2;
    // (A strip that gave all its other segments away is still one: its last
    // segment goes as they went.)
    const bool strip = alive && strip_region[ri];
    if (grouped && !strip) return;
    const Segment3& s = segs_[si];
    if (s.moments.n < 3) return;
    // A strip's lines lie in one scan plane (a sweep's reversal repeats a
    // servo reading), so the lines near its segment are the strip's own: no
    // member of the plane beside it need overlap it in beam index there.
    const int best = bestFit(s, cand, ri, 2, true, strip);
    if (best < 0 || (strip && !tests_.planar(regions_[best]))) return;
    if (grouped) {
      removeMember(ri, static_cast<int>(si));
    } else if (alive) {  // a lone segment's region empties
      regions_[ri].members.clear();
      regions_[ri].dead = true;
    }
    addMember(best, static_cast<int>(si));
  };
  for (std::size_t si = 0; si < segs_.size(); ++si) lateJoin(si);
  for (std::size_t si = segs_.size(); si-- > 0;) lateJoin(si);
  // The late joins grew planes, and two of them may now meet (a strip between
  // two pieces of a wall went to one of them): the merge judges its pairs again.
  collect();
  version.resize(regions_.size(), 0);  // (settlePairs may have made regions)
  mergeAgreeing();
  if (points) cutAtCreases(cand, points);

  // Whether a region may make a plane at all (most are single segments).
  const auto mayBePlane = [&](const Region& r) {
    return !r.dead && static_cast<int>(r.members.size()) >= params().min_segments && r.last_line != r.first_line;
  };
  // A region's plane, false when it makes none.
  const auto planeOf = [&](const Region& r, Plane& p) {
    p.fit = fitPlane(r.moments);
    // Its own points must fix its normal, as a region's must before a
    // segment is judged by its plane (tests_.planar()): two lines a centimetre apart
    // fit planes tilted by tens of degrees within their noise (a tread seen
    // by two lines from a step), and a strip that many lines cross at one
    // place (room_240's table edge under the laser) is no surface.
    if (tests_.spreadAcross(r) <= SurfaceTests::kPlanarSpread) return false;
    if (p.fit.normal.dot(sensor() - p.fit.centroid) < 0.0) {
      p.fit.normal = -p.fit.normal;
      p.fit.offset = -p.fit.offset;
    }
    p.members = r.members;
    p.segments = static_cast<int>(r.members.size());
    p.points = static_cast<int>(r.moments.n);
    buildPolygon(r, p);
    return p.area >= params().min_area;
  };
  // The planes, numbered in the regions' order; with setThreads(2) the two
  // halves of the regions on two threads.
  std::vector<Plane> second_half;
  inHalves(regions_.size(), shareFinish(),
           [&](std::size_t b, std::size_t e, int half) {
             for (std::size_t ri = b; ri < e; ++ri) {
               if (!mayBePlane(regions_[ri])) continue;
               Plane p;
               if (planeOf(regions_[ri], p)) (half ? second_half : planes).push_back(std::move(p));
             }
           });
  for (Plane& p : second_half) planes.push_back(std::move(p));
  if (points) dropExplained(planes, points);
  seg_plane_.assign(segs_.size(), -1);
  for (std::size_t k = 0; k < planes.size(); ++k) {
    planes[k].id = static_cast<int>(k);
    for (int m : planes[k].members) seg_plane_[m] = planes[k].id;
  }
  const GroupingParams& p = params();
  if (p.crease_reach > p.crease_margin) closeCreases(planes, p.crease_reach, p.crease_margin, p.merge_angle_deg);
}

void ScanLineGrouper::dropExplained(std::vector<Plane>& planes, const LinePoints& points) const {
  const std::size_t n = planes.size();
  std::vector<Eigen::AlignedBox3d> box(n);
  for (std::size_t i = 0; i < n; ++i)
    for (const Eigen::Vector3d& v : planes[i].boundary) box[i].extend(v);
  // The points of a's members within the distance threshold of none of the
  // planes `by`, every `stride`-th of them (a plane is judged by some 256
  // points spread over it), counted until more than `allowed`. A segment's
  // points lie within the split's threshold (at most the distance
  // threshold; twice it allowed) of the line between its ends, so a plane
  // that this line stays three thresholds from holds none of them (a wall's
  // line above the floor): such a member counts whole, its points unread.
  std::vector<const PlaneFit*> by_seg;
  const auto ownPoints = [&](const Plane& pa, const std::vector<const Plane*>& by, int stride, double allowed) {
    double own = 0.0;
    for (auto m = pa.members.begin(); m != pa.members.end() && own <= allowed; ++m) {
      const Segment3& s = segs_[*m];
      const double tol = params().threshold(std::max((s.start - sensor()).norm(), (s.end - sensor()).norm()));
      const Eigen::Vector3d c = s.moments.mean();
      by_seg.clear();
      for (const Plane* b : by)
        if (std::abs(b->fit.normal.dot(c) - b->fit.offset) - std::abs(b->fit.normal.dot(s.end - s.start)) <= 3.0 * tol)
          by_seg.push_back(&b->fit);
      if (by_seg.empty()) {
        own += s.moments.n / stride;
        continue;
      }
      const std::vector<Eigen::Vector3f>& pts = *points(s.line);
      for (int i = s.first + (*m % stride); i <= s.last; i += stride) {
        const Eigen::Vector3d q = pts[i].cast<double>();
        if (!q.allFinite()) continue;
        const double t = params().threshold((q - sensor()).norm());
        bool theirs = false;
        for (const PlaneFit* f : by_seg) theirs = theirs || std::abs(f->normal.dot(q) - f->offset) <= t;
        own += !theirs;
      }
    }
    return own;
  };
  std::vector<char> drop(n, 0);
  std::vector<const Plane*> around, beside;
  for (std::size_t a = 0; a < n; ++a) {
    const Plane& pa = planes[a];
    if (box[a].isEmpty()) continue;
    const double limit = params().threshold((pa.fit.centroid - sensor()).norm());
    const int stride = std::max(1, pa.points / 256);
    const double allowed = (1.0 - kExplained) * pa.points / stride;
    // First by the bigger planes whose polygons come that near (most planes
    // keep too many points of their own already), then by those it touches.
    around.clear();
    for (std::size_t b = 0; b < n; ++b)
      if (planes[b].points > pa.points && !box[b].isEmpty() && box[a].exteriorDistance(box[b]) <= limit)
        around.push_back(&planes[b]);
    if (around.empty() || ownPoints(pa, around, stride, allowed) > allowed) continue;
    beside.clear();
    for (const Plane* b : around)
      if (touch(pa.members, b->members, limit)) beside.push_back(b);
    drop[a] = !beside.empty() && ownPoints(pa, beside, stride, allowed) <= allowed;
  }
  std::size_t w = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (!drop[i]) {
      if (w != i) planes[w] = std::move(planes[i]);
      ++w;
    }
  planes.resize(w);
}

void closeCreases(std::vector<Plane>& planes, double reach, double margin, double min_angle_deg) {
  const std::size_t n = planes.size();
  // Boxes around the polygons: pairs farther apart than the reach never meet.
  std::vector<Eigen::AlignedBox3d> box(n);
  for (std::size_t i = 0; i < n; ++i)
    for (const Eigen::Vector3d& v : planes[i].boundary) box[i].extend(v);
  const double max_cos = std::cos(min_angle_deg * kDeg);
  // How far short of a crease a polygon may end. No line of the plane saw
  // the band across its outermost line up to where its next line would lie
  // (the spacing between its two outermost lines: a tread far from the head
  // has lines 10-20 cm apart); elsewhere (beyond a line's end, which the line
  // saw) `reach`. The outline lists each line's entry in order, then each
  // line's exit back (2 corners a line).
  std::vector<double> own_reach(n, reach);
  const auto layoutLines = [](const Plane& p) {
    return p.boundary.size() % 2 == 0 && p.boundary.size() >= 4 ? p.boundary.size() / 2 : std::size_t{0};
  };
  for (std::size_t i = 0; i < n; ++i) {
    const std::vector<Eigen::Vector3d>& b = planes[i].boundary;
    const std::size_t lines = layoutLines(planes[i]);
    if (lines == 0) continue;
    const auto apart = [&](std::size_t l, std::size_t m) {  // line l's ends from line m's chord
      const Eigen::Vector3d a = b[m], chord = b[2 * lines - 1 - m] - a;
      if (!(chord.norm() > 0.0)) return 0.0;
      const Eigen::Vector3d d = chord.normalized();
      const auto from = [&](const Eigen::Vector3d& x) { return ((x - a) - d * d.dot(x - a)).norm(); };
      return std::min(from(b[l]), from(b[2 * lines - 1 - l]));
    };
    own_reach[i] = std::max({reach, apart(0, 1), apart(lines - 1, lines - 2)});
  }
  // Whether corner v of plane k, `dist` short of the common line (negative:
  // past it), may be carried along u to it: within `reach` either way; or,
  // when v ends an outermost line, short of it by more: across that line by
  // up to the plane's own reach, along it (its ends, which the line saw) by
  // no more than `reach`, and not beyond its ends.
  const auto mayCarry = [&](std::size_t k, std::size_t v, double dist, const Eigen::Vector3d& u) {
    if (dist >= -reach && dist <= reach) return true;
    if (dist < 0.0 || own_reach[k] <= reach) return false;
    const std::vector<Eigen::Vector3d>& b = planes[k].boundary;
    const std::size_t lines = layoutLines(planes[k]);
    if (lines == 0) return false;
    const std::size_t l = v < lines ? v : 2 * lines - 1 - v;
    if (l != 0 && l != lines - 1) return false;
    const Eigen::Vector3d a = b[l], chord = b[2 * lines - 1 - l] - a;
    const double len = chord.norm();
    if (!(len > 0.0)) return false;
    const Eigen::Vector3d c = chord / len, move = -dist * u;
    const double along_move = c.dot(move), across_move = (move - along_move * c).norm();
    const double along = c.dot(b[v] + move - a) / len;
    return std::abs(along_move) <= reach && across_move <= own_reach[k] && along >= -1e-9 && along <= 1.0 + 1e-9;
  };
  // Whether a box comes within the reach of a plane (the common line lies on it).
  const auto nearPlane = [](const Eigen::AlignedBox3d& b, const PlaneFit& f, double reach) {
    double lo = 1e300, hi = -1e300;
    for (int k = 0; k < 8; ++k) {
      const double dist = f.normal.dot(b.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k))) - f.offset;
      lo = std::min(lo, dist);
      hi = std::max(hi, dist);
    }
    return lo <= reach && hi >= -reach;
  };
  // A corner and where it goes.
  struct Move {
    std::size_t plane, corner;
    Eigen::Vector3d u;  // towards the plane's centroid, at right angles to the crease
    double by;          // along u [m]
  };
  std::vector<Move> moves;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      if (box[i].isEmpty() || box[j].isEmpty() || box[i].exteriorDistance(box[j]) > own_reach[i] + own_reach[j]) continue;
      const PlaneFit &fa = planes[i].fit, &fb = planes[j].fit;
      const double c = fa.normal.dot(fb.normal);
      if (std::abs(c) > max_cos || !nearPlane(box[j], fa, own_reach[j]) || !nearPlane(box[i], fb, own_reach[i])) continue;
      const Eigen::Vector3d d = fa.normal.cross(fb.normal).normalized();
      const Eigen::Vector3d x0 =
          ((fa.offset - fb.offset * c) * fa.normal + (fb.offset - fa.offset * c) * fb.normal) / (1.0 - c * c);
      // The common line is x0 + t d. Each polygon's side of it, and the
      // stretch of it that the polygon reaches.
      struct Side {
        Eigen::Vector3d u;  // in the plane, at right angles to the line, towards its centroid
        double lo = 1e300, hi = -1e300;  // along d, of the corners within reach
        bool meets = false;
      };
      const auto side = [&](std::size_t k) {
        const Plane& p = planes[k];
        Side s;
        s.u = d.cross(p.fit.normal);
        if (s.u.dot(p.fit.centroid - x0) < 0.0) s.u = -s.u;
        std::size_t nearest = 0;
        double nearest_dist = 1e300;
        for (std::size_t v = 0; v < p.boundary.size(); ++v) {
          const double dist = s.u.dot(p.boundary[v] - x0);
          if (dist < nearest_dist) {
            nearest_dist = dist;
            nearest = v;
          }
          if (mayCarry(k, v, dist, s.u)) {
            const double t = d.dot(p.boundary[v] - x0);
            s.lo = std::min(s.lo, t);
            s.hi = std::max(s.hi, t);
          }
        }
        s.meets = !p.boundary.empty() && mayCarry(k, nearest, nearest_dist, s.u);
        return s;
      };
      const Side sa = side(i), sb = side(j);
      if (!sa.meets || !sb.meets) continue;
      const auto carry = [&](std::size_t k, const Side& own, const Side& other) {
        const std::vector<Eigen::Vector3d>& ring = planes[k].boundary;
        for (std::size_t v = 0; v < ring.size(); ++v) {
          const double dist = own.u.dot(ring[v] - x0), t = d.dot(ring[v] - x0);
          // (Corners within the margin on their own side stay.)
          if ((dist > margin || dist < -1e-9) && mayCarry(k, v, dist, own.u) && t >= other.lo - reach &&
              t <= other.hi + reach)
            moves.push_back({k, v, own.u, margin - dist});
        }
      };
      carry(i, sa, sb);
      carry(j, sb, sa);
    }
  // Moved after every pair was judged by the polygons as they were. A
  // corner near two creases (a box top's, by its front and its side) is
  // carried to the nearer, and to where it meets the next one that runs at
  // min_angle_deg or more to it, whatever order the pairs came in.
  std::sort(moves.begin(), moves.end(), [](const Move& a, const Move& b) {
    return std::make_tuple(a.plane, a.corner, std::abs(a.by), a.u.x(), a.u.y()) <
           std::make_tuple(b.plane, b.corner, std::abs(b.by), b.u.x(), b.u.y());
  });
  const double min_sin = std::sin(min_angle_deg * kDeg);
  std::vector<double> outer(n, -1.0);  // the outer polygon's area before, of those that change
  for (std::size_t m = 0; m < moves.size();) {
    const Move& a = moves[m];
    std::size_t e = m + 1;  // the corner's moves are [m, e)
    while (e < moves.size() && moves[e].plane == a.plane && moves[e].corner == a.corner) ++e;
    Eigen::Vector3d by = a.by * a.u;
    for (std::size_t k = m + 1; k < e; ++k) {
      const Move& b = moves[k];
      const double c = a.u.dot(b.u);
      if (a.u.cross(b.u).norm() < min_sin) continue;
      by = (a.by - c * b.by) / (1.0 - c * c) * a.u + (b.by - c * a.by) / (1.0 - c * c) * b.u;
      break;
    }
    Plane& p = planes[a.plane];
    if (outer[a.plane] < 0.0) outer[a.plane] = polygonArea(p.boundary, p.fit);
    p.boundary[a.corner] += by;
    m = e;
  }
  for (std::size_t i = 0; i < n; ++i)
    if (outer[i] >= 0.0) planes[i].area = std::max(0.0, planes[i].area + polygonArea(planes[i].boundary, planes[i].fit) - outer[i]);
}

void ScanLineGrouper::cutAtCreases(const std::vector<int>& cand, const LinePoints& points) {
  struct Cut {
    int seg, first, last, to;
  };
  std::vector<Cut> cuts;
  // The planes that could take a piece, with the lines and beams they reach.
  struct Other {
    int region, line_lo, line_hi, beam_lo, beam_hi;
    std::size_t order;  // tried in this order (the candidates')
  };
  std::vector<Other> others;
  for (const int rj : cand) {
    const Region& o = regions_[rj];
    if (o.dead || o.lines < 2) continue;
    Other x{rj, o.first_line - params().max_line_gap, o.last_line + params().max_line_gap, segs_[o.members[0]].first,
            segs_[o.members[0]].last, others.size()};
    for (const int m : o.members) {
      x.beam_lo = std::min(x.beam_lo, spans_[m].first - params().beam_slack);
      x.beam_hi = std::max(x.beam_hi, spans_[m].last + params().beam_slack);
    }
    others.push_back(x);
  }
  // Others by their first line: as the segments go line by line, those
  // whose lines reach the segment's are kept in `active`.
  std::sort(others.begin(), others.end(), [](const Other& a, const Other& b) { return a.line_lo < b.line_lo; });
  // The lone segments that may seed a plane with a run of a neighbour's (in index order, so by line).
  std::vector<int> lone;
  for (std::size_t i = 0; i < segs_.size(); ++i) {
    const int rt = seg_region_[i];
    if (rt >= 0 && !regions_[rt].dead && regions_[rt].members.size() == 1 && segs_[i].moments.n >= 2 * params().min_points)
      lone.push_back(static_cast<int>(i));
  }
  // The segments [s0, s1) voted on, their cuts into `out`. The planes
  // active at a segment are those whose lines reach its line, in the
  // candidates' order, wherever the pass starts: with setThreads(2) the
  // two halves of the segments run on two threads, the same cuts.
  const auto voteRange = [&](std::size_t s0, std::size_t s1, std::vector<Cut>& out) {
    std::vector<Other> active;
    std::size_t next_other = 0;
    // The planes whose lines reach `line` (in the candidates' order).
    const auto reachLine = [&](int line) {
      if (next_other < others.size() && others[next_other].line_lo <= line) {
        while (next_other < others.size() && others[next_other].line_lo <= line) active.push_back(others[next_other++]);
        std::sort(active.begin(), active.end(), [](const Other& a, const Other& b) { return a.order < b.order; });
      }
      active.erase(std::remove_if(active.begin(), active.end(), [&](const Other& x) { return x.line_hi < line; }),
                   active.end());
    };
    for (std::size_t si = s0; si < s1; ++si) {
      const int ri = seg_region_[si];
      if (ri < 0 || regions_[ri].dead) continue;
      const Segment3& s = segs_[si];
      if (regions_[ri].members.size() == 1) {
        // A segment no plane took that runs from one plane onto another (a
        // line down a riser and onto the floor at its foot, a bend under the
        // split's threshold): the run of its beams from one end whose points
        // lie within the threshold of a confirmed plane beside it goes to that
        // plane, the rest stays alone.
        if (s.moments.n < 2 * params().min_points) continue;
        const std::vector<Eigen::Vector3f>* lp = points(s.line);
        if (!lp || static_cast<int>(lp->size()) <= s.last) continue;
        reachLine(s.line);
        const double thr = params().threshold(s.range);
        Cut best{-1, 0, 0, -1};
        int best_n = params().min_points - 1;
        for (const Other& x : active) {
          if (x.region == ri || s.last < x.beam_lo || s.first > x.beam_hi || !tests_.confirmed(regions_[x.region])) continue;
          const PlaneFit& f = regions_[x.region].fit;
          const auto on = [&](int i) { return std::abs(f.normal.dot((*lp)[i].cast<double>()) - f.offset) <= thr; };
          for (const int dir : {1, -1}) {
            int n = 0, i = dir > 0 ? s.first : s.last, end = i;
            for (; i >= s.first && i <= s.last; i += dir) {
              if (!std::isfinite((*lp)[i].x())) continue;
              if (!on(i)) break;
              ++n;
              end = i;
            }
            if (i < s.first || i > s.last || n <= best_n) continue;  // all of it, or shorter
            best = dir > 0 ? Cut{static_cast<int>(si), s.first, end, x.region} : Cut{static_cast<int>(si), end, s.last, x.region};
            best_n = n;
          }
        }
        Segment3 piece;
        if (best.seg >= 0 && pieceOf(s, *lp, best.first, best.last, piece) &&
            std::abs(regions_[best.to].fit.normal.dot(piece.moments.mean()) - regions_[best.to].fit.offset) <=
                params().centroidTolerance(s.range))
          out.push_back(best);
        continue;
      }
      if (s.moments.n < 2 * params().min_points || !s.origin.allFinite()) continue;
      const Region& own = regions_[ri];
      const std::vector<Eigen::Vector3f>* pts = nullptr;
      PlaneFit fa;  // its own plane, without it if the rest has two lines or more
      const double thr = params().threshold(s.range);
      Cut best{-1, 0, 0, -1};
      PlaneFit best_fit;
      double best_votes = kMinCutVotes - 0.5;
      const auto loadPoints = [&] {
        if (!pts) {
          pts = points(s.line);
          if (!pts || static_cast<int>(pts->size()) <= s.last) return false;
          Moments3 rest = own.moments;
          rest -= s.moments;
          fa = own.lines > 2 ? fitPlane(rest) : own.fit;
        }
        return true;
      };
      // Votes s's beams lo..hi between its own plane and `of` (the plane of
      // region `to`, whose members near s sum to near_other); a run needs
      // min_votes net. False when the line's points are missing.
      const auto vote = [&](const PlaneFit& of, const Moments3& near_other, int lo, int hi, int to, double min_votes) {
        // The crease between the planes: convex (a box's edge) when each
        // plane's members near it lie behind the other plane, as seen from the
        // sensor; concave (a riser's foot) when in front. Not clear by the
        // tolerance: no crease to cut at.
        // Its own plane's other members on the lines near it, on the beams
        // lo..hi beside the other plane only: a floor goes on beside a ramp,
        // and there it lies behind the ramp's plane (by all its members near,
        // the ramp's foot was no crease or a convex one). A member's part on
        // those beams: the point of its line at their middle, weighed by their
        // share of its points.
        double near_n = 0.0;
        Eigen::Vector3d near_sum = Eigen::Vector3d::Zero();
        const auto [a0, a1] = membersIn(own, s.line - params().max_line_gap, s.line + params().max_line_gap);
        for (auto mi = a0; mi != a1; ++mi) {
          const int b0 = std::max(spans_[*mi].first, lo), b1 = std::min(spans_[*mi].last, hi);
          if (*mi == static_cast<int>(si) || b1 < b0) continue;
          const Segment3& m = segs_[*mi];
          const double span = std::max(1, m.last - m.first);
          const double n = m.moments.n * (b1 - b0 + 1) / (m.last - m.first + 1);
          near_n += n;
          near_sum += n * (m.start + (m.end - m.start) * ((0.5 * (b0 + b1) - m.first) / span));
        }
        if (near_n < params().min_points) return true;
        const auto inFront = [&](const PlaneFit& f, const Eigen::Vector3d& x) {
          const double d = f.normal.dot(x) - f.offset;
          return f.normal.dot(s.origin) > f.offset ? d : -d;  // normal turned to the sensor
        };
        const double side = inFront(of, near_sum / near_n) + inFront(own.fit, near_other.mean());
        const double tol = params().centroidTolerance(s.range);
        if (std::abs(side) < tol) return true;
        const bool convex = side < 0.0;
        if (!loadPoints()) return false;
        // Each beam's ray meets both planes; the surface is the farther of the
        // two at a convex crease, the nearer at a concave one. The range noise
        // of a point does not move its ray: near the crease the ray tells the
        // planes apart where the points' distances cannot, unless the planes
        // meet the ray within kCreaseMargin of each other (a line right on the
        // crease, within the planes' own errors: it stays). A beam votes for
        // the other plane if its ray meets that one clearly first (last) and
        // its point lies within the threshold of it, against if clearly not;
        // the run with the most votes net.
        double run = 0.0;
        int run_first = lo;
        const double need = std::max(best_votes, min_votes - 0.5);
        const double ha = fa.offset - fa.normal.dot(s.origin), hb = of.offset - of.normal.dot(s.origin);
        for (int i = lo; i <= hi; ++i) {
          const Eigen::Vector3f& q = (*pts)[i];
          if (!std::isfinite(q.x())) continue;
          const Eigen::Vector3d ray = q.cast<double>() - s.origin;
          const double r = ray.norm();
          const double ta = ha / fa.normal.dot(ray), tb = hb / of.normal.dot(ray);  // along the ray, 1 at the point
          double v = -1.0;
          if (std::isfinite(ta) && std::isfinite(tb) && ta > 0.0 && tb > 0.0 && std::abs(1.0 - tb) * r <= thr) {
            const double lead = (convex ? tb - ta : ta - tb) * r;  // [m], > 0: the other plane's
            v = lead > kCreaseMargin ? 1.0 : lead < -kCreaseMargin ? -1.0 : -0.25;
          }
          if (run <= 0.0) {
            run = 0.0;
            run_first = i;
          }
          run += v;
          if (run > need && run > best_votes) {
            best = {static_cast<int>(si), run_first, i, to};
            best_fit = of;
            best_votes = run;
          }
        }
        return true;
      };
      reachLine(s.line);
      bool have_points = true;
      for (const Other& x : active) {
        if (x.region == ri || s.last < x.beam_lo || s.first > x.beam_hi) continue;
        const int rj = x.region;
        const Region& o = regions_[rj];
        // A straight segment whose both ends lie on one side of that plane,
        // well beyond the threshold, has no point near it.
        const double d0 = o.fit.normal.dot(s.start) - o.fit.offset, d1 = o.fit.normal.dot(s.end) - o.fit.offset;
        if (d0 * d1 > 0.0 && std::min(std::abs(d0), std::abs(d1)) > 2.0 * thr) continue;
        // Only beside that plane's members on the lines near (a plane goes on
        // forever; the surface does not).
        int lo = s.last + 1, hi = s.first - 1;
        const auto [m0, m1] = membersIn(o, s.line - params().max_line_gap, s.line + params().max_line_gap);
        for (auto mi = m0; mi != m1; ++mi) {
          const Span& m = spans_[*mi];
          if (m.first > s.last + params().beam_slack || s.first > m.last + params().beam_slack) continue;
          lo = std::min(lo, m.first);
          hi = std::max(hi, m.last);
        }
        lo = std::max(lo, s.first);
        hi = std::min(hi, s.last);
        if (hi - lo + 1 < params().min_points) continue;
        Moments3 near_other;
        for (auto mi = m0; mi != m1; ++mi) near_other += segs_[*mi].moments;
        if (!(have_points = vote(o.fit, near_other, lo, hi, rj, kMinCutVotes))) break;
      }
      if (!have_points) continue;
      // A lone segment of the next or the line before, and this segment's
      // beams beside it, may span a plane of their own: a riser crossed by two
      // lines, the lower along its foot, which the floor's segment took (too
      // gentle a bend for the split). That plane is tried as the other one; a
      // run beside kMinLoneCover of the lone segment or more seeds it.
      for (int dl : {-1, 1}) {
        const int t_end = firstSegmentOf(s.line + dl + 1);
        for (auto it = std::lower_bound(lone.begin(), lone.end(), firstSegmentOf(s.line + dl));
             it != lone.end() && *it < t_end; ++it) {
          const int ti = *it;
          const Segment3& t = segs_[ti];
          const int rt = seg_region_[ti];
          // On this segment's plane it would span that plane again.
          if (std::abs(own.fit.normal.dot(t.moments.mean()) - own.fit.offset) <=
              params().centroidTolerance(t.range))
            continue;
          const int lo = std::max(s.first, t.first), hi = std::min(s.last, t.last);
          const double min_run = std::max<double>(params().min_points, kMinLoneCover * (t.last - t.first + 1));
          if (hi - lo + 1 < min_run || !loadPoints()) continue;
          Moments3 m = t.moments;
          for (int i = lo; i <= hi; ++i)
            if (std::isfinite((*pts)[i].x())) m.add((*pts)[i].cast<double>());
          const PlaneFit h = fitPlane(m);
          if (h.rms > 0.5 * params().threshold(t.range) || h.spread(1) <= SurfaceTests::kPlanarSpread ||
              std::abs(h.normal.dot(own.fit.normal)) > std::cos(params().merge_angle_deg * kDeg))
            continue;
          vote(h, t.moments, lo, hi, rt, min_run);
        }
      }
      if (best.seg < 0) continue;
      // The rest stays a segment of its own plane; too short for one, it goes
      // along (the whole segment belongs to the other plane: a tread's first
      // line that the riser below kept).
      int rest_n = 0;
      for (int i = s.first; i <= s.last; ++i)
        rest_n += (i < best.first || i > best.last) && std::isfinite((*pts)[i].x());
      if (rest_n < params().min_points) {
        best.first = s.first;
        best.last = s.last;
      }
      Segment3 piece;
      if (!pieceOf(s, *pts, best.first, best.last, piece)) continue;
      if (std::abs(best_fit.normal.dot(piece.moments.mean()) - best_fit.offset) >
          params().centroidTolerance(s.range))
        continue;
      out.push_back(best);
    }
  };
  std::vector<Cut> second_half;
  inHalves(segs_.size(), shareFinish(),
           [&](std::size_t b, std::size_t e, int half) { voteRange(b, e, half ? second_half : cuts); });
  cuts.insert(cuts.end(), second_half.begin(), second_half.end());
  if (cuts.empty()) return;

  // The segments again, each cut one in its pieces (in beam order); the
  // regions that lost or gained points are summed again.
  std::vector<Segment3> out;
  std::vector<int> region;
  out.reserve(segs_.size() + 2 * cuts.size());
  region.reserve(out.capacity());
  std::vector<char> touched(regions_.size(), 0);
  std::size_t c = 0;
  for (std::size_t si = 0; si < segs_.size(); ++si) {
    if (c == cuts.size() || cuts[c].seg != static_cast<int>(si)) {
      out.push_back(segs_[si]);
      region.push_back(seg_region_[si]);
      continue;
    }
    const Cut& cut = cuts[c++];
    const Segment3& s = segs_[si];
    const std::vector<Eigen::Vector3f>& pts = *points(s.line);
    const int own = seg_region_[si];
    touched[own] = touched[cut.to] = 1;
    const std::pair<int, int> spans[3] = {{s.first, cut.first - 1}, {cut.first, cut.last}, {cut.last + 1, s.last}};
    for (int k = 0; k < 3; ++k) {
      Segment3 piece;
      if (!pieceOf(s, pts, spans[k].first, spans[k].second, piece)) continue;
      out.push_back(piece);
      region.push_back(k == 1 ? cut.to : own);
    }
  }
  segs_ = std::move(out);
  seg_region_ = std::move(region);
  indexSegments();
  for (Region& r : regions_) r.members.clear();
  for (std::size_t si = 0; si < segs_.size(); ++si)
    if (seg_region_[si] >= 0) regions_[seg_region_[si]].members.push_back(static_cast<int>(si));
  for (std::size_t ri = 0; ri < regions_.size(); ++ri) {
    if (!touched[ri]) continue;
    Region& r = regions_[ri];
    if (r.members.empty()) {  // its segments all went whole
      r.dead = true;
      continue;
    }
    r.moments = Moments3();
    r.rays.setZero();
    r.origins = Moments3();
    for (int m : r.members) {
      r.moments += segs_[m].moments;
      r.rays += SurfaceTests::raysOf(segs_[m]);
      r.origins += SurfaceTests::originsOf(segs_[m]);
    }
    r.fit = fitPlane(r.moments);
    r.first_line = segs_[r.members.front()].line;
    r.last_line = segs_[r.members.back()].line;
    r.lines = countLines(r.members, spans_);
  }
}

bool chordsCross(const Eigen::Vector2d& a0, const Eigen::Vector2d& b0, const Eigen::Vector2d& a1,
                 const Eigen::Vector2d& b1, Eigen::Vector2d& at) {
  const auto cross = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); };
  const Eigen::Vector2d d0 = b0 - a0, d1 = b1 - a1;
  const double den = cross(d0, d1);
  if (den == 0.0) return false;
  const double u = cross(a1 - a0, d1) / den, w = cross(a1 - a0, d0) / den;
  at = a0 + u * d0;
  return u > 0.0 && u < 1.0 && w > 0.0 && w < 1.0;
}

Eigen::Vector3d cornerOnPlane(const Eigen::Vector3d& x, const Eigen::Vector3d& o, const PlaneFit& f,
                              const GroupingParams& p) {
  const double dist = f.normal.dot(x) - f.offset;
  const Eigen::Vector3d ray = x - o;
  const double along = f.normal.dot(ray);
  if (std::isfinite(along) && std::abs(along) >= SurfaceTests::kMinRayIncidence * ray.norm()) {
    const double t = dist / along;  // x - t ray is on the plane
    // No farther along the ray than range noise and a mixed pixel reach
    // (on a plane seen at a grazing angle, or a wrong one, it would fly off).
    const double r = ray.norm();
    if (std::abs(t) * r <= 2.0 * p.threshold(r)) return Eigen::Vector3d(x - t * ray);
  }
  return Eigen::Vector3d(x - dist * f.normal);
}

void ScanLineGrouper::buildPolygon(const Region& r, Plane& out) const {
  const PlaneFit& f = out.fit;
  const auto onPlane = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& o) { return cornerOnPlane(x, o, f, params()); };
  // Members are segment indices in increasing order: line by line, each
  // line's in beam order; lineEnd(k) is where the line of members[k] ends.
  const std::vector<int>& mem = r.members;
  const auto lineEnd = [&](std::size_t k) {
    std::size_t e = k + 1;
    while (e < mem.size() && spans_[mem[e]].line == spans_[mem[k]].line) ++e;
    return e;
  };
  // Outer boundary: where each line enters the plane, then back along where it leaves.
  std::vector<Eigen::Vector3d> left, right;
  left.reserve(r.lines);
  right.reserve(r.lines);
  for (std::size_t k = 0; k < mem.size(); k = lineEnd(k)) {
    const Segment3& first = segs_[mem[k]];
    const Segment3& last = segs_[mem[lineEnd(k) - 1]];
    left.push_back(onPlane(first.start, first.origin));
    right.push_back(onPlane(last.end, last.origin));
  }
  double area = stripArea(left, right, f);
  out.boundary = std::move(left);
  out.boundary.insert(out.boundary.end(), right.rbegin(), right.rend());
  // Holes: gaps inside lines, chained across lines while they overlap in beam index.
  struct Gap {
    int line, first, last;
    Eigen::Vector3d a, b;
  };
  std::vector<std::vector<Gap>> chains;
  std::vector<int> open_chains, next_open;
  for (std::size_t k = 0; k < mem.size();) {
    const std::size_t e = lineEnd(k);
    const int line = segs_[mem[k]].line;
    next_open.clear();
    for (std::size_t i = k; i + 1 < e; ++i) {
      const Segment3& a = segs_[mem[i]];
      const Segment3& b = segs_[mem[i + 1]];
      Gap g{line, a.last, b.first, onPlane(a.end, a.origin), onPlane(b.start, b.origin)};
      int chain = -1;
      for (int c : open_chains) {
        const Gap& prev = chains[c].back();
        if (prev.line >= line - params().max_line_gap && prev.first <= g.last && g.first <= prev.last) {
          chain = c;
          break;
        }
      }
      if (chain < 0) {
        chain = static_cast<int>(chains.size());
        chains.emplace_back();
      }
      chains[chain].push_back(g);
      next_open.push_back(chain);
    }
    for (int c : open_chains)
      if (std::find(next_open.begin(), next_open.end(), c) == next_open.end() &&
          chains[c].back().line >= line - params().max_line_gap)
        next_open.push_back(c);
    std::swap(open_chains, next_open);
    k = e;
  }
  for (const auto& c : chains) {
    if (c.size() < 2) continue;  // a slit in one line: no hole
    std::vector<Eigen::Vector3d> hole;
    for (const Gap& g : c) hole.push_back(g.a);
    for (auto it = c.rbegin(); it != c.rend(); ++it) hole.push_back(it->b);
    area -= polygonArea(hole, f);
    out.holes.push_back(std::move(hole));
  }
  out.area = std::max(0.0, area);
}

}  // namespace core
}  // namespace tilt_laser_perception
