#include "tilt_laser_perception/core/calibration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include <Eigen/Eigenvalues>

namespace tilt_laser_perception {
namespace core {

namespace {
constexpr double kDeg = M_PI / 180.0;
}  // namespace

double& HeadCalibration::operator[](int k) {
  return k == 0 ? joint_offset : k == 1 ? time_offset : k == 2 ? mount_roll : mount_yaw;
}
double HeadCalibration::operator[](int k) const { return const_cast<HeadCalibration&>(*this)[k]; }
const char* HeadCalibration::name(int k) {
  static const char* names[kParams] = {"joint_offset", "time_offset", "mount_roll", "mount_yaw"};
  return names[k];
}

Eigen::Isometry3d HeadCalibration::mount() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.rotate(Eigen::AngleAxisd(mount_yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(mount_roll, Eigen::Vector3d::UnitX()));
  return T;
}

TiltChain HeadCalibration::correct(const TiltChain& chain) const {
  TiltChain c = chain;
  c.joint_to_laser = chain.joint_to_laser * mount();
  return c;
}

std::string CalibrationOptions::validate() const {
  if (!(floor_angle_deg > 0.0 && floor_angle_deg < 45.0)) return "floor_angle_deg must be in (0, 45)";
  if (!(floor_height > 0.0)) return "floor_height must be > 0";
  if (min_plane_points < 10) return "min_plane_points must be >= 10";
  if (max_points_per_plane < 10) return "max_points_per_plane must be >= 10";
  if (!(merge_angle_deg > 0.0 && merge_distance > 0.0)) return "merge_angle_deg and merge_distance must be > 0";
  if (!(trim_sigma >= 2.0)) return "trim_sigma must be >= 2";
  if (max_iterations < 1) return "max_iterations must be >= 1";
  for (int k = 0; k < HeadCalibration::kParams; ++k)
    if (!(max_abs[k] > 0.0 && max_step[k] > 0.0 && max_standard_error[k] > 0.0))
      return "max_abs, max_step and max_standard_error must be > 0";
  return "";
}

HeadCalibrator::HeadCalibrator(const TiltChain& chain, const CalibrationOptions& options) : chain_(chain), o_(options) {}

void HeadCalibrator::addJoint(double t, double q) {
  if (!std::isfinite(t) || !std::isfinite(q)) return;
  if (!joints_.empty() && t <= joints_.back().first) return;
  joints_.emplace_back(t, q);
}

void HeadCalibrator::addSweep(const SweepResult& sw) {
  if (sw.lines.size() < 2) return;
  const auto& a = sw.lines.front().tilt;
  const auto& b = sw.lines.back().tilt;
  if (a.empty() || b.empty()) return;
  const int direction = b[b.size() / 2] > a[a.size() / 2] ? 1 : -1;
  std::vector<int> patch_of_plane(sw.planes.size(), -1);
  for (std::size_t k = 0; k < sw.planes.size(); ++k) {
    if (sw.planes[k].points < o_.min_plane_points) continue;
    patch_of_plane[k] = static_cast<int>(patches_.size());
    patches_.push_back(Patch{{}, sweeps_, direction});
  }
  // The planes' beams, (line, beam), then an even subsample of each (the
  // solve's cost is in the points, and a plane of 2000 is well fixed), and
  // only those put in the laser's frame.
  std::vector<std::vector<std::pair<int, int>>> beams(sw.planes.size());
  for (std::size_t si = 0; si < sw.segments.size() && si < sw.segment_plane.size(); ++si) {
    const int pl = sw.segment_plane[si];
    if (pl < 0 || pl >= static_cast<int>(patch_of_plane.size()) || patch_of_plane[pl] < 0) continue;
    const Segment3& s = sw.segments[si];
    const SweepLine& line = sw.lines[s.line];
    const int end = std::min({s.last + 1, static_cast<int>(line.points.size()), static_cast<int>(line.tilt.size())});
    for (int i = s.first; i < end; ++i)
      if (line.points[i].allFinite()) beams[pl].emplace_back(s.line, i);
  }
  for (std::size_t pl = 0; pl < beams.size(); ++pl) {
    if (patch_of_plane[pl] < 0) continue;
    const auto& all = beams[pl];
    const std::size_t n = std::min<std::size_t>(all.size(), static_cast<std::size_t>(o_.max_points_per_plane));
    auto& samples = patches_[patch_of_plane[pl]].samples;
    samples.reserve(n);
    const double stride = static_cast<double>(all.size()) / std::max<std::size_t>(1, n);
    for (std::size_t j = 0; j < n; ++j) {
      const auto [li, i] = all[static_cast<std::size_t>(j * stride)];
      const SweepLine& line = sw.lines[li];
      const Eigen::Vector3d x = chain_.laserPose(line.tilt[i]).inverse() * line.points[i].cast<double>();
      samples.push_back(Sample{x, line.stamp + i * line.time_increment, li});
    }
  }
  ++sweeps_;
}

namespace {

/// The problem as the solver sees it: samples in patches, patches in groups
/// (one surface; group -1 the floor, fixed at z = 0), and which samples count.
struct Problem {
  struct Point {
    Eigen::Vector3d x;
    double t;
    int group;
    int cluster;  // one scan line's piece of one patch
  };
  std::vector<Point> points;
  std::vector<char> active;
  int groups = 0;
  std::vector<Eigen::Vector3d> ref_normal;  // per group: the sign of its normal
  TiltChain chain;
  const std::vector<std::pair<double, double>>* joints = nullptr;

