// Time per sweep of 1081 x 200 scan lines (the stairs scene, the head sweeping
// 10..60 deg at 0.175 rad/s): the whole sweep's split and grouping CPU time,
// and the latency from the last scan line to the planes and the height map
// (medians over 20 sweeps, five times: the median and the minimum of the five),
// and the time to fuse the sweep into the fused map instead (fused_ms), and
// the steppable layer's (steppable_ms, built while subscribed). And
// one plane fit against Eigen's direct solver (PlaneFit, PlaneFitEigenDirect).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <random>
#include <vector>

#include <Eigen/Eigenvalues>

#include "tilt_laser_perception/core/fused_map.hpp"
#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/dynamixel/mx64.hpp"
#include "tilt_laser_perception/sim/head.hpp"

using namespace tilt_laser_perception;

namespace {
struct Recording {
  std::vector<std::pair<double, double>> joints;
  std::vector<core::LineInput> lines;  // with ranges only; split in the benchmark
  core::TiltChain chain;
};

const Recording& recording() {
  static const Recording rec = [] {
    Recording r;
    const sim::Scene scene = sim::loadScene("stairs");
    const sim::HeadGeometry head = sim::HeadGeometry::load(sim::configDirectory() + "/head.yaml");
    core::TiltProfileParams prof;
    prof.speed = 0.1745;  // 50 deg in 200 scans of 25 ms
    sim::ServoModel servo(prof.min_angle, 0.0);
    sim::SweepController sweep(servo, prof);
    sim::HeadSimulator hs(scene, head, servo, sim::NoiseParams(), 1);
    sim::HeadScan scan;
    double next_j = 0, next_s = 0;
    for (double t = 0.0; t < 12.0; t += 0.001) {
      sweep.update(t);
      if (t >= next_j) {
        r.joints.emplace_back(t, dynamixel::positionToRad(dynamixel::radToPosition(servo.state(t).position)));
        next_j += 0.005;
      }
      if (t >= next_s + 0.025) {
        hs.scan(next_s, scan);
        core::LineInput in;
        in.ranges = scan.scan.ranges;
        in.angle_min = scan.scan.model.angleMin();
        in.angle_increment = scan.scan.model.angle_increment;
        in.range_min = scan.scan.model.range_min;
        in.range_max = scan.scan.model.range_max;
        in.stamp = next_s;
        in.time_increment = scan.scan.model.timeIncrement();
        r.lines.push_back(std::move(in));
        next_s += 0.025;
      }
    }
    r.chain.base_to_joint.translation() = head.axis_origin;
    r.chain.joint_to_laser.translation() = head.laser_offset;
    return r;
  }();
  return rec;
}

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

/// The median in milliseconds: these machines are shared, and a neighbour's
/// burst moves a mean by milliseconds.
double medianMs(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? 0.0 : 1e3 * (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

/// The recording's lines split and fed, with their joints, to a new
/// assembler until it finishes a sweep: the first (false if none), or with
/// `last` the last one. `split_time`: each line's split time, by its stamp.
bool runSweep(const Recording& rec, core::ScanSplitter& splitter, core::SplitResult& split, bool last,
              core::SweepResult& done, std::map<double, double>* split_time = nullptr) {
  core::SweepAssembler a(core::SweepParams(), rec.chain);
  std::size_t j = 0;
  bool got = false;
  for (const core::LineInput& raw : rec.lines) {
    const double last_beam = raw.stamp + 1080 * raw.time_increment;
    while (j < rec.joints.size() && rec.joints[j].first <= last_beam + 0.005) {
      a.addJoint(rec.joints[j].first, rec.joints[j].second);
      ++j;
    }
    core::LineInput in = raw;
    core::ScanView v;
    v.ranges = in.ranges.data();
    v.size = in.ranges.size();
    v.angle_min = in.angle_min;
    v.angle_increment = in.angle_increment;
    v.angle_max = in.angle_min + (v.size - 1) * in.angle_increment;
    v.range_min = in.range_min;
    v.range_max = in.range_max;
    const double t0 = now();
    splitter.split(v, split);
    if (split_time) (*split_time)[raw.stamp] = now() - t0;
    for (const auto& s : split.segments) in.segments.emplace_back(s.first, s.last);
    a.addLine(std::move(in), last_beam);
    core::SweepResult r;
    if (a.poll(last_beam + 0.03, r)) {
      done = std::move(r);
      got = true;
      if (!last) break;
    }
  }
  return got;
}
}  // namespace

static void Sweep1081x200(benchmark::State& state) {
  const Recording& rec = recording();
  core::ScanSplitter splitter;
  core::SplitResult split;
  std::vector<double> split_s, group_s, latency_s, finish_s, map_s, sigma_s, fused_s, steppable_s;  // per sweep [s]
  std::vector<float> sigmas;
  std::vector<std::uint8_t> steppable;
  core::HeightMapGrid grid;  // kept between sweeps, as the nodelet keeps it
  // The map fused over sweeps (~fuse_sweeps), 6 m x 6 m at 1 cm, in place of the sweep's own.
  core::FusedHeightMap fused{core::HeightMapParams(), core::FusedMapParams()};
  long sweeps = 0, lines = 0, planes = 0;
  for (auto _ : state) {
    core::SweepResult done;
    std::map<double, double> split_time;  // by line stamp: only the finished sweep's lines count
    const bool got = runSweep(rec, splitter, split, false, done, &split_time);
    if (!got) {
      state.SkipWithError("no sweep");
      return;
    }
    double split = 0.0;
    for (const auto& line : done.lines) split += split_time[line.stamp];
    const double t1 = now();
    core::buildHeightMap(done, core::HeightMapParams(), grid);
    const double map = now() - t1;
    const double t4 = now();  // the map's uncertainty layer, published with it
    core::sweepUncertainty(grid, core::meanOrigin(done), core::FusedMapParams(), sigmas);
    const double sigma = now() - t4;
    sigma_s.push_back(sigma);
    const double t3 = now();
    core::steppableCells(grid, done.planes, core::FootParams(), steppable);
    steppable_s.push_back(now() - t3);
    const double t2 = now();
    fused.recentre(0.0, 0.0);
    fused.addSweep(done, core::meanOrigin(done), static_cast<double>(sweeps), 0.0);
    fused_s.push_back(now() - t2);
    split_s.push_back(split);
    finish_s.push_back(done.finish_seconds);
    map_s.push_back(map);
    latency_s.push_back(done.finish_seconds + map + sigma);
    group_s.push_back(done.group_seconds + done.finish_seconds + map + sigma);
    lines += static_cast<long>(done.lines.size());
    planes += static_cast<long>(done.planes.size());
    ++sweeps;
  }
  state.counters["lines/sweep"] = static_cast<double>(lines) / sweeps;
  state.counters["planes/sweep"] = static_cast<double>(planes) / sweeps;
  // Medians over the sweeps.
  state.counters["split_ms"] = medianMs(split_s);
  state.counters["group_ms"] = medianMs(group_s);
  state.counters["latency_ms"] = medianMs(latency_s);
  state.counters["finish_ms"] = medianMs(finish_s);
  state.counters["map_ms"] = medianMs(map_s);
  state.counters["sigma_ms"] = medianMs(sigma_s);  // of the latency: the map's uncertainty layer
  state.counters["fused_ms"] = medianMs(fused_s);  // instead of map_ms with ~fuse_sweeps
  state.counters["steppable_ms"] = medianMs(steppable_s);  // the steppable layer, when subscribed
}
// Five runs of 20 sweeps: the median and the fastest run's figures (on a
// shared machine the neighbours only ever add time).
BENCHMARK(Sweep1081x200)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(20)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true)
    ->ComputeStatistics("min", [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); });

