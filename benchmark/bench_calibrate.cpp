// Run time of the head's self-calibration for 10 sweeps (goal: under 30 s on
// the robot's PC): the stairs scene with --realistic's rig errors and a joint
// offset of 1.2 deg, a time offset of 6 ms and a mount roll and yaw of 0.5 and
// -0.4 deg; the sweeps are simulated and assembled once, then the estimator
// (HeadCalibrator::addSweep for each, and solve) runs in the loop. The whole
// tool over a recording adds the split and the assembly of each pass: see
// `calibrate`'s own last line ("N sweeps, P points, T s").
#include <benchmark/benchmark.h>

#include <cstdio>

#include "tilt_laser_perception/core/calibration.hpp"
#include "tilt_laser_perception/sim/scene_eval.hpp"

using namespace tilt_laser_perception;

namespace {
struct Recording {
  std::vector<std::pair<double, double>> joints;
  std::vector<core::SweepResult> sweeps;
  core::TiltChain chain;
};

const Recording& recording() {
  static const Recording rec = [] {
    Recording r;
    sim::SceneEvalOptions o;
    o.scene = "stairs";
    o.sweeps = 10;
    sim::setRealistic(o.rig, o.noise);
    const double deg = M_PI / 180.0;
    o.rig.joint_offset = 1.2 * deg;
    o.rig.time_offset = 0.006;
    o.rig.mount_roll = 0.5 * deg;
    o.rig.mount_yaw = -0.4 * deg;
    o.on_joint = [&](double t, double q) { r.joints.emplace_back(t, q); };
    o.on_sweep = [&](const core::SweepResult& s) { r.sweeps.push_back(s); };
    sim::evaluateScene(o);
    r.chain = sim::HeadGeometry::load(sim::configDirectory() + "/head.yaml").chain();
    return r;
  }();
  return rec;
}

void BM_Calibrate10Sweeps(benchmark::State& state) {
  const Recording& rec = recording();
  core::CalibrationResult res;
  for (auto _ : state) {
    core::HeadCalibrator cal(rec.chain);
    for (const auto& [t, q] : rec.joints) cal.addJoint(t, q);
    for (const auto& s : rec.sweeps) cal.addSweep(s);
    res = cal.solve();
    benchmark::DoNotOptimize(res);
  }
  state.counters["sweeps"] = res.sweeps;
  state.counters["points"] = res.points;
  std::fprintf(stderr, "%s\n", core::HeadCalibrator::summary(res).c_str());
}
BENCHMARK(BM_Calibrate10Sweeps)->Unit(benchmark::kMillisecond)->Iterations(5);
}  // namespace

BENCHMARK_MAIN();
