// The paper's Figure 3 experiment on simulated UTM-30LX scans: fixed split
// threshold (d_T = 0.03 m) against the range-adaptive one (zeta = 0.01),
// averaged over noise seeds. Prints CSV; with --check, also checks the claim.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "tilt_laser_perception/sim/evaluation.hpp"

using namespace tilt_laser_perception;

static void usage() {
  std::fprintf(stderr,
               "usage: figure3 [--seeds N] [--noise datasheet|percent] [--zeta Z] [--fixed D] [--no-merge] [--check]\n"
               "  --seeds N   noise seeds averaged per case (default 20)\n"
               "  --noise M   range noise model (default datasheet: +-30 mm to 10 m, +-50 mm beyond)\n"
               "  --zeta Z    adaptive factor (default 0.01)\n"
               "  --fixed D   fixed threshold and adaptive floor d_min [m] (default 0.03)\n"
               "  --check     exit 1 unless, at 10 m and beyond, adaptive has at most a fifth of fixed's\n"
               "              spurious edges, and finds at least 95 %% of the true edges everywhere\n"
               "  --no-merge  plain split, without merging neighbouring pieces that fit one line\n");
}

int main(int argc, char** argv) {
  int seeds = 20;
  bool check = false;
  sim::NoiseParams noise;
  core::SplitParams adaptive;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--seeds" && has_value) seeds = std::atoi(argv[++i]);
    else if (a == "--zeta" && has_value) adaptive.zeta = std::atof(argv[++i]);
    else if (a == "--fixed" && has_value) adaptive.d_min = std::atof(argv[++i]);
    else if (a == "--noise" && has_value) {
      if (!sim::parseNoiseMode(argv[++i], noise.mode)) { usage(); return 2; }
    } else if (a == "--check") check = true;
    else if (a == "--no-merge") adaptive.merge = false;
    else { usage(); return a == "--help" || a == "-h" ? 0 : 2; }
  }
  if (seeds < 1) { std::fprintf(stderr, "figure3: --seeds must be >= 1\n"); return 2; }
  core::SplitParams fixed = adaptive;
  fixed.mode = core::SplitMode::Fixed;
  for (const auto* p : {&adaptive, &fixed}) {
    const std::string problem = p->validate();
    if (!problem.empty()) { std::fprintf(stderr, "figure3: %s\n", problem.c_str()); return 2; }
  }

  bool ok = true;
  std::printf("distance_m,mode,segments,edge_points,spurious_edges,true_edges_found,true_edges\n");
  try {
    for (const auto& c : sim::figure3Cases()) {
      const sim::Scene scene = sim::loadScene(c.scene);
      const sim::Figure3Row f = sim::runFigure3Case(scene, c.distance_m, fixed, seeds, noise);
      const sim::Figure3Row a = sim::runFigure3Case(scene, c.distance_m, adaptive, seeds, noise);
      for (const auto& r : {f, a}) {
        std::printf("%g,%s,%.2f,%.2f,%.2f,%.2f,%.2f\n", r.distance_m, r.mode.c_str(), r.segments, r.edge_points,
                    r.spurious_edges, r.true_edges_found, r.true_edges);
      }
      if (a.true_edges_found < 0.95 * a.true_edges) ok = false;
      if (c.distance_m >= 10.0 && a.spurious_edges > 0.2 * f.spurious_edges) ok = false;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "figure3: %s\n", e.what());
    return 2;
  }
  if (check) {
    std::fprintf(stderr, "figure3 check: %s\n", ok ? "passed" : "FAILED");
    return ok ? 0 : 1;
  }
  return 0;
}
