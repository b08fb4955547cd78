#include "tilt_laser_perception/sim/scene.hpp"

#include <cmath>
#include <limits>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <yaml-cpp/yaml.h>

namespace tilt_laser_perception {
namespace sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Ctx {
  std::string where;
  std::string object;
  [[noreturn]] void fail(const std::string& msg) const {
    throw std::runtime_error(where + ": object '" + object + "': " + msg);
  }
};

std::vector<double> vec(const YAML::Node& n, const char* key, std::size_t size, const Ctx& c,
                        const std::vector<double>* def = nullptr) {
  const YAML::Node v = n[key];
  if (!v) {
    if (def) return *def;
    c.fail(std::string("missing field '") + key + "'");
  }
  if (!v.IsSequence() || v.size() != size)
    c.fail(std::string("field '") + key + "' must be a list of " + std::to_string(size) + " numbers");
  std::vector<double> out;
  for (const auto& e : v) out.push_back(e.as<double>());
  return out;
}

double num(const YAML::Node& n, const char* key, const Ctx& c, const double* def = nullptr) {
  const YAML::Node v = n[key];
  if (!v) {
    if (def) return *def;
    c.fail(std::string("missing field '") + key + "'");
  }
  try {
    return v.as<double>();
  } catch (const YAML::Exception&) {
    c.fail(std::string("field '") + key + "' must be a number");
  }
}

double positive(const YAML::Node& n, const char* key, const Ctx& c, const double* def = nullptr) {
  const double v = num(n, key, c, def);
  if (!(v > 0.0)) c.fail(std::string("field '") + key + "' must be > 0");
  return v;
}

bool pointOnFace(const Face& f, const Eigen::Vector3d& p, double eps) {
  const Eigen::Vector3d d = p - f.origin;
  if (std::abs(d.dot(f.normal)) > eps) return false;
  const double s = d.dot(f.u) / f.u.squaredNorm();
  const double t = d.dot(f.v) / f.v.squaredNorm();
  const double es = eps / f.u.norm(), et = eps / f.v.norm();
  return s >= -es && s <= 1.0 + es && t >= -et && t <= 1.0 + et && (!f.triangle || s + t <= 1.0 + es + et);
}

}  // namespace

int Scene::addFace(const std::string& object, const std::string& label, const Eigen::Vector3d& origin,
                   const Eigen::Vector3d& u, const Eigen::Vector3d& v, double reflectivity, bool triangle) {
  Face f;
  f.id = static_cast<int>(faces.size());
  f.surface = f.id;
  for (const Face& g : faces)
    if (g.object == object && g.label == label) {
      f.surface = g.surface;
      break;
    }
  f.triangle = triangle;
  f.object = object;
  f.label = label;
  f.origin = origin;
  f.u = u;
  f.v = v;
  f.normal = u.cross(v).normalized();
  f.reflectivity = reflectivity;
  faces.push_back(f);
  return f.id;
}

void Scene::updateAdjacency() {
  const std::size_t n = faces.size();
  crease_.assign(n, std::vector<unsigned char>(n, 0));
  constexpr double eps = 1e-4;
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      const Face& fa = faces[a];
      const Face& fb = faces[b];
      if (std::abs(fa.normal.dot(fb.normal)) > 1.0 - 1e-9) continue;  // parallel: no crease
      bool touch = false;
      for (const auto& c : fa.corners()) touch = touch || pointOnFace(fb, c, eps);
      for (const auto& c : fb.corners()) touch = touch || pointOnFace(fa, c, eps);
      crease_[a][b] = crease_[b][a] = touch;
    }
  }
}

bool Scene::creaseBetween(int a, int b) const {
  if (a < 0 || b < 0 || a >= static_cast<int>(crease_.size()) || b >= static_cast<int>(crease_.size()))
    return false;
  return crease_[a][b] != 0;
}

double Scene::heightAt(double x, double y) const {
  Hit hit;
  return raycast(Eigen::Vector3d(x, y, 100.0), -Eigen::Vector3d::UnitZ(), 200.0, hit) ? 100.0 - hit.t
                                                                                     : std::numeric_limits<double>::quiet_NaN();
}