  /// The reported joint angle at t, hinted by the index of the last look-up; false outside the record.
  bool jointAt(double t, std::size_t& hint, double& q) const {
    const auto& j = *joints;
    if (j.size() < 2 || t < j.front().first || t > j.back().first) return false;
    if (hint >= j.size() - 1 || j[hint].first > t) hint = 0;
    if (j[hint + 1].first < t) {
      // a few steps forward are the usual case; far jumps by binary search
      std::size_t steps = 0;
      while (hint + 1 < j.size() - 1 && j[hint + 1].first < t && ++steps < 8) ++hint;
      if (j[hint + 1].first < t) {
        const auto it = std::lower_bound(j.begin(), j.end(), t,
                                         [](const std::pair<double, double>& s, double v) { return s.first < v; });
        hint = static_cast<std::size_t>(std::max<std::ptrdiff_t>(0, (it - j.begin()) - 1));
      }
    }
    const auto& a = j[hint];
    const auto& b = j[hint + 1];
    if (b.first - a.first > 0.1) return false;  // a gap in the joint states
    q = a.second + (t - a.first) * (b.second - a.second) / (b.first - a.first);
    return true;
  }

  /// Every active point in 3D with the calibration c; false where its time leaves the joint record.
  void transform(const HeadCalibration& c, std::vector<Eigen::Vector3d>& out, std::vector<char>& valid) const {
    const TiltChain ch = c.correct(chain);
    out.resize(points.size());
    valid.assign(points.size(), 0);
    std::size_t hint = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!active[i]) continue;
      double q = 0.0;
      if (!jointAt(points[i].t - c.time_offset, hint, q)) continue;
      out[i] = ch.laserPose(q + c.joint_offset) * points[i].x;
      valid[i] = 1;
    }
  }

