// Simulates sweeps of a scene, runs split, grouping and the height map, and
// judges them against the ground truth: one CSV line per sweep, then a summary.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>

#include "calibration_yaml.hpp"
#include "tilt_laser_perception/sim/scene_eval.hpp"

using namespace tilt_laser_perception;

static void usage() {
  std::fprintf(stderr,
               "usage: evaluate --scene NAME [--sweeps N] [--seed S] [--speed RAD_PER_S] [--tilt-range MIN,MAX] [--spin RAD_PER_S]\n"
               "                [--head FILE] [--no-skew] [--reverse] [--fixed D]\n"
               "                [--verbose] [--dump PREFIX] [--calibration FILE | --errors-known]\n"
               "                [--walk SPEED [--path straight|turn|step] [--no-pose] ...] [--echo first|last|strongest]\n"
               "  --tilt-range MIN,MAX  the sweep's range [deg] (the driver's ~tilt_min, ~tilt_max; default 10,60)\n"
               "  --spin RAD_PER_S  a spinning head instead (config/head_spin.yaml: the laser's scan plane containing\n"
               "              the spin axis), turning on at this rate, a sweep each half turn\n"
               "  --head FILE the head's geometry (default config/head.yaml, or head_spin.yaml with --spin)\n"
               "  --no-skew   one joint angle per scan line (at its stamp, as one tf per scan gives) instead of one per beam\n"
               "  --reverse   each sweep's lines grouped in the other order (last first): the planes should not depend on it\n"
               "  --line-sigma-deg D  the grouping's line term (each line's own pose error; default 0)\n"
               "  --fixed D   fixed split threshold D [m] instead of the adaptive one\n"
               "  --verbose   list the faces each sweep missed, and the segments on them or in the planes that took them,\n"
               "              and the planes counted as noise (what they hold, their lines)\n"
               "  --dump P    write the last sweep's planes and height map to P_planes.csv, P_heightmap.{bin,txt}\n"
               "  --calibration FILE  apply calibrate's estimate (joint offset, time offset, mount) to the believed head\n"
               "  --errors-known      apply the rig errors' own values instead (what a perfect calibration gives)\n"
               "  --fused-resolution R  the fused map's cell side [m] (default: the grouper's ~fused_map_resolution)\n"
               "  --judge-mixed  count mixed pixels (ranges between two faces) as points of the face their beam's\n"
               "              centre hits; by default they are no face's points and are not judged\n"
               "  --crease-reach M  polygons carried to the crease of two planes that both end this close to it (the\n"
               "              grouper's ~crease_reach; 0: not)\n"
               "  --echo E    the echo the pipeline takes, as the driver's ~echo (first: the single-echo range)\n"
               "  --no-pose   (walking) every line of a sweep with the odometry's pose at the sweep's end, not its own\n"
               "  the summary's front_coverage and fused_front_coverage: the single sweep's and the fused map's cells known\n"
               "  in the 1 m x 1 m in front of the feet, over the sweeps after the robot walked 1 m (all when it stands)\n"
               "%s%s", sim::rigOptionsUsage(), sim::walkOptionsUsage());
}

int main(int argc, char** argv) {
  sim::SceneEvalOptions o;
  bool verbose = false, errors_known = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    try {
      if (sim::parseRigOption(argc, argv, i, o.rig, o.noise) || sim::parseWalkOption(argc, argv, i, o.walk)) continue;
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "evaluate: %s\n", e.what());
      return 2;
    }
    if (a == "--scene" && v) o.scene = argv[++i];
    else if (a == "--sweeps" && v) o.sweeps = std::atoi(argv[++i]);
    else if (a == "--seed" && v) o.seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--speed" && v) o.profile.speed = std::atof(argv[++i]);
    else if (a == "--spin" && v) {
      // A spinning head (config/head_spin.yaml unless --head), a sweep each half turn.
      o.profile.mode = core::TiltProfileParams::Mode::Spin;
      o.profile.speed = std::atof(argv[++i]);
      o.sweep.spin_span = o.profile.spin_span;
    }
    else if (a == "--head" && v) o.head_file = argv[++i];
    else if (a == "--tilt-range" && v) {
      double lo = 0.0, hi = 0.0;
      if (std::sscanf(argv[++i], "%lf,%lf", &lo, &hi) != 2 || !(lo < hi)) { usage(); return 2; }
      o.profile.min_angle = lo * M_PI / 180.0;
      o.profile.max_angle = hi * M_PI / 180.0;
    }
    else if (a == "--no-skew") o.sweep.per_beam = false;
    else if (a == "--reverse") o.sweep.reverse_lines = true;
    else if (a == "--line-sigma-deg" && v) o.sweep.grouping.line_sigma = std::atof(argv[++i]) * M_PI / 180.0;
    else if (a == "--no-pose") o.pose_per_line = false;
    else if (a == "--fused-resolution" && v) o.fused.resolution = std::atof(argv[++i]);
    else if (a == "--judge-mixed") o.judge_mixed = true;
    else if (a == "--crease-reach" && v) o.sweep.grouping.crease_reach = std::atof(argv[++i]);
    else if (a == "--echo" && v) {
      if (!scip::parseEchoChoice(argv[++i], o.echo)) { usage(); return 2; }
    }
    else if (a == "--fixed" && v) { o.split.mode = core::SplitMode::Fixed; o.split.d_min = std::atof(argv[++i]); }
    else if (a == "--verbose") verbose = true;
    else if (a == "--dump" && v) o.dump_prefix = argv[++i];
    else if (a == "--errors-known") errors_known = true;
    else if (a == "--calibration" && v) {
      try {
        o.calibration = tools::readCalibrationYaml(argv[++i]);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "evaluate: %s\n", e.what());
        return 2;
      }
    }
    else { usage(); return a == "-h" || a == "--help" ? 0 : 2; }
  }
  if (o.sweeps < 1 || !(o.profile.speed > 0)) { usage(); return 2; }
  if (const std::string e = o.profile.validate(); !e.empty()) {
    std::fprintf(stderr, "evaluate: %s\n", e.c_str());
    return 2;
  }
  if (errors_known) o.calibration = o.rig.calibration();
  try {
    const auto evals = sim::evaluateScene(o);
    std::printf("%s\n", sim::evalCsvHeader().c_str());
    for (std::size_t i = 0; i < evals.size(); ++i) {
      std::printf("%s\n", sim::evalCsvRow(static_cast<int>(i), evals[i]).c_str());
      if (verbose) {
        for (const auto& f : evals[i].missed_faces) std::fprintf(stderr, "sweep %zu missed %s\n", i, f.c_str());
        for (const auto& s : evals[i].missed_segments) std::fprintf(stderr, "  %s\n", s.c_str());
        for (const auto& n : evals[i].noise_planes) std::fprintf(stderr, "sweep %zu noise %s\n", i, n.c_str());
      }
    }
    std::printf("%s\n", sim::evalSummary(evals).c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "evaluate: %s\n", e.what());
    return 1;
  }
  return 0;
}
