#include "tilt_laser_perception/ros/conversions.hpp"

#include <cmath>

namespace tilt_laser_perception {

core::ScanView toScanView(const sensor_msgs::LaserScan& scan) {
  core::ScanView v;
  v.ranges = scan.ranges.data();
  v.size = scan.ranges.size();
  // Intensities of another length than the ranges (some drivers publish
  // them so): the ranges are kept, the intensities left out.
  const bool intensities = !scan.intensities.empty() && scan.intensities.size() == scan.ranges.size();
  v.intensities = intensities ? scan.intensities.data() : nullptr;
  v.intensities_size = intensities ? scan.intensities.size() : 0;
  v.angle_min = scan.angle_min;
  v.angle_max = scan.angle_max;
  v.angle_increment = scan.angle_increment;
  v.range_min = scan.range_min;
  v.range_max = scan.range_max;
  v.time_increment = scan.time_increment;
  v.scan_time = scan.scan_time;
  return v;
}

core::LineInput toLineInput(const sensor_msgs::LaserScan& scan) {
  core::LineInput in;
  in.ranges = scan.ranges;
  if (scan.intensities.size() == scan.ranges.size()) in.intensities = scan.intensities;
  in.angle_min = scan.angle_min;
  in.angle_increment = scan.angle_increment;
  in.range_min = scan.range_min;
  in.range_max = scan.range_max;
  in.stamp = scan.header.stamp.toSec();
  in.time_increment = scan.time_increment;
  return in;
}

namespace {
// Warm and green hues only (no blue: that is the height map's).
const float planePalette[8][3] = {{0.95f, 0.55f, 0.10f}, {0.95f, 0.85f, 0.20f}, {0.85f, 0.20f, 0.15f},
                                  {0.40f, 0.80f, 0.25f}, {0.90f, 0.45f, 0.65f}, {0.70f, 0.70f, 0.10f},
                                  {0.75f, 0.30f, 0.80f}, {0.60f, 0.90f, 0.40f}};
geometry_msgs::Point point(const Eigen::Vector2d& p) {
  geometry_msgs::Point q;
  q.x = p.x();
  q.y = p.y();
  q.z = 0.0;
  return q;
}
std_msgs::ColorRGBA color(float r, float g, float b) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = 1.0f;
  return c;
}
}  // namespace

void toMsg(const core::SplitResult& result, const core::SplitParams& params, const std_msgs::Header& header,
           ScanSegments& msg) {
  msg.header = header;
  msg.segments.resize(result.segments.size());
  for (std::size_t i = 0; i < result.segments.size(); ++i) {
    const core::Segment& s = result.segments[i];
    LineSegment& m = msg.segments[i];
    m.first_index = static_cast<uint32_t>(s.first);
    m.last_index = static_cast<uint32_t>(s.last);
    m.start = point(s.start);
    m.end = point(s.end);
    m.point_count = static_cast<uint32_t>(s.count);
    m.rms_error = static_cast<float>(s.rms);
    m.sum_x = s.moments.sx;
    m.sum_y = s.moments.sy;
    m.sum_xx = s.moments.sxx;
    m.sum_xy = s.moments.sxy;
    m.sum_yy = s.moments.syy;
  }
  const std::size_t ne = result.edges.size();
  msg.edge_indices.resize(ne);
  msg.edge_kinds.resize(ne);
  msg.edge_angles.resize(ne);
  msg.edge_points.resize(ne);
  for (std::size_t i = 0; i < ne; ++i) {
    const core::EdgePoint& e = result.edges[i];
    msg.edge_indices[i] = static_cast<uint32_t>(e.index);
    msg.edge_kinds[i] = static_cast<uint8_t>(e.kind);
    msg.edge_angles[i] = static_cast<float>(e.angle);
    msg.edge_points[i] = point(e.point);
  }
  msg.mode = params.mode == core::SplitMode::Fixed ? ScanSegments::MODE_FIXED : ScanSegments::MODE_ADAPTIVE;
  msg.zeta = static_cast<float>(params.zeta);
  msg.d_min = static_cast<float>(params.d_min);
  msg.jump_min = static_cast<float>(params.jump_min);
  msg.jump_ratio = static_cast<float>(params.jump_ratio);
  msg.min_points = static_cast<uint32_t>(params.min_points);
  msg.merge = params.merge;
}