  /// Each group's plane (floor: z = 0) at c: normals and centroids.
  void planes(const std::vector<Eigen::Vector3d>& p, const std::vector<char>& valid, std::vector<Eigen::Vector3d>& n,
              std::vector<Eigen::Vector3d>& centroid, std::vector<int>& count) const {
    std::vector<Eigen::Vector3d> sum(groups, Eigen::Vector3d::Zero());
    std::vector<Eigen::Matrix3d> outer(groups, Eigen::Matrix3d::Zero());
    count.assign(groups, 0);
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (!valid[i] || points[i].group < 0) continue;
      const int g = points[i].group;
      sum[g] += p[i];
      outer[g] += p[i] * p[i].transpose();
      ++count[g];
    }
    n.assign(groups, Eigen::Vector3d::UnitZ());
    centroid.assign(groups, Eigen::Vector3d::Zero());
    for (int g = 0; g < groups; ++g) {
      if (count[g] < 3) continue;
      centroid[g] = sum[g] / count[g];
      const Eigen::Matrix3d cov = outer[g] / count[g] - centroid[g] * centroid[g].transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
      n[g] = es.eigenvectors().col(0);
      if (g < static_cast<int>(ref_normal.size()) && n[g].dot(ref_normal[g]) < 0.0) n[g] = -n[g];
    }
  }

  /// Point-to-plane residuals at c (0 where a point is inactive or invalid), their count and sum of squares.
  void residuals(const HeadCalibration& c, Eigen::VectorXd& r, int& used, double& ss) const {
    std::vector<Eigen::Vector3d> p, n, centroid;
    std::vector<char> valid;
    std::vector<int> count;
    transform(c, p, valid);
    planes(p, valid, n, centroid, count);
    r.setZero(static_cast<Eigen::Index>(points.size()));
    used = 0;
    ss = 0.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!valid[i]) continue;
      const int g = points[i].group;
      double e;
      if (g < 0) e = p[i].z();
      else if (count[g] >= 3) e = n[g].dot(p[i] - centroid[g]);
      else continue;
      r[static_cast<Eigen::Index>(i)] = e;
      ss += e * e;
      ++used;
    }
  }

  /// Each group's plane with the points put in 3D at c.
  void planesAt(const HeadCalibration& c, std::vector<Eigen::Vector3d>& n, std::vector<Eigen::Vector3d>& centroid,
                std::vector<int>& count) const {
    std::vector<Eigen::Vector3d> p;
    std::vector<char> valid;
    transform(c, p, valid);
    planes(p, valid, n, centroid, count);
  }

  /// The groups' normals at c become the reference of their signs.
  void setReferenceNormals(const HeadCalibration& c) {
    ref_normal.clear();
    std::vector<Eigen::Vector3d> n, centroid;
    std::vector<int> count;
    planesAt(c, n, centroid, count);
    ref_normal = n;
  }
};

struct Fit {
  HeadCalibration c;
  HeadCalibration se;
  double rms = 0.0;
  int used = 0, iterations = 0;
  bool ok = false;
};