// Each layer of the map alone on one finished sweep of the recording (its
// last), many times over: HeightMap (buildHeightMap into a kept grid, as the
// nodelet does), Uncertainty (sweepUncertainty) and Steppable
// (steppableCells). Their fastest repetition is the steadiest figure on a
// shared machine, for comparing two builds of a layer.
const core::SweepResult& finishedSweep() {
  static const core::SweepResult sweep = [] {
    core::ScanSplitter splitter;
    core::SplitResult split;
    core::SweepResult done;
    runSweep(recording(), splitter, split, true, done);
    return done;
  }();
  return sweep;
}

void HeightMap(benchmark::State& state) {
  const core::SweepResult& sweep = finishedSweep();
  core::HeightMapGrid grid;
  for (auto _ : state) core::buildHeightMap(sweep, core::HeightMapParams(), grid);
}

void Uncertainty(benchmark::State& state) {
  const core::SweepResult& sweep = finishedSweep();
  core::HeightMapGrid grid;
  core::buildHeightMap(sweep, core::HeightMapParams(), grid);
  std::vector<float> sigmas;
  for (auto _ : state) core::sweepUncertainty(grid, core::meanOrigin(sweep), core::FusedMapParams(), sigmas);
}

void Steppable(benchmark::State& state) {
  const core::SweepResult& sweep = finishedSweep();
  core::HeightMapGrid grid;
  core::buildHeightMap(sweep, core::HeightMapParams(), grid);
  std::vector<std::uint8_t> steppable;
  for (auto _ : state) core::steppableCells(grid, sweep.planes, core::FootParams(), steppable);
  // The work: the map's box, its known cells, and those steppable.
  long known = 0, yes = 0;
  for (std::size_t c = 0; c < steppable.size(); ++c) {
    known += steppable[c] != 255;
    yes += steppable[c] == 1;
  }
  state.counters["box_cells"] = static_cast<double>(grid.box_x1 - grid.box_x0 + 1) * (grid.box_y1 - grid.box_y0 + 1);
  state.counters["known_cells"] = static_cast<double>(known);
  state.counters["steppable_cells"] = static_cast<double>(yes);
}
void layerRuns(benchmark::internal::Benchmark* b) {
  b->Unit(benchmark::kMicrosecond)
      ->Repetitions(5)
      ->ReportAggregatesOnly(true)
      ->ComputeStatistics("min", [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); });
}
BENCHMARK(HeightMap)->Apply(layerRuns);
BENCHMARK(Uncertainty)->Apply(layerRuns);
BENCHMARK(Steppable)->Apply(layerRuns);

