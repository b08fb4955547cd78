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

namespace tilt_laser_perception {
namespace core {

/// A straight segment of one scan line, in 3D.
struct Segment3 {
  int line = 0;               ///< scan line index in the sweep
  int first = 0, last = 0;    ///< beam indices (inclusive)
  Eigen::Vector3d start = Eigen::Vector3d::Zero(), end = Eigen::Vector3d::Zero();  ///< end points [m]
  Moments3 moments;           ///< of its points in 3D
  double range = 0.0;         ///< mean range of its points [m]
  /// Where the sensor saw it from (NaN: unknown). Range noise moves a point
  /// along its ray, so a polygon corner is put where the ray meets the plane.
  Eigen::Vector3d origin = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double length() const { return (end - start).norm(); }
};

/// A segment of the points pts[first..last] (NaN points skipped) with their
/// ranges: moments, mean range, and end points on the points' own line.
/// False when fewer than two points are valid. For Vector3d points with
/// double ranges, and Vector3f points with float ranges (a scan's own).
template <class Point, class Range>
bool makeSegment3(const std::vector<Point>& pts, const std::vector<Range>& ranges, int line, int first, int last,
                  Segment3& out);

struct GroupingParams {
  double dist_min = 0.03;         ///< plane distance threshold floor [m]
  double dist_ratio = 0.015;      ///< threshold growth with range [1]
  double centroid_min = 0.012;    ///< a segment's centroid must lie this close to the plane [m] ...
  double centroid_ratio = 0.005;  ///< ... plus this much of its range [1] (a fitted line is far less noisy than its points)
  double angle_deg = 12.0;        ///< a segment may leave its plane by this much [deg]
  double merge_angle_deg = 15.0;  ///< the most two planes' normals may differ by and merge, however uncertain (within it the noise model judges them, and their union must fit each); a crease cut's new plane differs by more [deg]
  double seed_gap = 0.25;         ///< largest distance between the segments that seed a plane [m] (+ 5 % of range)
  int beam_slack = 8;             ///< beam index slack for overlap between adjacent lines
  int max_line_gap = 2;           ///< a plane stays open this many lines without a new segment
  int min_segments = 2;           ///< smaller planes are dropped (a riser may be crossed by two lines only)
  double min_area = 0.01;         ///< [m^2]
  int min_points = 8;             ///< segments with fewer points than this are left out
  double crease_reach = 0.08;     ///< two planes' polygons that both end this close to their common line are carried to it (closeCreases) ... [m]
  double crease_margin = 0.005;   ///< ... up to this far from it; reach <= margin: never [m]
  /// The noise model's line term: each scan line's own pose error (tilt
  /// encoder, backlash, timing), common to all its points, moves a whole line
  /// by about range * line_sigma out of its scan plane [rad, 1 sigma]; 0: the
  /// tolerances above hold alone. A line is taken to be on a plane while it
  /// lies within `significance` of these sigmas of it.
  double line_sigma = 0.0;
  double significance = 3.0;  ///< [sigmas]
  /// The sweep's last line lies beside its first (a spinning head's half or
  /// whole turn ends in the plane it began in): planes that meet across that
  /// seam merge as planes that meet anywhere else.
  bool cyclic_lines = false;
  /// The laser's distance from the axis it turns about [m] (0: unknown). Each
  /// scan plane touches the cylinder of this radius about the axis, so the
  /// points beside the laser, whatever their surface, lie near the scan
  /// planes' common tangent: a plane that passes nearer than this to where
  /// its lines were seen from (root mean square) fixes no normal.
  double arm = 0.0;
  std::string validate() const;
  /// How far a segment's points may lie from its plane [m].
  double threshold(double range) const {
    return std::max({dist_min, dist_ratio * range, significance * line_sigma * range});
  }
  /// How far a segment's centroid may lie from its plane [m]: a fitted line is far less noisy than its
  /// points, but its pose error is its points' too.
  double centroidTolerance(double range) const {
    return std::max({centroid_min, centroid_ratio * range, significance * line_sigma * range});
  }
};

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
  explicit ScanLineGrouper(const GroupingParams& p = GroupingParams()) : p_(p) {}
  void setParams(const GroupingParams& p) { p_ = p; }
  const GroupingParams& params() const { return p_; }

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
  struct Region {
    Moments3 moments;
    std::vector<int> members;
    int first_line = 0, last_line = 0;
    int lines = 0;       // distinct scan lines among the members
    PlaneFit fit;
    bool dead = false;   // merged into another
    /// The scan plane's normal at its first segment (zero: unknown). The
    /// points of one scan line all lie in its scan plane, which they fit
    /// whatever the surface: only their spread out of it, across the lines,
    /// fixes the surface's normal.
    Eigen::Vector3d across = Eigen::Vector3d::Zero();
    /// Its members' rays: the sum over them of points x u u^T, u the unit
    /// ray from a segment's origin to its centroid (raysOf()). n^T rays n over
    /// its trace (the points with a known origin) is the mean squared sine at
    /// which they meet a plane of normal n.
    Eigen::Matrix3d rays = Eigen::Matrix3d::Zero();
    /// Where its members were seen from: each origin weighted by its
    /// segment's points (originsOf()).
    Moments3 origins;
  };
  /// Whether s may join r (and a score, lowest best). `lone`: s is a segment
  /// no plane took (the late joins); beyond the tolerance of r's plane it
  /// may still join if r's plane refitted with it takes it.
  bool fits(const Region& r, const Segment3& s, double& score, bool lone = false) const;
  /// How far r's points spread across its lines within its plane [m]
  /// (counted less where the plane lies within 30 degrees of its first scan
  /// plane, where one line's own spread would pass for it; none where the
  /// rays that saw its points graze its plane).
  double spreadAcross(const Region& r) const;
  /// A segment's share of Region::rays (zero where its origin is unknown).
  static Eigen::Matrix3d raysOf(const Segment3& s);
  /// A segment's share of Region::origins (none where its origin is unknown).
  static Moments3 originsOf(const Segment3& s);
  /// Whether r's lines lie far enough apart to fix its normal.
  bool planar(const Region& r) const { return r.last_line > r.first_line && spreadAcross(r) > kPlanarSpread; }
  /// Points spread this much across their lines, or more, fix a normal [m].
  static constexpr double kPlanarSpread = 0.02;
  /// Three lines or more span a plane (two parallel lines fit any plane
  /// through both), if they lie far enough apart.
  bool confirmed(const Region& r) const { return r.lines >= 3 && planar(r); }
  /// The region `among` those of `min_lines` lines (at least two) or more (not `except`)
  /// that s fits best (`lone`: see fits()); it must overlap a member of the lines near s. -1 for none.
  int bestFit(const Segment3& s, const std::vector<int>& among, int except, int min_lines, bool lone = false) const;
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
  /// Whether both ends of s lie within kEndsOn thresholds of r's plane, and
  /// beyond its centroid within what the line term leaves its tilt
  /// uncertain (lineTilt) over the distance: a segment joins a plane only so.
  bool endsOn(const Segment3& s, const Region& r) const;
  /// A segment's end is one beam, as noisy as any point, where its fit is
  /// not: it may lie 1.5 distance thresholds off (the growth's factor since
  /// its start, set by hand, not yet from the noise model).
  static constexpr double kEndsOn = 1.5;
  /// The tangent of the tilt the line term leaves r's plane uncertain by
  /// (significance sigmas; 0 without a line term).
  double lineTilt(const Region& r) const;
  /// The covariance of r's normal [rad^2], from the noise model: each of its
  /// lines one measurement of the surface (see the definition).
  Eigen::Matrix3d normalCovariance(const Region& r) const;
  /// A normal's variance where a region fixes none (one line, no spread).
  static constexpr double kUnknownNormal = 1e6;
  /// cyclic_lines: whether a member of `a` in the sweep's first lines and one
  /// of `b` in its last come within `limit` of each other (or the converse).
  bool touchAcrossSeam(const std::vector<int>& a, const std::vector<int>& b, double limit) const;
  /// The index of the first segment on `line` or after it.
  int firstSegmentOf(int line) const;
  /// line_start_ and spans_ again from segs_ (after segments were cut).
  void indexSegments();
  /// Whether a and b are one surface; `score`: the worst part's rms about
  /// their union's plane over the distance threshold (how well it explains them).
  bool planesAgree(const Region& a, const Region& b, double* score = nullptr) const;
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

  GroupingParams p_;
  int threads_ = 1;  // setThreads()
  Eigen::Vector3d sensor_ = Eigen::Vector3d::Zero();
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