void segmentMarkers(const ScanSegments& seg, visualization_msgs::MarkerArray& markers) {
  markers.markers.resize(2);
  visualization_msgs::Marker& lines = markers.markers[0];
  lines.header = seg.header;
  lines.ns = "segments";
  lines.id = 0;
  lines.type = visualization_msgs::Marker::LINE_LIST;
  lines.action = visualization_msgs::Marker::ADD;
  lines.pose.orientation.w = 1.0;
  lines.scale.x = 0.02;
  lines.color = color(1, 1, 1);
  lines.points.clear();
  lines.colors.clear();
  for (std::size_t i = 0; i < seg.segments.size(); ++i) {
    const float* p = planePalette[i % 8];
    lines.points.push_back(seg.segments[i].start);
    lines.points.push_back(seg.segments[i].end);
    lines.colors.push_back(color(p[0], p[1], p[2]));
    lines.colors.push_back(color(p[0], p[1], p[2]));
  }
  visualization_msgs::Marker& edges = markers.markers[1];
  edges.header = seg.header;
  edges.ns = "edge_points";
  edges.id = 1;
  edges.type = visualization_msgs::Marker::SPHERE_LIST;
  edges.action = visualization_msgs::Marker::ADD;
  edges.pose.orientation.w = 1.0;
  edges.scale.x = edges.scale.y = edges.scale.z = 0.05;
  edges.color = color(1, 1, 1);
  edges.points = seg.edge_points;
  edges.colors.clear();
  for (uint8_t k : seg.edge_kinds) {
    switch (k) {
      case ScanSegments::EDGE_JUMP: edges.colors.push_back(color(0.9f, 0.1f, 0.1f)); break;
      case ScanSegments::EDGE_OCCLUDED: edges.colors.push_back(color(1.0f, 0.55f, 0.0f)); break;
      case ScanSegments::EDGE_CREASE: edges.colors.push_back(color(0.2f, 0.3f, 1.0f)); break;
      case ScanSegments::EDGE_VEIL: edges.colors.push_back(color(0.6f, 0.6f, 0.6f)); break;
      default: edges.colors.push_back(color(0.1f, 0.8f, 0.2f)); break;
    }
  }
}

}  // namespace tilt_laser_perception

#include <sensor_msgs/point_cloud2_iterator.h>

namespace tilt_laser_perception {

Eigen::Isometry3d toIsometry(const urdf::Pose& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  T.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z).toRotationMatrix();
  return T;
}

namespace {
geometry_msgs::Point32 point32(const Eigen::Vector3d& p) {
  geometry_msgs::Point32 q;
  q.x = static_cast<float>(p.x());
  q.y = static_cast<float>(p.y());
  q.z = static_cast<float>(p.z());
  return q;
}
void heightColor(double t, float& r, float& g, float& b) {
  // dark blue (low) -> cyan -> pale blue-white (high): the height map keeps to
  // blue hues so that the plane polygons (warm colours, planePalette) stand
  // apart from it in rviz and in the screenshot check
  t = std::max(0.0, std::min(1.0, t));
  r = static_cast<float>(t < 0.5 ? 0.0 : 0.9 * (t - 0.5));
  g = static_cast<float>(0.15 + 0.75 * t);
  b = static_cast<float>(0.55 + 0.45 * t);
}

}  // namespace

bool tiltChainFromUrdf(const urdf::Model& model, const std::string& joint_name, const std::string& laser_frame,
                       core::TiltChain& chain, std::string& parent_link, std::string& error) {
  const urdf::JointConstSharedPtr joint = model.getJoint(joint_name);
  if (!joint) {
    error = "the URDF has no joint '" + joint_name + "'";
    return false;
  }
  if (joint->type != urdf::Joint::REVOLUTE && joint->type != urdf::Joint::CONTINUOUS) {
    error = "joint '" + joint_name + "' is not revolute";
    return false;
  }
  parent_link = joint->parent_link_name;
  chain.base_to_joint = toIsometry(joint->parent_to_joint_origin_transform);
  chain.axis = Eigen::Vector3d(joint->axis.x, joint->axis.y, joint->axis.z).normalized();
  // From the laser frame up to the joint's child link: fixed joints only.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  std::string link = laser_frame;
  while (link != joint->child_link_name) {
    const urdf::LinkConstSharedPtr l = model.getLink(link);
    if (!l || !l->parent_joint) {
      error = "the URDF has no chain from '" + joint->child_link_name + "' to the laser frame '" + laser_frame + "'";
      return false;
    }
    if (l->parent_joint->type != urdf::Joint::FIXED) {
      error = "joint '" + l->parent_joint->name + "' between the tilt joint and the laser is not fixed";
      return false;
    }
    T = toIsometry(l->parent_joint->parent_to_joint_origin_transform) * T;
    link = l->parent_joint->parent_link_name;
  }
  chain.joint_to_laser = T;
  return true;
}

