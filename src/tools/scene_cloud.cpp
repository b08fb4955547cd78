// A range image of one of the simulator's scenes from the head, as an
// organized PCD cloud whose label field is each point's face (0: none): a
// cloud with its truth, for segment_cloud --truth-field label --truth-none 0.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "tilt_laser_perception/io/pcd.hpp"
#include "tilt_laser_perception/sim/head.hpp"
#include "tilt_laser_perception/sim/lidar_sim.hpp"
#include "tilt_laser_perception/sim/scene_eval.hpp"

using namespace tilt_laser_perception;

static void usage() {
  std::fprintf(stderr,
               "usage: scene_cloud OUT.pcd [--scene NAME] [--size N] [--sigma S] [--seed K]\n"
               "  an N x N range image (default 200) of the scene (default stairs) from the head: rows of equal\n"
               "  elevation 10 to 60 degrees down, columns +60 to -60 degrees of azimuth, Gaussian range noise S\n"
               "  [m] (default 0.01); fields x y z label, the label each point's face + 1 (0: no return)\n");
}

int main(int argc, char** argv) {
  std::string out, scene_name = "stairs";
  int n = 200;
  double sigma = 0.01;
  unsigned long seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    if (a == "--scene" && v) scene_name = argv[++i];
    else if (a == "--size" && v) n = std::atoi(argv[++i]);
    else if (a == "--sigma" && v) sigma = std::atof(argv[++i]);
    else if (a == "--seed" && v) seed = std::strtoul(argv[++i], nullptr, 10);
    else if (a[0] != '-' && out.empty()) out = a;
    else { usage(); return a == "-h" || a == "--help" ? 0 : 2; }
  }
  if (out.empty() || n < 2 || !(sigma >= 0.0)) { usage(); return 2; }
  try {
    const sim::Scene scene = sim::loadScene(scene_name);
    io::OrganizedCloud c;
    c.width = c.height = n;
    c.viewpoint = sim::HeadGeometry::load(sim::configDirectory() + "/head.yaml").axis_origin;
    std::vector<int> faces;
    c.points = sim::rangeImage(scene, c.viewpoint, n, sigma, seed, &faces);
    std::vector<std::uint32_t> labels(faces.size());
    for (std::size_t i = 0; i < faces.size(); ++i) labels[i] = static_cast<std::uint32_t>(faces[i] + 1);
    io::writeLabeledPcd(out, c, labels);
    std::printf("%s: %d x %d range image of %s, noise %.4f m, seed %lu\n", out.c_str(), n, n, scene_name.c_str(), sigma,
                seed);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "scene_cloud: %s\n", e.what());
    return 1;
  }
  return 0;
}