/// Levenberg-Marquardt over the free parameters, the planes refitted at every
/// evaluation (variable projection), the Jacobian by central differences.
Fit solveFree(const Problem& pr, HeadCalibration c, const std::array<bool, HeadCalibration::kParams>& free,
              const CalibrationOptions& o) {
  Fit f;
  std::vector<int> idx;
  for (int k = 0; k < HeadCalibration::kParams; ++k)
    if (free[k]) idx.push_back(k);
  const int m = static_cast<int>(idx.size());
  const auto step = [](int) { return 1e-4; };  // 0.1 mrad, 0.1 ms
  Eigen::VectorXd r;
  double ss = 0.0;
  int used = 0;
  pr.residuals(c, r, used, ss);
  if (used < 10) return f;
  double lambda = 1e-3;
  Eigen::MatrixXd J(r.size(), std::max(1, m));
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(std::max(1, m), std::max(1, m));
  const auto jacobian = [&]() {
    for (int j = 0; j < m; ++j) {
      HeadCalibration a = c, b = c;
      a[idx[j]] += step(idx[j]);
      b[idx[j]] -= step(idx[j]);
      Eigen::VectorXd ra, rb;
      double sa, sb;
      int ua, ub;
      pr.residuals(a, ra, ua, sa);
      pr.residuals(b, rb, ub, sb);
      J.col(j) = (ra - rb) / (2.0 * step(idx[j]));
      // a point valid at one side only (its time at the record's end) counts for neither
      for (Eigen::Index i = 0; i < r.size(); ++i)
        if ((ra[i] == 0.0) != (rb[i] == 0.0) || r[i] == 0.0) J(i, j) = 0.0;
    }
    H = J.transpose() * J;
  };
  for (int it = 0; it < o.max_iterations && m > 0; ++it) {
    f.iterations = it + 1;
    jacobian();
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    Eigen::VectorXd delta;
    for (int tries = 0; tries < 10; ++tries) {
      Eigen::MatrixXd A = H;
      for (int j = 0; j < m; ++j) A(j, j) += lambda * std::max(H(j, j), 1e-12);
      delta = -A.ldlt().solve(g);
      double scale = 1.0;  // the trust region: no parameter moves more than its max_step
      for (int j = 0; j < m; ++j) scale = std::min(scale, o.max_step[idx[j]] / std::max(1e-300, std::abs(delta[j])));
      delta *= scale;
      HeadCalibration cn = c;
      for (int j = 0; j < m; ++j)
        cn[idx[j]] = std::clamp(cn[idx[j]] + delta[j], -o.max_abs[idx[j]], o.max_abs[idx[j]]);
      Eigen::VectorXd rn;
      double ssn;
      int un;
      pr.residuals(cn, rn, un, ssn);
      if (un >= used * 0.99 && ssn / un <= ss / used) {
        c = cn;
        r = rn;
        ss = ssn;
        used = un;
        lambda = std::max(1e-7, lambda * 0.3);
        improved = true;
        break;
      }
      lambda *= 10.0;
    }
    if (!improved) break;
    double biggest = 0.0;
    for (int j = 0; j < m; ++j) biggest = std::max(biggest, std::abs(delta[j]) / step(idx[j]));
    if (biggest < 1e-3) break;  // below a micro-radian, a tenth of a microsecond
  }
  f.c = c;
  f.used = used;
  f.rms = std::sqrt(ss / std::max(1, used));
  if (m > 0) {
    // Cluster-robust (sandwich) covariance H^-1 B H^-1, B the sum over the
    // clusters (a line's piece of a plane) of g g^T, g = J_c^T r_c: errors
    // shared within a line count once, not once a beam.
    jacobian();
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(m, m);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(m);
    int cluster = -1;
    for (std::size_t i = 0; i <= pr.points.size(); ++i) {
      if (i == pr.points.size() || pr.points[i].cluster != cluster) {
        B += g * g.transpose();
        g.setZero();
        if (i == pr.points.size()) break;
        cluster = pr.points[i].cluster;
      }
      g += J.row(static_cast<Eigen::Index>(i)).transpose() * r[static_cast<Eigen::Index>(i)];
    }
    const Eigen::MatrixXd Hi = H.ldlt().solve(Eigen::MatrixXd::Identity(m, m));
    const Eigen::MatrixXd cov = Hi * B * Hi;
    // A parameter that moves no point (a zero column: a recording whose joint
    // angle is held over each scan line does that to a time offset) is not
    // known at all: its error is unbounded, not zero.
    for (int j = 0; j < m; ++j)
      f.se[idx[j]] = H(j, j) > 0.0 && std::isfinite(cov(j, j)) ? std::sqrt(std::max(0.0, cov(j, j)))
                                                               : std::numeric_limits<double>::infinity();
  }
  f.ok = true;
  return f;
}

/// Drops points farther from their plane than k rms; returns how many.
int trim(Problem& pr, const HeadCalibration& c, double k) {
  Eigen::VectorXd r;
  double ss;
  int used;
  pr.residuals(c, r, used, ss);
  const double limit = k * std::sqrt(ss / std::max(1, used));
  int dropped = 0;
  for (std::size_t i = 0; i < pr.points.size(); ++i)
    if (pr.active[i] && std::abs(r[static_cast<Eigen::Index>(i)]) > limit) {
      pr.active[i] = 0;
      ++dropped;
    }
  return dropped;
}

}  // namespace