void toMsg(const std::vector<core::Plane>& planes, PlanePolygonArray& msg) {
  msg.planes.resize(planes.size());
  for (std::size_t i = 0; i < planes.size(); ++i) {
    const core::Plane& p = planes[i];
    PlanePolygon& m = msg.planes[i];
    m.id = static_cast<uint32_t>(p.id);
    m.normal.x = p.fit.normal.x();
    m.normal.y = p.fit.normal.y();
    m.normal.z = p.fit.normal.z();
    m.offset = p.fit.offset;
    m.centroid.x = p.fit.centroid.x();
    m.centroid.y = p.fit.centroid.y();
    m.centroid.z = p.fit.centroid.z();
    m.area = p.area;
    m.rms_error = p.fit.rms;
    m.point_count = static_cast<uint32_t>(p.points);
    m.segment_count = static_cast<uint32_t>(p.segments);
    m.boundary.points.clear();
    for (const auto& v : p.boundary) m.boundary.points.push_back(point32(v));
    m.holes.resize(p.holes.size());
    for (std::size_t h = 0; h < p.holes.size(); ++h) {
      m.holes[h].points.clear();
      for (const auto& v : p.holes[h]) m.holes[h].points.push_back(point32(v));
    }
  }
}

void toMsg(const core::HeightMapGrid& g, nav_msgs::MapMetaData& info) {
  info.resolution = static_cast<float>(g.params.resolution);
  info.width = static_cast<uint32_t>(g.params.width);
  info.height = static_cast<uint32_t>(g.params.height);
  info.origin.position.x = g.params.origin_x;
  info.origin.position.y = g.params.origin_y;
  info.origin.position.z = 0.0;
  info.origin.orientation.w = 1.0;
}

void toMsg(const core::HeightMapGrid& g, HeightMap& msg) {
  toMsg(g, msg.info);
  msg.heights = g.heights;
  msg.plane_ids = g.plane_ids;
  msg.classes.resize(g.classes.size());
  for (std::size_t i = 0; i < g.classes.size(); ++i) msg.classes[i] = static_cast<uint8_t>(g.classes[i]);
}

void toOccupancyGrid(const core::HeightMapGrid& g, nav_msgs::OccupancyGrid& msg) {
  toMsg(g, msg.info);
  msg.data.resize(g.classes.size());
  for (std::size_t i = 0; i < g.classes.size(); ++i) msg.data[i] = core::occupancyOfClass(g.classes[i]);
}

void steppableGrid(const core::HeightMapGrid& g, const std::vector<std::uint8_t>& steppable,
                   nav_msgs::OccupancyGrid& msg) {
  toMsg(g, msg.info);
  msg.data.resize(steppable.size());
  for (std::size_t i = 0; i < steppable.size(); ++i)
    msg.data[i] = steppable[i] == 1 ? 0 : steppable[i] == 0 ? 100 : -1;
}

void heightMapCloud(const core::HeightMapGrid& g, sensor_msgs::PointCloud2& cloud) {
  std::size_t known = 0;
  float zmin = 1e30f, zmax = -1e30f;
  for (float h : g.heights)
    if (std::isfinite(h)) {
      ++known;
      zmin = std::min(zmin, h);
      zmax = std::max(zmax, h);
    }
  sensor_msgs::PointCloud2Modifier mod(cloud);
  mod.setPointCloud2FieldsByString(2, "xyz", "rgb");
  mod.resize(known);
  cloud.height = 1;
  cloud.width = static_cast<uint32_t>(known);
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  sensor_msgs::PointCloud2Iterator<uint8_t> rgb(cloud, "rgb");
  const float span = std::max(0.05f, zmax - zmin);
  for (int iy = 0; iy < g.params.height; ++iy)
    for (int ix = 0; ix < g.params.width; ++ix) {
      const float h = g.heights[g.index(ix, iy)];
      if (!std::isfinite(h)) continue;
      *x = static_cast<float>(g.params.origin_x + (ix + 0.5) * g.params.resolution);
      *y = static_cast<float>(g.params.origin_y + (iy + 0.5) * g.params.resolution);
      *z = h;
      float r, gg, b;
      heightColor((h - zmin) / span, r, gg, b);
      if (g.classes[g.index(ix, iy)] == core::CellClass::Obstacle) r = 1.0f, gg = 0.1f, b = 0.8f;
      rgb[0] = static_cast<uint8_t>(b * 255);
      rgb[1] = static_cast<uint8_t>(gg * 255);
      rgb[2] = static_cast<uint8_t>(r * 255);
      ++x, ++y, ++z, ++rgb;
    }
}

