/**
 * @file sweep.hpp
 * @brief Sweep assembly: joint angles interpolated at every beam's own time,
 *        scan lines put in 3D through the tilt chain, sweeps cut at the tilt
 *        reversals, and scan line grouping run as lines arrive. ROS-free;
 *        time [s], angles [rad], lengths [m].
 */
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tilt_laser_perception/core/grouping.hpp"
#include "tilt_laser_perception/core/scan_split.hpp"

namespace tilt_laser_perception {
namespace core {

/// The kinematic chain from the assembly frame to the laser through the tilt joint:
/// laser pose = base_to_joint * rotation(axis, q) * joint_to_laser.
struct TiltChain {
  Eigen::Isometry3d base_to_joint = Eigen::Isometry3d::Identity();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();
  Eigen::Isometry3d joint_to_laser = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d laserPose(double q) const {
    return base_to_joint * Eigen::AngleAxisd(q, axis) * joint_to_laser;
  }
};

/// Joint angles over time; linear interpolation; gaps and disorder detected.
class JointBuffer {
 public:
  explicit JointBuffer(double max_gap = 0.05, double keep = 5.0) : max_gap_(max_gap), keep_(keep) {}
  /// Adds a sample; false (not added) when its stamp is not after the last one.
  bool add(double t, double q);
  /// The angle at t; false when t is outside the buffer or falls in a gap longer than max_gap.
  bool at(double t, double& q) const;
  /// The angles at t0, t0 + dt, ..., t0 + (n - 1) dt in one pass; false like at().
  bool sample(double t0, double dt, std::size_t n, std::vector<double>& q) const;
  double latest() const { return samples_.empty() ? -1e300 : samples_.back().first; }
  bool empty() const { return samples_.empty(); }
  void clear() { samples_.clear(); }

 private:
  double max_gap_, keep_;
  std::deque<std::pair<double, double>> samples_;
};

struct SweepParams {
  double reversal_hysteresis = 0.005;  ///< the joint must come back this far from an extreme to count as a reversal [rad]
  /// 0: a nodding head, whose sweeps end at its reversals. > 0: a spinning
  /// head (the joint turns on, its readings wrapped or not): the angle is
  /// unwrapped, and a sweep ends each time it passes a multiple of this
  /// (pi: a half turn, which sees everything once) [rad].
  double spin_span = 0.0;
  double max_joint_gap = 0.05;         ///< longest gap between joint states to interpolate over [s]
  double max_wait = 0.3;               ///< a scan line waits this long for joint states [s]
  double max_dropped_fraction = 0.1;   ///< a sweep with more dropped lines is dropped [1]
  int min_lines = 10;                  ///< shorter sweeps are dropped
  int max_lines = 1000;                ///< longer ones too (no tilt reversal: the head stands still), so memory stays bounded
  double time_jump_back = 1.0;          ///< stamps this far before the latest, twice in a row: the clock restarted (a looping bag), start again [s]
  ScanLimits scan_limits;              ///< lines beyond these are dropped as malformed
  bool per_beam = true;                ///< joint angle at every beam's time; false: one per line, at its stamp (as tools that look up one tf per scan do)
  /// For evaluation: each sweep's lines grouped at its end in the other
  /// order (last line first), the result given back in the lines' own
  /// numbering. The planes should not depend on it (evaluate --reverse).
  bool reverse_lines = false;
  GroupingParams grouping;
  /// Empty when valid (these, the scan limits and the grouping's), else a message naming the parameter.
  std::string validate() const;
};

/// A scan line put in 3D (organized: one entry per beam, NaN where there is no return).
struct SweepLine {
  double stamp = 0.0;            ///< time of beam 0 [s]
  double time_increment = 0.0;   ///< [s]
  std::vector<Eigen::Vector3f> points;
  std::vector<float> intensities;  ///< empty when the scan had none
  std::vector<float> tilt;         ///< joint angle at each beam [rad]
  std::vector<std::pair<int, EdgeKind>> edges;
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();  ///< where the laser was at the middle beam [m]
  /// Beams before returns_begin and from returns_end on have no return (a
  /// 270-degree scan's rear beams often see nothing): passes over the line's
  /// loose points skip them. The defaults say nothing (the whole line).
  int returns_begin = 0, returns_end = std::numeric_limits<int>::max();
  /// [first, last + 1) of the beams with a return, within the line.
  std::pair<int, int> returns() const {
    return {std::max(0, returns_begin), std::min(static_cast<int>(points.size()), returns_end)};
  }
};

/// A finished sweep.
struct SweepResult {
  std::uint32_t id = 0;
  double start = 0.0, end = 0.0;    ///< reversal times [s]
  std::vector<SweepLine> lines;
  std::vector<Segment3> segments;   ///< all segments, lines in order
  std::vector<int> segment_plane;   ///< plane of each segment, -1 none
  std::vector<Plane> planes;
  /// What its planes were grouped with: the tolerances the height map holds
  /// a plane's points and corners to are the same.
  GroupingParams grouping;
  int dropped_lines = 0;            ///< lines dropped, and lines that never came (an outage), within the sweep
  double group_seconds = 0.0;       ///< CPU time of putting lines in 3D and grouping them as they came [s]
  double finish_seconds = 0.0;      ///< time from the sweep's end to its planes [s]
};

/// Counters for diagnostics.
struct SweepCounters {
  unsigned long lines = 0, lines_no_joint = 0, lines_out_of_order = 0, lines_no_pose = 0, lines_bad = 0,
                joints_out_of_order = 0, joints_bad = 0, sweeps = 0, sweeps_dropped = 0, reversals = 0, time_jumps = 0;
  /// Lines put in 3D while no sweep was open (before the first reversal): kept in none.
  unsigned long lines_outside_sweeps = 0;
  /// Everything dropped or restarted so far (a change asks for a warning).
  unsigned long problems() const {
    return lines_no_joint + lines_no_pose + lines_out_of_order + lines_bad + joints_out_of_order + joints_bad +
           sweeps_dropped + time_jumps;
  }
};

/// One scan line with its split, as the assembler takes it (copied).
struct LineInput {
  std::vector<float> ranges, intensities;
  double angle_min = 0.0, angle_increment = 0.0, range_min = 0.0, range_max = 0.0;
  double stamp = 0.0;            ///< time of beam 0 [s]
  double time_increment = 0.0;   ///< [s]
  std::vector<std::pair<int, int>> segments;           ///< beam ranges of the split's segments
  std::vector<std::pair<int, EdgeKind>> edges;
};

class SweepAssembler {
 public:
  /// Whether the pose of the chain's base is known at a time: Ok; Wait (not
  /// yet: the transforms have not reached that time, the line waits up to
  /// max_wait); Missing (a gap that will not fill: the line is dropped).
  enum class PoseStatus { Ok, Wait, Missing };
  /// Pose of the chain's base frame in the assembly frame at time t.
  using BasePose = std::function<PoseStatus(double t, Eigen::Isometry3d& pose)>;