CalibrationResult HeadCalibrator::solve() const {
  CalibrationResult res;
  res.sweeps = sweeps_;
  const std::string bad = o_.validate();
  if (!bad.empty()) {
    res.notes.push_back("options: " + bad);
    return res;
  }
  {
    std::vector<int> dir(sweeps_, 0);
    for (const Patch& p : patches_) dir[p.sweep] = p.direction;
    res.up_sweeps = static_cast<int>(std::count(dir.begin(), dir.end(), 1));
  }
  if (patches_.empty() || joints_.size() < 2) {
    res.notes.push_back(patches_.empty() ? "no planes of " + std::to_string(o_.min_plane_points) + " points or more"
                                         : "no joint states");
    return res;
  }
  Problem pr;
  pr.chain = chain_;
  pr.joints = &joints_;
  std::vector<int> patch_first;
  int clusters = -1;
  for (std::size_t k = 0; k < patches_.size(); ++k) {
    patch_first.push_back(static_cast<int>(pr.points.size()));
    int last_line = -1;
    for (const Sample& s : patches_[k].samples) {
      if (s.line != last_line) {
        ++clusters;
        last_line = s.line;
      }
      pr.points.push_back(Problem::Point{s.x, s.t, static_cast<int>(k), clusters});
    }
  }
  patch_first.push_back(static_cast<int>(pr.points.size()));
  pr.active.assign(pr.points.size(), 1);
  pr.groups = static_cast<int>(patches_.size());
  // Each patch's plane with the believed geometry: which are the floor.
  std::vector<char> is_floor(patches_.size(), 0);
  HeadCalibration zero;
  std::vector<Eigen::Vector3d> n0, c0;
  std::vector<int> cnt0;
  pr.planesAt(zero, n0, c0, cnt0);
  // The floor: first, in each sweep, the largest patch near z = 0 and near
  // horizontal (with the believed geometry it may be tilted and shifted by
  // the errors; a low step must not be taken for it); after the first pass,
  // every patch that lies on z = 0 as closely as surfaces are merged.
  const auto markFloor = [&](const std::vector<Eigen::Vector3d>& n, const std::vector<Eigen::Vector3d>& c,
                             const std::vector<int>& cnt, double angle_deg, double height, bool largest_only) {
    std::fill(is_floor.begin(), is_floor.end(), 0);
    res.floor_points = 0;
    if (!o_.floor) return;
    std::vector<int> best(sweeps_, -1);
    for (std::size_t k = 0; k < patches_.size(); ++k) {
      if (cnt[k] < 3 || std::abs(n[k].z()) < std::cos(angle_deg * kDeg) || std::abs(c[k].z()) > height) continue;
      int& b = best[patches_[k].sweep];
      if (!largest_only) is_floor[k] = 1;
      else if (b < 0 || cnt[k] > cnt[b]) b = static_cast<int>(k);
    }
    for (int b : best)
      if (b >= 0) is_floor[b] = 1;
    for (std::size_t k = 0; k < patches_.size(); ++k)
      if (is_floor[k]) res.floor_points += patch_first[k + 1] - patch_first[k];
  };
  markFloor(n0, c0, cnt0, o_.floor_angle_deg, o_.floor_height, true);
  // Groups from a patch assignment: floor patches to -1, the others numbered.
  const auto assign = [&](const std::vector<int>& surface_of_patch) {
    int groups = 0;
    for (std::size_t k = 0; k < patches_.size(); ++k) {
      const int g = is_floor[k] ? -1 : surface_of_patch[k];
      groups = std::max(groups, g + 1);
      for (int i = patch_first[k]; i < patch_first[k + 1]; ++i) pr.points[i].group = g;
    }
    pr.groups = groups;
  };

  std::array<bool, HeadCalibration::kParams> free = o_.estimate;
  if (!o_.floor || res.floor_points == 0) {
    if (free[0])
      res.notes.push_back("joint_offset held: no floor (a rotation about the tilt axis leaves every plane flat)");
    free[0] = false;
  }
  // A mount rotation about the joint's own axis is a joint offset (a spinning
  // head whose laser looks along its spin axis: its roll): folded into it.
  const Eigen::Vector3d axis = chain_.axis.normalized();
  const Eigen::Matrix3d mount_axes = chain_.joint_to_laser.linear();
  for (const int k : {2, 3}) {  // roll about the laser's x, yaw about its z
    if (!free[k] || std::abs(mount_axes.col(k == 2 ? 0 : 2).dot(axis)) < std::cos(1.0 * kDeg)) continue;
    free[k] = false;
    res.notes.push_back(std::string(HeadCalibration::name(k)) + " held: about the joint's own axis here, the same as " +
                        "a joint offset: folded into joint_offset");
  }
  const bool both = res.up_sweeps > 0 && res.up_sweeps < sweeps_;
  if (!both && free[1]) {
    res.notes.push_back("time_offset held: sweeps in one direction only (it then looks like a joint offset)");
    free[1] = false;
  }

  // What the data cannot tell is held, and the rest solved again: an estimate
  // at its bound first (the fit ran along a flat direction), then the least
  // certain parameter beyond its limit (unless bounds_only).
  Fit fit;
  const auto hold = [&](bool bounds_only) {
    for (;;) {
      int worst = -1;
      double ratio = 1.0;
      bool at_bound = false;
      for (int k = 0; k < HeadCalibration::kParams; ++k) {
        if (!free[k]) continue;
        if (std::abs(fit.c[k]) >= 0.999 * o_.max_abs[k]) {
          worst = k;
          at_bound = true;
          break;
        }
        if (!bounds_only && fit.se[k] / o_.max_standard_error[k] > ratio) {
          ratio = fit.se[k] / o_.max_standard_error[k];
          worst = k;
        }
      }
      if (worst < 0) break;
      char buf[200];
      const bool time = worst == 1;
      const double unit = time ? 1e3 : 1.0 / kDeg;
      if (at_bound)
        std::snprintf(buf, sizeof(buf), "%s held: not fixed by this scene (the fit ran to its bound, %.1f %s)",
                      HeadCalibration::name(worst), fit.c[worst] * unit, time ? "ms" : "deg");
      else if (!std::isfinite(fit.se[worst]))
        std::snprintf(buf, sizeof(buf), "%s held: not observable in this recording (no point moves with it)",
                      HeadCalibration::name(worst));
      else
        std::snprintf(buf, sizeof(buf), "%s held: not observable in this recording (standard error %.3f %s)",
                      HeadCalibration::name(worst), fit.se[worst] * unit, time ? "ms" : "deg");
      res.notes.push_back(buf);
      free[worst] = false;
      fit.c[worst] = 0.0;
      fit = solveFree(pr, fit.c, free, o_);
    }
  };

  // Pass 1: each sweep's planes on their own, the floor shared.
  std::vector<int> own(patches_.size());
  for (std::size_t k = 0; k < own.size(); ++k) own[k] = static_cast<int>(k);
  assign(own);
  pr.setReferenceNormals(zero);
  fit = solveFree(pr, zero, free, o_);
  if (!fit.ok) {
    res.notes.push_back("too few points on the planes");
    return res;
  }
  hold(true);
  trim(pr, fit.c, o_.trim_sigma);

  // Pass 2: one surface seen in several sweeps is one plane (the up and the
  // down sweeps must agree), merged with the pass-1 estimate.
  std::vector<Eigen::Vector3d> n1, c1;
  std::vector<int> cnt1;
  std::fill(is_floor.begin(), is_floor.end(), 0);
  assign(own);
  pr.ref_normal.clear();
  pr.planesAt(fit.c, n1, c1, cnt1);
  pr.ref_normal = n1;  // the signs from the pass-1 estimate
  markFloor(n1, c1, cnt1, o_.merge_angle_deg, o_.merge_distance, false);
  if (free[0] && res.floor_points == 0) {
    res.notes.push_back("joint_offset held: no floor at z = 0 once corrected (a rotation about the tilt axis leaves "
                        "every plane flat)");
    free[0] = false;
    fit.c.joint_offset = 0.0;
  }
  std::vector<int> order(patches_.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return cnt1[a] > cnt1[b]; });
  std::vector<int> surface(patches_.size(), -1), head;  // head: the first (largest) patch of each surface
  for (int k : order) {
    if (is_floor[k] || cnt1[k] < 3) continue;
    for (std::size_t s = 0; s < head.size(); ++s) {
      const int h = head[s];
      if (std::abs(n1[k].dot(n1[h])) < std::cos(o_.merge_angle_deg * kDeg)) continue;
      if (std::abs(n1[h].dot(c1[k] - c1[h])) > o_.merge_distance || std::abs(n1[k].dot(c1[h] - c1[k])) > o_.merge_distance)
        continue;
      surface[k] = static_cast<int>(s);
      break;
    }
    if (surface[k] < 0) {
      surface[k] = static_cast<int>(head.size());
      head.push_back(k);
    }
  }
  for (std::size_t k = 0; k < surface.size(); ++k)
    if (surface[k] < 0) surface[k] = static_cast<int>(head.size() + k);  // too few points: its own
  assign(surface);
  res.surfaces = static_cast<int>(head.size()) + (res.floor_points > 0 ? 1 : 0);
  pr.setReferenceNormals(fit.c);  // the normals' signs from the pass-1 estimate, near the answer
  fit = solveFree(pr, fit.c, free, o_);
  trim(pr, fit.c, o_.trim_sigma);
  fit = solveFree(pr, fit.c, free, o_);
  hold(false);
  {
    Eigen::VectorXd r;
    double ss;
    int used;
    pr.residuals(zero, r, used, ss);
    res.rms_before = std::sqrt(ss / std::max(1, used));  // on the points kept, with the believed geometry
  }
  res.calibration = fit.c;
  res.standard_error = fit.se;
  res.estimated = free;
  res.rms_after = fit.rms;
  res.points = fit.used;
  res.iterations = fit.iterations;
  res.ok = true;
  // A mount pitch (about the laser's y) is a joint offset where that is the
  // joint's axis (a nodding head); elsewhere (a spinning head, its scan plane
  // along the axis) it tilts the scan plane off the axis, which no parameter
  // here models.
  if (o_.estimate[2] || o_.estimate[3] || o_.estimate[0]) {
    if (std::abs(mount_axes.col(1).dot(axis)) >= std::cos(1.0 * kDeg))
      res.notes.push_back("a mount pitch (about the tilt axis) is the same as a joint offset: folded into joint_offset");
    else
      res.notes.push_back("a mount pitch (about the laser's y axis, not the joint's axis here) is not estimated");
  }
  return res;
}

