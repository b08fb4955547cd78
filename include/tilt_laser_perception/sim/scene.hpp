/**
 * @file scene.hpp
 * @brief Scenes for the simulator: every object is a set of planar
 *        rectangular faces with an id. ROS-free. Units: [m], angles in YAML [deg].
 *
 * YAML format (the files in config/scenes):
 * @code
 * name: stairs
 * objects:
 *   - {type: floor, name: floor, center: [2, 0], size: [8, 8], z: 0}
 *   - {type: wall, name: back, from: [6, -3], to: [6, 3], height: 2.5}
 *   - {type: board, name: board, center: [1, 0, 0], width: 0.6, height: 1.0, yaw: 0}
 *   - {type: box, name: box, center: [1.5, 0.8], size: [0.4, 0.4, 0.3], yaw: 0}
 *   - {type: stairs, name: stairs, start: [2, 0], yaw: 0, steps: 4, rise: 0.15, run: 0.30, width: 1.0}
 *   - {type: rect, name: r, origin: [0, 0, 0], u: [1, 0, 0], v: [0, 1, 0]}
 *   - {type: rect, name: box, label: front, triangle: true, origin: [1.3, 1.0, 0.3], u: [0, -0.4, 0], v: [0, 0, 0.1]}
 * @endcode
 * A rect's `label` (default "face") names its face; one with the label of a
 * face already there (of the same object) is part of that face's surface.
 * `triangle: true` keeps the half s + t <= 1 of it (u and v at right
 * angles): a wedge's side above its box.
 * Every object takes `reflectivity` (0..1, default 0.5: the detection range is
 * 60 m * reflectivity, so 0.5 gives the data sheet's 30 m).
 */
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace tilt_laser_perception {
namespace sim {

/// A planar rectangle: origin + s*u + t*v for s, t in [0, 1] (a triangle: s + t <= 1 too).
struct Face {
  int id = 0;                 ///< index in Scene::faces
  std::string object;         ///< name of the object it belongs to
  std::string label;          ///< face name within the object ("top", "riser2", ...)
  Eigen::Vector3d origin, u, v;
  Eigen::Vector3d normal;     ///< unit, u x v
  double reflectivity = 0.5;  ///< [0, 1]

  /// Half of the rectangle: s + t <= 1 (u and v at right angles), a
  /// triangle's corners origin, origin + u, origin + v.
  bool triangle = false;
  /// The face whose id a hit on this one reports: the first face of the
  /// same object and label (a block's side that is a rectangle and a
  /// triangle above it is one surface). Its own id otherwise.
  int surface = 0;

  Eigen::Vector3d center() const {
    return triangle ? Eigen::Vector3d(origin + (u + v) / 3.0) : Eigen::Vector3d(origin + 0.5 * (u + v));
  }
  double area() const { return (triangle ? 0.5 : 1.0) * u.cross(v).norm(); }
  /// The corners, counter-clockwise about the normal.
  std::vector<Eigen::Vector3d> corners() const {
    if (triangle) return {origin, origin + u, origin + v};
    return {origin, origin + u, origin + u + v, origin + v};
  }
};

/// A ray hit.
struct Hit {
  double t = 0.0;              ///< distance along the unit ray [m]
  int face = -1;               ///< face id
  double cos_incidence = 1.0;  ///< |cos| of the angle between ray and normal
};

/// A scene of rectangular faces.
class Scene {
 public:
  std::string name;
  std::vector<Face> faces;

  /// Loads a scene file; throws std::runtime_error with the file and field on errors.
  static Scene load(const std::string& path);
  /// Parses YAML text; `where` names the source in error messages.
  static Scene parse(const std::string& yaml_text, const std::string& where = "<string>");

  /// Adds a face (computes id and normal) and returns its id. Call
  /// updateAdjacency() after the last face.
  int addFace(const std::string& object, const std::string& label, const Eigen::Vector3d& origin,
              const Eigen::Vector3d& u, const Eigen::Vector3d& v, double reflectivity, bool triangle = false);

  /// Nearest hit of the ray origin + t*dir (dir unit) with t in (0, max_t].
  bool raycast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_t, Hit& hit) const;
  /// The height of the highest surface above (x, y) (below 100 m) [m]; NaN where there is none.
  double heightAt(double x, double y) const;

  /// True when faces a and b touch along an edge and are not coplanar (a crease between them).
  bool creaseBetween(int a, int b) const;

  /// Recomputes which faces meet in a crease (load and parse call it).
  void updateAdjacency();

 private:
  std::vector<std::vector<unsigned char>> crease_;
};

/// The package's config folder: $TLP_CONFIG_DIR, else the installed share
/// folder's config, else the source tree's config.
std::string configDirectory();
/// Where scene files live: configDirectory()/scenes.
std::string sceneDirectory();
/// Loads a scene by name (NAME -> sceneDirectory()/NAME.yaml) or by path.
Scene loadScene(const std::string& name_or_path);

}  // namespace sim
}  // namespace tilt_laser_perception
