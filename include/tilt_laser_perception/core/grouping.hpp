/**
 * @file grouping.hpp
 * @brief Scan line grouping (Jiang and Bunke 1994): straight segments of
 *        adjacent scan lines that are coplanar seed a plane; planes grow with
 *        the segments of the next lines that fit them; planes that meet and
 *        agree merge. Runs as scan lines arrive; finish() only merges and
 *        builds the polygons. Plane parameters come from the summed point
 *        moments of the members (exact least squares). ROS-free; [m], [rad].
 */
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "tilt_laser_perception/core/plane.hpp"
#include "tilt_laser_perception/core/surface_tests.hpp"

namespace tilt_laser_perception {
namespace core {

/// A plane found by grouping.
struct Plane {
  int id = 0;
  PlaneFit fit;                       ///< normal points towards the sensor
  double area = 0.0;                  ///< [m^2], outer polygon minus holes
  int points = 0, segments = 0;
  std::vector<int> members;           ///< indices into ScanLineGrouper::segments()
  std::vector<Eigen::Vector3d> boundary;               ///< outer polygon, on the plane
  std::vector<std::vector<Eigen::Vector3d>> holes;     ///< hole polygons, on the plane
};

/// A segment's end point as a corner on its plane: where the point's ray from
/// `origin` meets the plane (range noise and a mixed pixel move a point
/// along its ray only, no farther than twice the grouping's distance
/// threshold), or straight onto the plane where the ray is unknown (NaN
/// origin) or grazes it.
Eigen::Vector3d cornerOnPlane(const Eigen::Vector3d& x, const Eigen::Vector3d& origin, const PlaneFit& f,
                              const GroupingParams& params);

/// Whether chord a0-b0 crosses chord a1-b1 within both (in a plane's 2D
/// coordinates), and where (`at`): a spinning head's lines cross where its
/// axis meets a surface.
bool chordsCross(const Eigen::Vector2d& a0, const Eigen::Vector2d& b0, const Eigen::Vector2d& a1,
                 const Eigen::Vector2d& b1, Eigen::Vector2d& at);

/// Two planes that meet are bounded by their common line: a polygon ends at
/// its last scan line, the surface at the crease, which lies between that
/// line and the other plane's first (the 2-5 cm of a tread next to its riser
/// that no line reaches). Where the polygons of two planes whose normals
/// differ by more than `min_angle_deg` both come within `reach` of their
/// common line (or cross it by no more), the corners of each that lie
/// between `margin` and `reach` from it, or past it by no more than `reach`,
/// beside the stretch of it that the other reaches, are moved to `margin`
/// from it on their own side, within their plane; areas follow. A corner past the line is an overshoot (a spinning
/// line crosses a nosing obliquely, and range noise moves its last point
/// along the line beyond it). The margin is the line's own error: a riser
/// crossed by two or three lines puts it a few millimetres off, and a tread
/// carried past its nosing would claim the floor in front. A polygon whose
/// outline lists its lines' entries and exits (2 corners a line) may also be
/// short of the line by more than `reach` at an outermost line: no line of it
/// saw the band across that line up to where its next line would lie, so
/// those corners are carried across the line by up to the spacing of its two
/// outermost lines (along it, where the line saw its ends, by `reach` at most).
/// A corner near two common lines (a box top's, by its front and its side)
/// goes to the nearer, and to where it meets the next one that runs at
/// `min_angle_deg` or more to it; whatever the planes' order.
void closeCreases(std::vector<Plane>& planes, double reach, double margin, double min_angle_deg);

class ScanLineGrouper {
 public:
  explicit ScanLineGrouper(const GroupingParams& p = GroupingParams()) : tests_(p) {}
  void setParams(const GroupingParams& p) { tests_ = SurfaceTests(p, tests_.sensor()); }
  const GroupingParams& params() const { return tests_.params(); }

  /// Starts a new sweep. `sensor` is where the sensor is (normals are turned towards it).
  void reset(const Eigen::Vector3d& sensor = Eigen::Vector3d::Zero());
  /// Adds the segments of the next scan line (all with the same `line`, increasing).
  void addLine(const std::vector<Segment3>& segments);
  /// The points of scan line `line` by beam (NaN where none), those its
  /// segments were made of; null when unknown.
  using LinePoints = std::function<const std::vector<Eigen::Vector3f>*(int line)>;
  /// Merges, filters and builds the polygons; planes are numbered from 0.
  /// With the lines' points, segments that cross a crease are cut there
  /// (segments() then holds the pieces).
  void finish(std::vector<Plane>& planes, const LinePoints& points = nullptr);

  /// Threads finish() may use: 1 (the default), or 2: the crease votes and
  /// the planes' polygons in two halves on two threads, when there are
  /// kMinSegmentsToShare segments or more; the same planes either way.
  void setThreads(int n) { threads_ = n; }
  static constexpr std::size_t kMinSegmentsToShare = 200;

  const std::vector<Segment3>& segments() const { return segs_; }
  /// After finish(): the plane of each segment, -1 for none.
  const std::vector<int>& segmentPlane() const { return seg_plane_; }

