#include "tilt_laser_perception/sim/pcd.hpp"

#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace tilt_laser_perception {
namespace sim {

OrganizedCloud readPcd(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::vector<std::string> fields;
  std::vector<int> sizes, counts;
  std::vector<char> types;
  OrganizedCloud c;
  std::string data, line;
  long points = -1;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    std::string v;
    if (key == "FIELDS") while (ss >> v) fields.push_back(v);
    else if (key == "SIZE") while (ss >> v) sizes.push_back(std::stoi(v));
    else if (key == "TYPE") while (ss >> v) types.push_back(v[0]);
    else if (key == "COUNT") while (ss >> v) counts.push_back(std::stoi(v));
    else if (key == "WIDTH") ss >> c.width;
    else if (key == "HEIGHT") ss >> c.height;
    else if (key == "POINTS") ss >> points;
    else if (key == "VIEWPOINT") ss >> c.viewpoint.x() >> c.viewpoint.y() >> c.viewpoint.z();
    else if (key == "DATA") {
      ss >> data;
      break;
    }
  }
  if (counts.empty()) counts.assign(fields.size(), 1);
  if (fields.empty() || sizes.size() != fields.size() || types.size() != fields.size() || counts.size() != fields.size())
    throw std::runtime_error(path + ": bad PCD header");
  if (c.width <= 0 || c.height <= 0) throw std::runtime_error(path + ": WIDTH and HEIGHT must be positive");
  const std::size_t n = static_cast<std::size_t>(c.width) * c.height;
  int ix = -1, iy = -1, iz = -1;
  std::vector<int> offset(fields.size());
  int stride = 0;
  for (std::size_t f = 0; f < fields.size(); ++f) {
    offset[f] = stride;
    stride += sizes[f] * counts[f];
    if (fields[f] == "x") ix = static_cast<int>(f);
    if (fields[f] == "y") iy = static_cast<int>(f);
    if (fields[f] == "z") iz = static_cast<int>(f);
  }
  if (ix < 0 || iy < 0 || iz < 0) throw std::runtime_error(path + ": needs fields x, y and z");
  for (int f : {ix, iy, iz})
    if (types[f] != 'F' || (sizes[f] != 4 && sizes[f] != 8)) throw std::runtime_error(path + ": x, y, z must be floats");
  c.points.assign(n, Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  const auto get = [&](const char* rec, int f) {
    if (sizes[f] == 4) {
      float v;
      std::memcpy(&v, rec + offset[f], 4);
      return v;
    }
    double v;
    std::memcpy(&v, rec + offset[f], 8);
    return static_cast<float>(v);
  };
  if (data == "binary") {
    std::vector<char> buf(n * stride);
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    if (static_cast<std::size_t>(in.gcount()) != buf.size()) throw std::runtime_error(path + ": data is short");
    for (std::size_t i = 0; i < n; ++i) {
      const char* rec = buf.data() + i * stride;
      c.points[i] = Eigen::Vector3f(get(rec, ix), get(rec, iy), get(rec, iz));
    }
  } else if (data == "ascii") {
    std::size_t total = 0;
    for (int k : counts) total += k;
    for (std::size_t i = 0; i < n; ++i) {
      std::vector<double> vals(total);
      for (auto& v : vals) {
        std::string tok;
        if (!(in >> tok)) throw std::runtime_error(path + ": data is short");
        v = tok == "nan" || tok == "NaN" ? std::numeric_limits<double>::quiet_NaN() : std::stod(tok);
      }
      std::size_t k = 0;
      float xyz[3] = {0, 0, 0};
      for (std::size_t f = 0; f < fields.size(); ++f) {
        if (static_cast<int>(f) == ix) xyz[0] = static_cast<float>(vals[k]);
        if (static_cast<int>(f) == iy) xyz[1] = static_cast<float>(vals[k]);
        if (static_cast<int>(f) == iz) xyz[2] = static_cast<float>(vals[k]);
        k += counts[f];
      }
      c.points[i] = Eigen::Vector3f(xyz[0], xyz[1], xyz[2]);
    }
  } else {
    throw std::runtime_error(path + ": DATA " + data + " is not supported (ascii or binary)");
  }
  return c;
}

void writeLabeledPcd(const std::string& path, const OrganizedCloud& c, const std::vector<std::uint32_t>& labels) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << "# .PCD v0.7 - written by tilt_laser_perception segment_cloud\nVERSION 0.7\nFIELDS x y z label\n"
      << "SIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH " << c.width << "\nHEIGHT " << c.height
      << "\nVIEWPOINT " << c.viewpoint.x() << ' ' << c.viewpoint.y() << ' ' << c.viewpoint.z() << " 1 0 0 0\nPOINTS "
      << c.points.size() << "\nDATA binary\n";
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    out.write(reinterpret_cast<const char*>(c.points[i].data()), 12);
    const std::uint32_t l = i < labels.size() ? labels[i] : 0;
    out.write(reinterpret_cast<const char*>(&l), 4);
  }
}

}  // namespace sim
}  // namespace tilt_laser_perception