std::string HeadCalibrator::summary(const CalibrationResult& r) {
  std::string out;
  char buf[160];
  for (int k = 0; k < HeadCalibration::kParams; ++k) {
    const bool time = k == 1;
    const double f = time ? 1e3 : 1.0 / kDeg;
    const char* unit = time ? "ms" : "deg";
    if (r.estimated[k])
      std::snprintf(buf, sizeof(buf), "%s_%s=%.4f %s_%s_se=%.4f ", HeadCalibration::name(k), unit, r.calibration[k] * f,
                    HeadCalibration::name(k), unit, r.standard_error[k] * f);
    else
      std::snprintf(buf, sizeof(buf), "%s_%s=held ", HeadCalibration::name(k), unit);
    out += buf;
  }
  std::snprintf(buf, sizeof(buf), "plane_rms_before_m=%.4f plane_rms_after_m=%.4f", r.rms_before, r.rms_after);
  return out + buf;
}

CalibrationWatch::CalibrationWatch(const TiltChain& chain, const CalibrationWatchOptions& options)
    : chain_(chain), o_(options) {}

void CalibrationWatch::addJoint(double t, double q) {
  if (current_) current_->addJoint(t, q);
  recent_.emplace_back(t, q);
  while (recent_.size() > 2 && recent_.front().first < t - 30.0) recent_.pop_front();  // a slow sweep's
}