 private:
  /// A plane as it grows: what it holds (SurfaceEvidence) and its members.
  struct Region : SurfaceEvidence {
    std::vector<int> members;
    bool dead = false;  // merged into another
  };
  /// Whether s may join r (and a score, lowest best). `lone`: s is a segment
  /// no plane took (the late joins); beyond the tolerance of r's plane it
  /// may still join if r's plane refitted with it takes it.
  bool fits(const Region& r, const Segment3& s, double& score, bool lone = false) const;
  /// The region `among` those of `min_lines` lines (at least two) or more (not `except`)
  /// that s fits best (`lone`: see fits()); it must overlap a member of the lines near s in beam
  /// index, or with `beside_only` lie beside one (fits()). -1 for none.
  int bestFit(const Segment3& s, const std::vector<int>& among, int except, int min_lines, bool lone = false,
              bool beside_only = false) const;
  /// Whether two segments of different lines seed a plane (side by side,
  /// the shorter beside 30 % of the longer or more, near, coplanar, and no
  /// line between them saw another surface beside them); a score, lowest
  /// for the next line, a whole overlap and a small rms.
  bool pairs(const Segment3& a, const Segment3& b, double& score) const;
  /// A region of one segment.
  int newRegion(int segment);
  /// Pairs that a confirmed plane explains better are taken apart; then
  /// segments left alone pair with a neighbour of an adjacent line, or with
  /// the pieces of one (pairBrokenLines).
  void settlePairs();
  /// A lone segment and a run of lone pieces of the next line, end to end
  /// in beam order (a line the split broke at outliers), seed a plane when
  /// together they lie beside 30 % of it, fit one plane and span it.
  void pairBrokenLines();
  /// The members of r (segment indices, increasing) on lines [line_lo, line_hi].
  std::pair<std::vector<int>::const_iterator, std::vector<int>::const_iterator> membersIn(
      const std::vector<int>& members, int line_lo, int line_hi) const;
  std::pair<std::vector<int>::const_iterator, std::vector<int>::const_iterator> membersIn(const Region& r, int line_lo,
                                                                                         int line_hi) const {
    return membersIn(r.members, line_lo, line_hi);
  }
  /// Whether a member of `a` comes within `limit` of a member of `b` on a
  /// line within max_line_gap + 1 of its own (both segment indices, increasing).
  /// Given the regions (both or neither), where one of them is confirmed,
  /// only where a segment of one ends on a confirmed one's plane (endsOn):
  /// where they meet, it would have joined that plane as it grew; and not
  /// where a segment of either's line lies between the two behind both
  /// planes (its rays passed where the surface would go on).
  bool touch(const std::vector<int>& a, const std::vector<int>& b, double limit, const Region* ra = nullptr,
             const Region* rb = nullptr) const;
  /// cyclic_lines: whether a member of `a` in the sweep's first lines and one
  /// of `b` in its last come within `limit` of each other (or the converse).
  bool touchAcrossSeam(const std::vector<int>& a, const std::vector<int>& b, double limit) const;
  /// The index of the first segment on `line` or after it.
  int firstSegmentOf(int line) const;
  /// line_start_ and spans_ again from segs_ (after segments were cut).
  void indexSegments();
  void absorb(int into, int from);
  void addMember(int region, int segment);     // keeps members sorted, refits
  void removeMember(int region, int segment);  // refits
  /// Whether a neighbour of members[k] in the sorted members (so in line order) lies on its line.
  bool lineShared(const std::vector<int>& members, std::ptrdiff_t k) const;
  /// One pass over the segments on their planes' edges: each goes to a
  /// neighbouring plane it lies nearer to, or, farther than the tolerance
  /// from its own plane fitted without it (if the rest still spans a plane),
  /// leaves that plane (each segment moves once); true when one moved.
  bool moveCreaseSegments(const std::vector<int>& cand, std::vector<char>& moved_once);
  /// A segment that crosses a crease (a line over a yawed box's edge, a
  /// line along a riser's foot) lies on two planes, too gently bent for the
  /// split to see. Cuts out the run of its beams whose rays meet a
  /// neighbouring plane clearly first (concave crease) or last (convex),
  /// four net votes or more; the whole segment if fewer than min_points
  /// points would stay. A lone segment of the next or the line before and
  /// the beams beside it may also span such a plane (a riser crossed by one
  /// line and by the floor's line along its foot): cut out, they seed it.
  /// A segment no plane took that runs from one plane onto another (a line
  /// down a riser and onto the floor at its foot) gives the run of its beams
  /// from one end within the threshold of a confirmed plane to that plane.
  void cutAtCreases(const std::vector<int>& cand, const LinePoints& points);
  void buildPolygon(const Region& r, Plane& out) const;
  /// Drops the planes that hold nothing their bigger neighbours do not: at
  /// least kExplained of their points lie within the distance threshold of
  /// bigger planes they touch (touch() within the distance threshold).
  /// Such a plane is made of pieces that straddle a step smaller than the
  /// split's threshold (a ramp's edge a few centimetres above the floor, the
  /// footprint's blend over it), or of lines that rig errors moved between
  /// two planes: its points are the neighbours' own.
  void dropExplained(std::vector<Plane>& planes, const LinePoints& points) const;
  static constexpr double kExplained = 0.9;

  /// Whether finish() shares its work with a second thread (setThreads()).
  bool shareFinish() const { return threads_ >= 2 && segs_.size() >= kMinSegmentsToShare; }

  SurfaceTests tests_;  // the same-surface decisions, and the parameters and sensor they hold
  const Eigen::Vector3d& sensor() const { return tests_.sensor(); }
  int threads_ = 1;  // setThreads()
  std::vector<Segment3> segs_;
  std::vector<int> line_start_;  // per line: the index of its first segment (or of the next line's)
  /// Each segment's line and beams, apart from the rest: the loops that walk
  /// a plane's members by line read 12 bytes a segment, not its 200.
  struct Span {
    int line, first, last;
  };
  std::vector<Span> spans_;
  std::vector<int> seg_region_;
  std::vector<Region> regions_;
  std::vector<int> open_;  // regions still growing
  std::vector<int> seg_plane_;
  std::vector<int> order_;  // addLine's matching order
  std::vector<std::pair<double, int>> matches_;  // addLine's regions that a segment fits (score, region)
};

}  // namespace core
}  // namespace tilt_laser_perception