void sweepCloud(const core::SweepResult& sw, sensor_msgs::PointCloud2& cloud) {
  const std::size_t rows = sw.lines.size();
  const std::size_t cols = rows ? sw.lines[0].points.size() : 0;
  sensor_msgs::PointCloud2Modifier mod(cloud);
  mod.setPointCloud2Fields(6, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
                           sensor_msgs::PointField::FLOAT32, "intensity", 1, sensor_msgs::PointField::FLOAT32, "ring", 1,
                           sensor_msgs::PointField::UINT16, "time", 1, sensor_msgs::PointField::FLOAT32);
  mod.resize(rows * cols);
  cloud.height = static_cast<uint32_t>(rows);
  cloud.width = static_cast<uint32_t>(cols);
  cloud.row_step = cloud.width * cloud.point_step;
  cloud.is_dense = false;
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z"), in(cloud, "intensity"),
      tm(cloud, "time");
  sensor_msgs::PointCloud2Iterator<uint16_t> ring(cloud, "ring");
  for (std::size_t r = 0; r < rows; ++r) {
    const core::SweepLine& l = sw.lines[r];
    for (std::size_t c = 0; c < cols; ++c, ++x, ++y, ++z, ++in, ++ring, ++tm) {
      const bool ok = c < l.points.size();
      *x = ok ? l.points[c].x() : NAN;
      *y = ok ? l.points[c].y() : NAN;
      *z = ok ? l.points[c].z() : NAN;
      *in = ok && c < l.intensities.size() ? l.intensities[c] : 0.0f;
      *ring = static_cast<uint16_t>(r);
      *tm = static_cast<float>(l.stamp + c * l.time_increment - sw.start);
    }
  }
}

void edgeCloud(const core::SweepResult& sw, sensor_msgs::PointCloud2& cloud) {
  std::size_t n = 0;
  for (const auto& l : sw.lines)
    for (const auto& e : l.edges) n += e.first >= 0 && e.first < static_cast<int>(l.points.size()) && std::isfinite(l.points[e.first].x());
  sensor_msgs::PointCloud2Modifier mod(cloud);
  mod.setPointCloud2Fields(4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
                           sensor_msgs::PointField::FLOAT32, "kind", 1, sensor_msgs::PointField::UINT8);
  mod.resize(n);
  cloud.height = 1;
  cloud.width = static_cast<uint32_t>(n);
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  sensor_msgs::PointCloud2Iterator<uint8_t> kind(cloud, "kind");
  for (const auto& l : sw.lines)
    for (const auto& e : l.edges) {
      if (e.first < 0 || e.first >= static_cast<int>(l.points.size()) || !std::isfinite(l.points[e.first].x())) continue;
      *x = l.points[e.first].x();
      *y = l.points[e.first].y();
      *z = l.points[e.first].z();
      *kind = static_cast<uint8_t>(e.second);
      ++x, ++y, ++z, ++kind;
    }
}

namespace {
/// Ear clipping of a simple polygon given in 2D; returns vertex index triples.
std::vector<int> triangulate(const std::vector<Eigen::Vector2d>& pts) {
  std::vector<int> out, idx(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) idx[i] = static_cast<int>(i);
  double area = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto& a = pts[i];
    const auto& b = pts[(i + 1) % pts.size()];
    area += a.x() * b.y() - b.x() * a.y();
  }
  const double sign = area >= 0 ? 1.0 : -1.0;
  const auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::size_t guard = 0;
  while (idx.size() > 2 && guard++ < 4 * pts.size() * pts.size()) {
    bool clipped = false;
    for (std::size_t i = 0; i < idx.size(); ++i) {
      const int ia = idx[(i + idx.size() - 1) % idx.size()], ib = idx[i], ic = idx[(i + 1) % idx.size()];
      if (sign * cross(pts[ia], pts[ib], pts[ic]) <= 0) continue;  // reflex
      bool inside = false;
      for (int j : idx) {
        if (j == ia || j == ib || j == ic) continue;
        if (sign * cross(pts[ia], pts[ib], pts[j]) > 0 && sign * cross(pts[ib], pts[ic], pts[j]) > 0 &&
            sign * cross(pts[ic], pts[ia], pts[j]) > 0) {
          inside = true;
          break;
        }
      }
      if (inside) continue;
      out.insert(out.end(), {ia, ib, ic});
      idx.erase(idx.begin() + static_cast<long>(i));
      clipped = true;
      break;
    }
    if (!clipped) break;  // degenerate: stop
  }
  return out;
}
}  // namespace