std::unique_ptr<HeadCalibrator> CalibrationWatch::addSweep(const SweepResult& sweep) {
  if (!current_) {
    if (sweep.start < next_start_) return nullptr;
    // A new window: this sweep's joint states from its start on.
    next_start_ = sweep.start + o_.period;
    current_ = std::make_unique<HeadCalibrator>(chain_, o_.calibration);
    for (const auto& [t, q] : recent_)
      if (t >= sweep.start - 0.1) current_->addJoint(t, q);
  }
  current_->addSweep(sweep);
  if (current_->sweeps() < o_.sweeps) return nullptr;
  return std::move(current_);
}

bool CalibrationWatch::judge(const CalibrationResult& r, std::string& message) const {
  if (!r.ok) {
    message = "calibration check: no estimate";
    for (const auto& n : r.notes) message += "; " + n;
    return false;
  }
  bool drifted = false;
  std::string off;
  for (int k = 0; k < HeadCalibration::kParams; ++k) {
    if (!r.estimated[k]) continue;
    const double v = r.calibration[k];
    if (std::abs(v) > o_.limit[k] && std::abs(v) > o_.sigmas * r.standard_error[k]) {
      drifted = true;
      const bool time = k == 1;
      char buf[120];
      std::snprintf(buf, sizeof(buf), "%s%s %+.3f %s", off.empty() ? "" : ", ", HeadCalibration::name(k),
                    v * (time ? 1e3 : 1.0 / kDeg), time ? "ms" : "deg");
      off += buf;
    }
  }
  char rms[96];
  std::snprintf(rms, sizeof(rms), " (plane rms %.1f mm, %.1f mm with it; %d sweeps)", r.rms_before * 1e3,
                r.rms_after * 1e3, r.sweeps);
  message = drifted ? "the head's calibration has drifted: " + off + rms +
                          "; record a few sweeps and run calibrate, or apply: " + HeadCalibrator::summary(r)
                    : std::string("calibration holds") + rms;
  return drifted;
}