  SweepAssembler(const SweepParams& params, const TiltChain& chain, BasePose base_pose = nullptr);
  void setParams(const SweepParams& p);
  /// Grouping settings for the sweeps to come: the sweep in progress keeps its own.
  void setGroupingParams(const GroupingParams& g);
  /// The grouping settings of the sweep in progress, with what the chain and
  /// the sweep's span give (GroupingParams::arm, cyclic_lines).
  const GroupingParams& groupingParams() const { return grouper_.params(); }

  /// Takes a joint sample. A time or angle that is not finite is dropped
  /// (joints_bad); a time before the latest is dropped as out of order,
  /// unless it is the second in a row that far back (a restarted clock).
  void addJoint(double t, double q);
  /// Queues a scan line; it is put in 3D once the joint states cover its last
  /// beam. A line that checkScan() refuses or whose stamp is not finite is
  /// dropped at once (lines_bad), so it never holds up the lines behind it.
  void addLine(LineInput line, double arrival);
  /// Processes what it can; true when a sweep finished (in `out`). Call until false.
  bool poll(double now, SweepResult& out);
  /// The end of the input (a recording's end): the lines still queued are
  /// taken or dropped as poll() would after max_wait, then the sweep in
  /// progress is finished after its last line, as a reversal there would
  /// (subject to min_lines and the dropped share, like any sweep). True when
  /// a sweep finished (in `out`). Call until false.
  bool flush(double now, SweepResult& out);

  const SweepCounters& counters() const { return counters_; }
  /// Lines waiting for joint states.
  std::size_t pending() const { return queue_.size(); }
  /// What the first waiting line waits for after the last poll (Nothing when
  /// none waits): a caller that is told of new joint states or new poses
  /// polls again only when they may let it go.
  enum class Waiting { Nothing, Joints, Pose };
  Waiting waiting() const { return waiting_; }
  /// Lines in the sweep being assembled.
  std::size_t linesInSweep() const { return in_sweep_ ? current_.lines.size() : 0; }
  /// The last warning (why a line or sweep was dropped), for throttled logs.
  const std::string& lastWarning() const { return warning_; }

