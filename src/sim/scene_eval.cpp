#include "tilt_laser_perception/sim/scene_eval.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "tilt_laser_perception/dynamixel/mx64.hpp"
#include "tilt_laser_perception/sim/evaluation.hpp"

namespace tilt_laser_perception {
namespace sim {

namespace {
double cpuNow() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

}  // namespace

core::TiltChain headChain(const HeadGeometry& g) {
  core::TiltChain c;
  c.base_to_joint = Eigen::Isometry3d::Identity();
  c.base_to_joint.translation() = g.axis_origin;
  c.base_to_joint.rotate(Eigen::AngleAxisd(g.tilt_offset, Eigen::Vector3d::UnitY()));
  c.axis = Eigen::Vector3d::UnitY();
  c.joint_to_laser = Eigen::Isometry3d::Identity();
  c.joint_to_laser.translation() = g.laser_offset;
  return c;
}

namespace {

struct LineTruth {
  std::vector<int> face;
  std::vector<float> ranges;
  std::vector<TrueEdge> edges;
  std::vector<core::EdgePoint> found;
  int veil_segments = 0;  // segments most of whose points are mixed pixels
  int overhanging = 0;    // segments with own points more than 1 cm beyond their ends
};

SweepEval judge(const Scene& scene, const std::vector<float>& truth_h, const core::SweepResult& sw,
                const std::map<double, LineTruth>& truth, const std::map<double, double>& split_time,
                const SceneEvalOptions& o, double latency, core::HeightMapGrid& grid) {
  SweepEval e;
  e.lines = static_cast<int>(sw.lines.size());
  // Points judged: valid returns within the radius; their true face and detected plane.
  RegionOverlap ov;
  std::vector<std::vector<int>> plane_of(sw.lines.size());
  for (std::size_t li = 0; li < sw.lines.size(); ++li) plane_of[li].assign(sw.lines[li].points.size(), -1);
  std::vector<core::Plane> external_planes;
  if (o.segmenter) {
    const double t0 = cpuNow();
    o.segmenter(sw, plane_of, external_planes);
    e.external_ms = (cpuNow() - t0) * 1e3;
  } else {
    for (std::size_t si = 0; si < sw.segments.size(); ++si) {
      const core::Segment3& s = sw.segments[si];
      for (int i = s.first; i <= s.last; ++i) plane_of[s.line][i] = sw.segment_plane[si];
    }
  }
  const std::vector<core::Plane>& planes = o.segmenter ? external_planes : sw.planes;
  e.planes = static_cast<int>(planes.size());
  int edges_found = 0, edges_spurious = 0, edges_true = 0, edges_hit = 0;
  for (std::size_t li = 0; li < sw.lines.size(); ++li) {
    const auto it = truth.find(sw.lines[li].stamp);
    if (it == truth.end()) continue;
    const LineTruth& t = it->second;
    e.veil_segments += t.veil_segments;
    e.overhanging_segments += t.overhanging;
    const EdgeScore es = scoreEdges(t.found, t.edges);
    edges_found += es.edge_points;
    edges_spurious += es.spurious;
    edges_true += es.true_edges;
    edges_hit += es.found;
    for (std::size_t i = 0; i < sw.lines[li].points.size(); ++i) {
      const Eigen::Vector3f& p = sw.lines[li].points[i];
      if (!std::isfinite(p.x()) || std::hypot(p.x(), p.y()) > o.eval_radius) continue;
      ov.add(t.face[i], plane_of[li][i]);
    }
  }
  e.edge_precision = edges_found ? 1.0 - static_cast<double>(edges_spurious) / edges_found : 1.0;
  e.edge_recall = edges_true ? static_cast<double>(edges_hit) / edges_true : 1.0;

  const HooverScore h = hooverScore(
      ov, o.overlap,
      [&](int f) { return ov.truth_count.at(f) >= o.min_face_points && scene.faces[f].area() >= o.min_face_area; },
      o.min_face_points);
  e.true_faces = h.expected;
  e.correct = h.correct;
  e.over = h.over;
  e.under = h.under;
  e.missed = h.missed;
  e.noise = h.noise;
  for (const auto& [d, f] : h.correct_pairs) {
    const Face& face = scene.faces[f];
    const core::Plane& pl = planes[d];
    e.normal_err_deg += std::acos(std::min(1.0, std::abs(pl.fit.normal.dot(face.normal)))) * 180.0 / M_PI / e.correct;
    e.offset_err_m += std::abs(face.normal.dot(pl.fit.centroid - face.origin)) / e.correct;
  }
  const auto& face_count = ov.truth_count;
  const auto& plane_count = ov.found_count;
  const auto& overlap = ov.overlap;
  for (int f : h.missed_truth) {
    // Where its points went: "object/label (N points: plane:count ..., none:count)".
    std::string where = scene.faces[f].object + "/" + scene.faces[f].label + " (" +
                        std::to_string(face_count.at(f)) + " points:";
    int assigned = 0;
    for (const auto& [key, n] : overlap)
      if (key.second == f) {
        where += " plane" + std::to_string(key.first) + "[" + std::to_string(plane_count.at(key.first)) +
                 "]:" + std::to_string(n);
        assigned += n;
      }
    where += " none:" + std::to_string(face_count.at(f) - assigned) + ")";
    e.missed_faces.push_back(where);
    if (o.segmenter) continue;
    for (std::size_t si = 0; si < sw.segments.size(); ++si) {
      const core::Segment3& s = sw.segments[si];
      const auto it = truth.find(sw.lines[s.line].stamp);
      if (it == truth.end()) continue;
      std::map<int, int> faces;
      for (int i = s.first; i <= s.last; ++i) ++faces[it->second.face[i]];
      const int pl = sw.segment_plane[si];
      const auto on_face = overlap.find({pl, f});
      const auto on_it = faces.find(f);
      if ((on_it == faces.end() || on_it->second < 3) && !(on_face != overlap.end() && on_face->second >= 0.1 * face_count.at(f))) continue;
      int mf = -1, mn = -1;
      for (const auto& [face, n] : faces)
        if (n > mn) {
          mn = n;
          mf = face;
        }
      e.missed_segments.push_back(
          scene.faces[f].label + ": line " + std::to_string(s.line) + " beams " + std::to_string(s.first) + "-" +
          std::to_string(s.last) + " (" + std::to_string(static_cast<int>(s.moments.n)) + " points, " +
          std::to_string(on_it == faces.end() ? 0 : on_it->second) + " on it, mostly " +
          (mf >= 0 ? scene.faces[mf].object + "/" + scene.faces[mf].label : std::string("none")) + ") -> plane " +
          std::to_string(pl));
    }
  }

  // Height map against the true one, within the radius (the grid is kept
  // from sweep to sweep, as the grouper nodelet keeps it).
  const double t0 = cpuNow();
  core::buildHeightMap(sw, o.heightmap, grid);
  latency += cpuNow() - t0;
  if (!o.dump_prefix.empty()) dumpSweep(sw, grid, o.dump_prefix);
  const core::HeightMapParams& hp = o.heightmap;
  double se = 0.0;
  int known = 0, expected_cells = 0;
  for (int iy = 0; iy < hp.height; ++iy)
    for (int ix = 0; ix < hp.width; ++ix) {
      const double x = hp.origin_x + (ix + 0.5) * hp.resolution, y = hp.origin_y + (iy + 0.5) * hp.resolution;
      if (std::hypot(x, y) > o.heightmap_radius) continue;
      const std::size_t c = grid.index(ix, iy);
      if (std::isnan(truth_h[c])) continue;
      ++expected_cells;
      if (std::isnan(grid.heights[c])) continue;
      ++known;
      se += (grid.heights[c] - truth_h[c]) * (grid.heights[c] - truth_h[c]);
    }
  e.heightmap_rmse_m = known ? std::sqrt(se / known) : 0.0;
  e.heightmap_coverage = expected_cells ? static_cast<double>(known) / expected_cells : 0.0;
  double split = 0.0;
  for (const auto& line : sw.lines) {
    const auto it = split_time.find(line.stamp);
    if (it != split_time.end()) split += it->second;
  }
  e.split_ms = split * 1e3;
  e.group_ms = (sw.group_seconds + latency) * 1e3;
  e.latency_ms = latency * 1e3;
  return e;
}
}  // namespace

std::vector<SweepEval> evaluateScene(const SceneEvalOptions& o) {
  const Scene scene = loadScene(o.scene);
  const HeadGeometry head = HeadGeometry::load(o.head_file.empty() ? configDirectory() + "/head.yaml" : o.head_file);
  ServoModel servo(o.profile.min_angle, 0.0);
  SweepController sweep(servo, o.profile);
  HeadSimulator head_sim(scene, head, servo, o.noise, o.seed, LidarModel(), o.rig);
  const LidarModel& m = head_sim.model();
  core::SweepAssembler assembler(o.sweep, o.calibration.correct(headChain(head)));
  core::ScanSplitter splitter(o.split);
  core::SplitResult split;
  HeadScan hs;
  std::map<double, LineTruth> truth;
  std::map<double, double> split_time;
  std::vector<SweepEval> out;
  core::HeightMapGrid grid;
  const core::HeightMapParams& hp = o.heightmap;
  const std::vector<float> truth_h = trueHeightMap(scene, hp.origin_x, hp.origin_y, hp.resolution, hp.width, hp.height);
  double next_joint = 0.0, next_scan = 0.0;
  const double joint_period = 1.0 / o.joint_rate;
  for (double t = 0.0; static_cast<int>(out.size()) < o.sweeps && t < 600.0; t += 0.001) {
    sweep.update(t);
    if (t + 1e-9 >= next_joint) {
      double q = servo.reading(t);
      if (o.quantize_joint) q = dynamixel::positionToRad(dynamixel::radToPosition(q));
      q += o.calibration.joint_offset;
      if (o.on_joint) o.on_joint(t, q);
      assembler.addJoint(t, q);
      next_joint += joint_period;
    }
    if (t + 1e-9 >= next_scan + m.scan_period) {
      head_sim.scan(next_scan, hs);
      const double s0 = cpuNow();
      splitter.split(hs.scan.view(), split);
      const double st = cpuNow() - s0;
      core::LineInput in;
      in.ranges = hs.scan.ranges;
      in.angle_min = m.angleMin();
      in.angle_increment = m.angle_increment;
      in.range_min = m.range_min;
      in.range_max = m.range_max;
      const double stamp = next_scan - o.calibration.time_offset;
      in.stamp = stamp;
      in.time_increment = m.timeIncrement();
      for (const auto& s : split.segments) in.segments.emplace_back(s.first, s.last);
      for (const auto& e : split.edges) in.edges.emplace_back(e.index, e.kind);
      LineTruth lt{hs.scan.face, hs.scan.ranges, hs.scan.edges, split.edges};
      for (const auto& s : split.segments) {
        int mixed = 0;
        for (int i = s.first; i <= s.last; ++i) mixed += hs.scan.mixed[i];
        lt.veil_segments += 2 * mixed > s.count;
        lt.overhanging += core::segmentOverhang(hs.scan.view(), s) > 0.01;
      }
      truth[stamp] = std::move(lt);
      split_time[stamp] = st;
      assembler.addLine(std::move(in), t);
      next_scan += m.scan_period;
    }
    core::SweepResult done;
    while (assembler.poll(t, done)) {
      if (o.on_sweep) o.on_sweep(done);
      out.push_back(judge(scene, truth_h, done, truth, split_time, o, done.finish_seconds, grid));
      // Forget the truth of lines before this sweep.
      truth.erase(truth.begin(), truth.lower_bound(done.start));
    }
  }
  return out;
}

void dumpSweep(const core::SweepResult& sw, const core::HeightMapGrid& grid, const std::string& prefix) {
  if (std::FILE* f = std::fopen((prefix + "_planes.csv").c_str(), "w")) {
    std::fprintf(f, "kind,id,a,b,c,d,e,f,g\n");
    for (const core::Plane& p : sw.planes) {
      std::fprintf(f, "plane,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f\n", p.id, p.area, p.fit.normal.x(), p.fit.normal.y(),
                   p.fit.normal.z(), p.fit.centroid.x(), p.fit.centroid.y(), p.fit.centroid.z());
      for (const auto& v : p.boundary) std::fprintf(f, "vertex,%d,%.4f,%.4f,%.4f,,,,\n", p.id, v.x(), v.y(), v.z());
    }
    std::fclose(f);
  }
  if (std::FILE* f = std::fopen((prefix + "_heightmap.bin").c_str(), "wb")) {
    std::fwrite(grid.heights.data(), sizeof(float), grid.heights.size(), f);
    std::fclose(f);
  }
  if (std::FILE* f = std::fopen((prefix + "_heightmap.txt").c_str(), "w")) {
    std::fprintf(f, "%f %f %f %d %d\n", grid.params.origin_x, grid.params.origin_y, grid.params.resolution,
                 grid.params.width, grid.params.height);
    std::fclose(f);
  }
}

std::string evalCsvHeader() {
  return "sweep,lines,planes,true_faces,correct,over,under,missed,noise,normal_err_deg,offset_err_m,edge_precision,"
         "edge_recall,heightmap_rmse_m,heightmap_coverage,split_ms,group_ms,latency_ms,veil_segments,overhanging_segments";
}

std::string evalCsvRow(int sweep, const SweepEval& e) {
  char buf[512];
  std::snprintf(buf, sizeof(buf), "%d,%d,%d,%d,%d,%d,%d,%d,%d,%.3f,%.4f,%.3f,%.3f,%.4f,%.3f,%.2f,%.2f,%.3f,%d,%d", sweep,
                e.lines, e.planes, e.true_faces, e.correct, e.over, e.under, e.missed, e.noise, e.normal_err_deg,
                e.offset_err_m, e.edge_precision, e.edge_recall, e.heightmap_rmse_m, e.heightmap_coverage, e.split_ms,
                e.group_ms, e.latency_ms, e.veil_segments, e.overhanging_segments);
  return buf;
}

std::string evalSummary(const std::vector<SweepEval>& ev) {
  SweepEval s;
  const double n = ev.empty() ? 1.0 : static_cast<double>(ev.size());
  double correct = 0, over = 0, under = 0, missed = 0, noise = 0;
  int veil = 0, overhanging = 0;
  for (const SweepEval& e : ev) {
    veil += e.veil_segments;
    overhanging += e.overhanging_segments;
    correct += e.correct;
    over += e.over;
    under += e.under;
    missed += e.missed;
    noise += e.noise;
    s.normal_err_deg += e.normal_err_deg / n;
    s.offset_err_m += e.offset_err_m / n;
    s.edge_precision += e.edge_precision / n;
    s.edge_recall += e.edge_recall / n;
    s.heightmap_rmse_m += e.heightmap_rmse_m / n;
    s.heightmap_coverage += e.heightmap_coverage / n;
    s.split_ms += e.split_ms / n;
    s.group_ms += e.group_ms / n;
    s.latency_ms += e.latency_ms / n;
  }
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "correct=%.2f over=%.2f under=%.2f missed=%.2f noise=%.2f normal_err_deg=%.3f offset_err_m=%.4f "
                "edge_precision=%.3f edge_recall=%.3f heightmap_rmse_m=%.4f heightmap_coverage=%.3f split_ms=%.2f "
                "group_ms=%.2f latency_ms=%.3f veil_segments=%d overhanging_segments=%d",
                correct / n, over / n, under / n, missed / n, noise / n, s.normal_err_deg, s.offset_err_m,
                s.edge_precision, s.edge_recall, s.heightmap_rmse_m, s.heightmap_coverage, s.split_ms, s.group_ms,
                s.latency_ms, veil, overhanging);
  return buf;
}

}  // namespace sim
}  // namespace tilt_laser_perception