CalibrationMonitor::CalibrationMonitor(const TiltChain& chain, const CalibrationWatchOptions& options)
    : chain_(chain), o_(options) {}

CalibrationMonitor::~CalibrationMonitor() {
  if (check_.valid()) check_.wait();
}

void CalibrationMonitor::addJoint(double t, double q) {
  if (watch_) watch_->addJoint(t, q);
}

bool CalibrationMonitor::poll() {
  if (!check_.valid() || check_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return false;
  const CalibrationResult r = check_.get();
  ++checks_;
  drifted_ = watch_ && watch_->judge(r, message_);
  return true;
}

void CalibrationMonitor::addSweep(const SweepResult& sweep, const Eigen::Isometry3d& base) {
  // The check solves for a head that stands: a base that moved (1 cm, 0.01
  // rad: far beyond what standing sways) starts the window again at its new place.
  if (watch_ && ((base.translation() - base_.translation()).norm() > 0.01 ||
                 Eigen::AngleAxisd(base.linear() * base_.linear().transpose()).angle() > 0.01)) {
    watch_.reset();
    message_ = "waiting for the robot to stand still";
  }
  if (!watch_) {
    base_ = base;
    TiltChain chain = chain_;
    chain.base_to_joint = base * chain.base_to_joint;
    watch_ = std::make_unique<CalibrationWatch>(chain, o_);
    return;  // its joint states start now: the next sweep is its first
  }
  std::shared_ptr<HeadCalibrator> full = watch_->addSweep(sweep);
  if (full && !check_.valid()) check_ = std::async(std::launch::async, [full] { return full->solve(); });
}

}  // namespace core
}  // namespace tilt_laser_perception