// One plane fit (core::fitPlane) against Eigen's direct 3 x 3 solver on the
// same covariance (what fitPlane ran before its Newton step), over 1,000
// patches of 30 points: 1 m x 0.5 m, 1 cm thick, up to 3 m from the origin.
const std::vector<core::Moments3>& patches() {
  static const std::vector<core::Moments3> ms = [] {
    std::mt19937 rng(1);
    std::normal_distribution<double> g(0.0, 1.0);
    std::vector<core::Moments3> out(1000);
    for (auto& m : out) {
      const Eigen::Quaterniond q = Eigen::Quaterniond::UnitRandom();
      const Eigen::Vector3d o(3.0 * g(rng), 3.0 * g(rng), g(rng));
      for (int i = 0; i < 30; ++i) m.add(o + q * Eigen::Vector3d(g(rng), 0.5 * g(rng), 0.01 * g(rng)));
    }
    return out;
  }();
  return ms;
}

void PlaneFit(benchmark::State& state) {
  const auto& ms = patches();
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(core::fitPlane(ms[i++ % ms.size()]));
}
BENCHMARK(PlaneFit)->Unit(benchmark::kNanosecond);

void PlaneFitEigenDirect(benchmark::State& state) {
  const auto& ms = patches();
  std::size_t i = 0;
  for (auto _ : state) {
    const core::Moments3& m = ms[i++ % ms.size()];
    const Eigen::Vector3d c = m.mean();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(m.ss / m.n - c * c.transpose());
    benchmark::DoNotOptimize(es.eigenvectors().col(0).normalized().eval());
  }
}
BENCHMARK(PlaneFitEigenDirect)->Unit(benchmark::kNanosecond);

BENCHMARK_MAIN();
