/**
 * @file lidar_sim.hpp
 * @brief Ray-casting model of the Hokuyo UTM-30LX(-EW) with data-sheet noise,
 *        no-return rules, mixed pixels, intensities and per-beam ground truth.
 *        ROS-free. Units: [m], [rad], [s].
 */
#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "tilt_laser_perception/core/scan_split.hpp"
#include "tilt_laser_perception/scip/codec.hpp"
#include "tilt_laser_perception/sim/scene.hpp"

namespace tilt_laser_perception {
namespace sim {

/// Scan geometry and timing of the UTM-30LX: 1081 steps over 270 deg, front
/// step 540 at 0 rad, 0.25 deg apart, 1440 steps per 25 ms revolution.
struct LidarModel {
  int beams = 1081;
  int front_step = 540;
  double angle_increment = 0.25 * M_PI / 180.0;  ///< [rad]
  int steps_per_revolution = 1440;
  double scan_period = 0.025;  ///< [s]
  double range_min = 0.023;    ///< reported minimum [m]
  double range_max = 60.0;     ///< reported maximum [m]
  double max_detect_range = 60.0;  ///< detection range at reflectivity 1 [m]; 30 m at 0.5

  double angleMin() const { return -front_step * angle_increment; }
  double angleMax() const { return (beams - 1 - front_step) * angle_increment; }
  double angle(int i) const { return (i - front_step) * angle_increment; }
  /// Time of beam i after beam 0 [s].
  double timeIncrement() const { return scan_period / steps_per_revolution; }
  double beamTime(int i) const { return i * timeIncrement(); }
};

/// Range noise.
enum class NoiseMode {
  None,       ///< exact ranges (still rounded to mm)
  Datasheet,  ///< +-30 mm up to 10 m, +-50 mm beyond, taken as 3 sigma (sigma 10 mm = the repeatability)
  Percent,    ///< +-percent % of range taken as 3 sigma (the paper's 1 % model)
};

struct NoiseParams {
  NoiseMode mode = NoiseMode::Datasheet;
  double percent = 1.0;                  ///< bound for NoiseMode::Percent [%]
  double grazing_limit_deg = 85.0;       ///< no return beyond this incidence angle [deg]
  double mixed_pixel_probability = 0.5;  ///< chance that a beam straddling a depth jump mixes both ranges (footprint 0)
  /// Width of the beam's footprint [rad]. 0: the footprint is one step wide
  /// and a beam straddling a jump takes a range in between with the chance
  /// above (one beam at a depth edge). Wider: the reported range is the
  /// return-power weighted mean over the footprint, so a depth edge gives a
  /// run of beams between the near and the far surface, as real sensors do.
  double footprint = 0.0;
  double dropout_probability = 0.0;      ///< chance of a random no-return
  /// Multi-echo (the UTM-30LX-EW): returns of one beam farther than the first
  /// echo by more than this are a separate echo [m]. An assumed pulse
  /// resolution (a few ns of pulse), not a data-sheet value.
  double echo_separation = 0.3;
  /// Rain or dust: the chance that a beam also meets a drop between 0.3 and
  /// 4 m, a weak return before the surface's; the first (and the single-echo)
  /// range is then the drop's, the surface a later echo.
  double rain_probability = 0.0;