bool Scene::raycast(const Eigen::Vector3d& o, const Eigen::Vector3d& dir, double max_t, Hit& hit) const {
  double best = max_t;
  int best_face = -1;
  double best_cos = 1.0;
  for (const Face& f : faces) {
    const double denom = dir.dot(f.normal);
    if (std::abs(denom) < 1e-12) continue;
    const double t = (f.origin - o).dot(f.normal) / denom;
    if (!(t > 1e-9) || t >= best) continue;
    const Eigen::Vector3d d = o + t * dir - f.origin;
    const double s = d.dot(f.u) / f.u.squaredNorm();
    const double w = d.dot(f.v) / f.v.squaredNorm();
    if (s < 0.0 || s > 1.0 || w < 0.0 || w > 1.0 || (f.triangle && s + w > 1.0)) continue;
    best = t;
    best_face = f.surface;
    best_cos = std::abs(denom);
  }
  if (best_face < 0) return false;
  hit.t = best;
  hit.face = best_face;
  hit.cos_incidence = best_cos;
  return true;
}

Scene Scene::parse(const std::string& text, const std::string& where) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(where + ": " + e.what());
  }
  Scene scene;
  scene.name = root["name"] ? root["name"].as<std::string>() : std::string("unnamed");
  const YAML::Node objects = root["objects"];
  if (!objects || !objects.IsSequence()) throw std::runtime_error(where + ": needs a list 'objects'");
  int index = 0;
  for (const YAML::Node& o : objects) {
    Ctx c{where, o["name"] ? o["name"].as<std::string>() : ("object" + std::to_string(index))};
    ++index;
    if (!o["type"]) c.fail("missing field 'type'");
    const std::string type = o["type"].as<std::string>();
    const double half = 0.5, zero = 0.0;
    const double refl = num(o, "reflectivity", c, &half);
    if (!(refl > 0.0 && refl <= 1.0)) c.fail("reflectivity must be in (0, 1]");
    const auto add = [&](const std::string& label, const Eigen::Vector3d& org, const Eigen::Vector3d& u,
                         const Eigen::Vector3d& v) { scene.addFace(c.object, label, org, u, v, refl); };
    if (type == "rect") {
      const auto org = vec(o, "origin", 3, c), u = vec(o, "u", 3, c), v = vec(o, "v", 3, c);
      const Eigen::Vector3d U(u[0], u[1], u[2]), V(v[0], v[1], v[2]);
      if (U.cross(V).norm() < 1e-9) c.fail("u and v must span a rectangle");
      const bool triangle = o["triangle"] && o["triangle"].as<bool>();
      if (triangle && std::abs(U.dot(V)) > 1e-9 * U.norm() * V.norm()) c.fail("a triangle's u and v must be at right angles");
      scene.addFace(c.object, o["label"] ? o["label"].as<std::string>() : std::string("face"),
                    Eigen::Vector3d(org[0], org[1], org[2]), U, V, refl, triangle);
    } else if (type == "floor") {
      const auto ctr = vec(o, "center", 2, c), size = vec(o, "size", 2, c);
      const double z = num(o, "z", c, &zero);
      if (!(size[0] > 0 && size[1] > 0)) c.fail("size must be > 0");
      add("floor", Eigen::Vector3d(ctr[0] - size[0] / 2, ctr[1] - size[1] / 2, z), Eigen::Vector3d(size[0], 0, 0),
          Eigen::Vector3d(0, size[1], 0));
    } else if (type == "wall") {
      const auto from = vec(o, "from", 2, c), to = vec(o, "to", 2, c);
      const double h = positive(o, "height", c), z = num(o, "z", c, &zero);
      const Eigen::Vector3d u(to[0] - from[0], to[1] - from[1], 0);
      if (u.norm() < 1e-9) c.fail("'from' and 'to' must differ");
      add("wall", Eigen::Vector3d(from[0], from[1], z), u, Eigen::Vector3d(0, 0, h));
    } else if (type == "board") {
      const auto ctr = vec(o, "center", 3, c);
      const double w = positive(o, "width", c), h = positive(o, "height", c), yaw = num(o, "yaw", c, &zero) * kDeg;
      const Eigen::Vector3d across(-std::sin(yaw), std::cos(yaw), 0), up(0, 0, 1);
      const Eigen::Vector3d center(ctr[0], ctr[1], ctr[2]);
      add("board", center - 0.5 * w * across - 0.5 * h * up, w * across, h * up);
    } else if (type == "box") {
      const auto ctr = vec(o, "center", 2, c), size = vec(o, "size", 3, c);
      const double yaw = num(o, "yaw", c, &zero) * kDeg, z = num(o, "z", c, &zero);
      if (!(size[0] > 0 && size[1] > 0 && size[2] > 0)) c.fail("size must be > 0");
      const Eigen::Vector3d ex = Eigen::Vector3d(std::cos(yaw), std::sin(yaw), 0) * size[0];
      const Eigen::Vector3d ey = Eigen::Vector3d(-std::sin(yaw), std::cos(yaw), 0) * size[1];
      const Eigen::Vector3d ez(0, 0, size[2]);
      const Eigen::Vector3d o0 = Eigen::Vector3d(ctr[0], ctr[1], z) - 0.5 * ex - 0.5 * ey;
      add("front", o0, ey, ez);            // -x side
      add("back", o0 + ex, ez, ey);        // +x side
      add("right", o0, ez, ex);            // -y side
      add("left", o0 + ey, ex, ez);        // +y side
      add("top", o0 + ez, ex, ey);
      if (z > 0.0) add("bottom", o0, ey, ex);
    } else if (type == "stairs") {
      const auto start = vec(o, "start", 2, c);
      const double yaw = num(o, "yaw", c, &zero) * kDeg, z = num(o, "z", c, &zero);
      const double rise = positive(o, "rise", c), run = positive(o, "run", c), width = positive(o, "width", c);
      const double steps_d = positive(o, "steps", c);
      const int steps = static_cast<int>(steps_d);
      if (steps != steps_d || steps > 100) c.fail("steps must be a whole number from 1 to 100");
      const double top_depth = positive(o, "top_depth", c, &run);
      const Eigen::Vector3d fwd(std::cos(yaw), std::sin(yaw), 0), left(-std::sin(yaw), std::cos(yaw), 0);
      const Eigen::Vector3d base = Eigen::Vector3d(start[0], start[1], z) - 0.5 * width * left;
      for (int k = 0; k < steps; ++k) {
        const Eigen::Vector3d foot = base + fwd * (k * run) + Eigen::Vector3d(0, 0, k * rise);
        add("riser" + std::to_string(k + 1), foot, width * left, Eigen::Vector3d(0, 0, rise));
        const double depth = (k + 1 == steps) ? top_depth : run;
        add("tread" + std::to_string(k + 1), foot + Eigen::Vector3d(0, 0, rise), fwd * depth, width * left);
      }
    } else {
      c.fail("unknown type '" + type + "' (rect, floor, wall, board, box, stairs)");
    }
  }
  scene.updateAdjacency();
  return scene;
}

Scene Scene::load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open scene file " + path);
  std::stringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path);
}

std::string configDirectory() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("TLP_CONFIG_DIR")) return env;
#ifdef TLP_INSTALL_SHARE_DIR
  if (fs::is_directory(TLP_INSTALL_SHARE_DIR "/config/scenes")) return TLP_INSTALL_SHARE_DIR "/config";
#endif
#ifdef TLP_SOURCE_DIR
  return TLP_SOURCE_DIR "/config";
#else
  return "config";
#endif
}

std::string sceneDirectory() { return configDirectory() + "/scenes"; }

Scene loadScene(const std::string& name_or_path) {
  namespace fs = std::filesystem;
  if (name_or_path.find('/') != std::string::npos || fs::exists(name_or_path)) return Scene::load(name_or_path);
  return Scene::load(sceneDirectory() + "/" + name_or_path + ".yaml");
}

}  // namespace sim
}  // namespace tilt_laser_perception