void planeMarkers(const std::vector<core::Plane>& planes, const std_msgs::Header& header,
                  visualization_msgs::MarkerArray& markers) {
  markers.markers.clear();
  visualization_msgs::Marker clear;
  clear.action = visualization_msgs::Marker::DELETEALL;
  markers.markers.push_back(clear);
  visualization_msgs::Marker fill, lines, arrows;
  fill.header = lines.header = arrows.header = header;
  fill.ns = "plane_fill";
  lines.ns = "plane_outline";
  arrows.ns = "plane_normal";
  fill.type = visualization_msgs::Marker::TRIANGLE_LIST;
  lines.type = visualization_msgs::Marker::LINE_LIST;
  arrows.type = visualization_msgs::Marker::LINE_LIST;
  fill.pose.orientation.w = lines.pose.orientation.w = arrows.pose.orientation.w = 1.0;
  fill.scale.x = fill.scale.y = fill.scale.z = 1.0;
  lines.scale.x = 0.01;
  arrows.scale.x = 0.015;
  fill.color.a = lines.color.a = arrows.color.a = 1.0;
  for (const core::Plane& p : planes) {
    const float* c = planePalette[p.id % 8];
    std_msgs::ColorRGBA col;
    col.r = c[0];
    col.g = c[1];
    col.b = c[2];
    col.a = 0.7f;
    const Eigen::Vector3d u = p.fit.normal.unitOrthogonal();
    const Eigen::Vector3d v = p.fit.normal.cross(u);
    std::vector<Eigen::Vector2d> pts2;
    for (const auto& q : p.boundary) pts2.emplace_back(q.dot(u), q.dot(v));
    for (int i : triangulate(pts2)) {
      geometry_msgs::Point pt;
      pt.x = p.boundary[i].x();
      pt.y = p.boundary[i].y();
      pt.z = p.boundary[i].z();
      fill.points.push_back(pt);
      fill.colors.push_back(col);
    }
    col.a = 1.0f;
    const auto ring = [&](const std::vector<Eigen::Vector3d>& poly) {
      for (std::size_t i = 0; i < poly.size(); ++i) {
        for (const auto* q : {&poly[i], &poly[(i + 1) % poly.size()]}) {
          geometry_msgs::Point pt;
          pt.x = q->x();
          pt.y = q->y();
          pt.z = q->z();
          lines.points.push_back(pt);
          lines.colors.push_back(col);
        }
      }
    };
    ring(p.boundary);
    for (const auto& h : p.holes) ring(h);
    geometry_msgs::Point a, b;
    a.x = p.fit.centroid.x();
    a.y = p.fit.centroid.y();
    a.z = p.fit.centroid.z();
    b.x = a.x + 0.2 * p.fit.normal.x();
    b.y = a.y + 0.2 * p.fit.normal.y();
    b.z = a.z + 0.2 * p.fit.normal.z();
    arrows.points.push_back(a);
    arrows.points.push_back(b);
    arrows.colors.push_back(col);
    arrows.colors.push_back(col);
    visualization_msgs::Marker text;
    text.header = header;
    text.ns = "plane_id";
    text.id = p.id;
    text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    text.pose.position = b;
    text.pose.orientation.w = 1.0;
    text.scale.z = 0.08;
    text.color.r = text.color.g = text.color.b = text.color.a = 1.0f;
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%d: %.2f m2", p.id, p.area);
    text.text = buf;
    markers.markers.push_back(text);
  }
  markers.markers.push_back(fill);
  markers.markers.push_back(lines);
  markers.markers.push_back(arrows);
}

}  // namespace tilt_laser_perception