  /// Standard deviation of the range noise at range r [m].
  double sigma(double r) const;
};

/// "datasheet", "percent" or "none"; false for anything else.
bool parseNoiseMode(const std::string& name, NoiseMode& mode);

/// A true edge of the scan line, for scoring edge points.
struct TrueEdge {
  int index = 0;  ///< beam index (near side for a jump)
  core::EdgeKind kind = core::EdgeKind::Boundary;
};

/// What a multi-echo sensor receives for one beam: up to scip::kMaxEchoes
/// echoes, nearest first. The first is the single-echo range (a mixed pixel at
/// a depth edge); a later one is a surface farther than the first echo by more
/// than NoiseParams::echo_separation (the far side of a depth edge, or the
/// surface behind a drop of rain).
struct BeamEchoes {
  std::uint8_t count = 0;
  float range[scip::kMaxEchoes] = {};      ///< [m]
  float intensity[scip::kMaxEchoes] = {};
  std::uint8_t mixed[scip::kMaxEchoes] = {};  ///< 1 where that echo is a range between two faces
};

/// One simulated scan with its ground truth.
struct SimScan {
  double stamp = 0.0;                 ///< time of beam 0 [s]
  LidarModel model;
  std::vector<float> ranges;          ///< measured [m]; +inf where there is no return (REP 117)
  std::vector<float> intensities;     ///< arbitrary units
  std::vector<float> true_ranges;     ///< noise-free range of the centre ray [m]; NaN: nothing hit
  std::vector<int> face;              ///< face hit by the centre ray; -1 none
  std::vector<unsigned char> mixed;   ///< 1 where the return is a mixed pixel: a range between two faces
  std::vector<BeamEchoes> echoes;     ///< every beam's echoes; echo 0 is ranges[i]
  std::vector<TrueEdge> edges;        ///< true edges, in beam order

  /// View for the splitter (points into this object).
  core::ScanView view() const;
};

/// Makes the chosen echo every beam's range, intensity and mixed flag (what a
/// driver publishing that echo gives).
void selectEcho(SimScan& scan, scip::EchoChoice choice);

/// Pose of the sensor frame in the scene frame at time t [s].
using PoseFunction = std::function<Eigen::Isometry3d(double)>;

/// Simulates scans of a scene. Deterministic for a seed.
class LidarSimulator {
 public:
  LidarSimulator(const Scene& scene, const LidarModel& model, const NoiseParams& noise, std::uint64_t seed);

  /// Simulates the scan whose beam 0 is at time t0; the pose is evaluated at every beam's own time.
  void scan(double t0, const PoseFunction& pose, SimScan& out);
  SimScan scan(double t0, const PoseFunction& pose) {
    SimScan s;
    scan(t0, pose, s);
    return s;
  }

  const LidarModel& model() const { return model_; }

 private:
  /// The power-weighted mean range over a footprint of half-width w about angle a; NaN: no return.
  /// several_faces: the returns came from more than one face.
  /// A sub-ray's return within a footprint.
  struct SubReturn {
    double t, w;
    int face;
  };
  static constexpr int kFootprintRays = 11;
  template <typename Dir>
  double footprintRange(const Eigen::Vector3d& o, const Dir& dirAt, double a, double w, double cos_grazing,
                        bool& several_faces, SubReturn* returns, int& n_returns) const;
  const Scene& scene_;
  LidarModel model_;
  NoiseParams noise_;
  std::mt19937_64 rng_;
  std::mt19937_64 echo_rng_;  ///< later echoes and rain, so that the single-echo ranges do not change with them
};

/// True edges from the per-beam faces and returns: creases between faces that
/// meet, jumps (at the nearer beam) between faces that do not, boundaries next
/// to beams without a return and at the ends of the scan.
std::vector<TrueEdge> trueEdges(const Scene& scene, const std::vector<int>& face,
                                const std::vector<float>& ranges, const std::vector<float>& true_ranges);

/// An n x n range image of the scene from `origin` (row-major): rows of
/// equal elevation (10 to 60 degrees down, the tilt's range), columns of
/// equal azimuth (+60 to -60 degrees), Gaussian range noise of `sigma` [m];
/// NaN where no face within 30 m. `faces`, if given, gets each point's face
/// id (-1: none).
std::vector<Eigen::Vector3f> rangeImage(const Scene& scene, const Eigen::Vector3d& origin, int n, double sigma,
                                        std::uint64_t seed, std::vector<int>* faces = nullptr);

}  // namespace sim
}  // namespace tilt_laser_perception