 private:
  std::optional<GroupingParams> next_grouping_;  ///< from setGroupingParams, taken when the next sweep begins
  std::vector<std::vector<Segment3>> held_;      ///< reverse_lines: the sweep's segments, line by line, grouped at its end
  /// The base's motion within a line: its pose at the middle beam, and the
  /// change of its position and orientation (rotation vector) from the first
  /// beam to the last, in the assembly frame (zero when it stands still).
  struct LineMotion {
    Eigen::Isometry3d mid = Eigen::Isometry3d::Identity();
    Eigen::Vector3d dp = Eigen::Vector3d::Zero(), dtheta = Eigen::Vector3d::Zero();
    bool moving() const { return !dp.isZero(0.0) || !dtheta.isZero(0.0); }
  };
  /// The base's pose at the line's first and last beam (one look-up at its
  /// middle when per_beam is off): Ok, Wait or Missing, the worst of the two.
  PoseStatus lineMotion(const LineInput& in, double mid, LineMotion& motion) const;
  Waiting waiting_ = Waiting::Nothing;
  bool process(const LineInput& in, const LineMotion& motion);
  /// The clock went back (a recording looped, a simulation restarted): forget
  /// the joints, queued lines and the sweep in progress.
  void restart();
  /// Whether stamp t, before `latest` by more than time_jump_back, is a
  /// restarted clock: only when the previous one was too (`suspect` holds it).
  enum class Jump { None, Suspect, Restart };
  Jump jumpBack(double t, double latest, double& suspect) const;
  bool finishSweep(double end, SweepResult& out);
  /// A line of the sweep in progress, at its middle, was kept or dropped.
  void takeLine(double mid, bool kept);
  void beginSweep(double start);
  /// Puts the line's beams in 3D at their joint angles (q_); returns where the laser was at the middle beam.
  Eigen::Vector3d transformBeams(const LineInput& in, const LineMotion& motion, SweepLine& line);

  SweepParams p_;
  TiltChain chain_;
  BasePose base_pose_;
  JointBuffer joints_;
  std::deque<std::pair<LineInput, double>> queue_;
  std::deque<double> reversals_;
  int direction_ = 0;
  bool have_extreme_ = false;
  double last_mid_ = -1e300;
  /// The line period: the median of the last intervals between lines (a gap
  /// of an outage does not move it; a new scan rate does within a few lines) [s].
  double linePeriod() const;
  /// Lines that should lie between two line middles a and b but never came.
  int missingBetween(double a, double b) const;
  std::array<double, 8> intervals_{};
  int n_intervals_ = 0;
  double sweep_last_mid_ = 0.0;  ///< middle of the last line taken for the sweep in progress (kept or dropped) [s]
  double extreme_q_ = 0.0, extreme_t_ = 0.0, last_joint_t_ = -1e300;
  double last_raw_q_ = 0.0, last_q_ = 0.0;  ///< spin: the last reading as it came and unwrapped [rad]
  /// Spin: the sweep boundaries (multiples of spin_span) the joint passed
  /// from (t0, q0) to (t1, q1), at their times by interpolation.
  void spinBoundaries(double t0, double q0, double t1, double q1);
  ScanLineGrouper grouper_;
  bool in_sweep_ = false;
  SweepResult current_;
  double last_line_stamp_ = -1e300, last_line_added_ = -1e300;
  /// Where the latest sweep that no sweep came before began (the first, or the
  /// next after one dropped): the lines before it are in none, even those that
  /// come after it began (joint states run ahead of the scans).
  double first_start_ = -1e300;
  double joint_jump_ = std::numeric_limits<double>::quiet_NaN(), line_jump_ = std::numeric_limits<double>::quiet_NaN();
  std::uint32_t next_id_ = 0;
  SweepCounters counters_;
  std::string warning_;
  // per-line buffers
  std::vector<double> q_;
  std::vector<float> ux_, uy_, uz_;  // beam directions in the joint frame
  std::vector<float> dq_, c_, s_, px_, py_, pz_;
  double trig_min_ = 0.0, trig_inc_ = 0.0;
};

/// Where the laser was during a sweep: the mean of its lines' origins (zero without lines).
Eigen::Vector3d meanOrigin(const SweepResult& sweep);

/// The time of the last beam of a sweep's last line (its end without lines):
/// the latest time the assembler had the base's pose for. Its end, the
/// reversal, may lie later, where a live run may not have the pose yet.
double lastBeamTime(const SweepResult& sweep);

/// Moves a finished sweep rigidly (points, origins, segments, planes and their
/// polygons): p -> T p. What a tool that puts a whole sweep in the world with
/// one pose does (evaluate --no-pose), and how a sweep changes frame.
void transformSweep(SweepResult& sweep, const Eigen::Isometry3d& T);

}  // namespace core
}  // namespace tilt_laser_perception
