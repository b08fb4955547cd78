// Split time per 1081-beam UTM-30LX scan (Google Benchmark). Scans come from
// the simulator: the stairs-like corner scene and the 10 m wall of Figure 3.
#include <benchmark/benchmark.h>

#include "tilt_laser_perception/sim/evaluation.hpp"

using namespace tilt_laser_perception;

namespace {
void runSplit(benchmark::State& state, const char* scene_name, core::SplitMode mode) {
  const sim::Scene scene = sim::loadScene(scene_name);
  sim::LidarSimulator simulator(scene, sim::LidarModel(), sim::NoiseParams(), 7);
  std::vector<sim::SimScan> scans;
  const sim::PoseFunction pose = [](double) { return Eigen::Isometry3d::Identity(); };
  for (int i = 0; i < 16; ++i) scans.push_back(simulator.scan(0.025 * i, pose));
  core::SplitParams params;
  params.mode = mode;
  core::ScanSplitter splitter(params);
  core::SplitResult result;
  std::size_t i = 0, segments = 0;
  for (auto _ : state) {
    splitter.split(scans[i++ % scans.size()].view(), result);
    segments += result.segments.size();
    benchmark::DoNotOptimize(result.segments.data());
  }
  state.counters["segments/scan"] = static_cast<double>(segments) / static_cast<double>(state.iterations());
}
}  // namespace

BENCHMARK_CAPTURE(runSplit, room_adaptive, "split_room", core::SplitMode::Adaptive)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(runSplit, room_fixed, "split_room", core::SplitMode::Fixed)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(runSplit, wall10_adaptive, "figure3_wall_10m", core::SplitMode::Adaptive)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
