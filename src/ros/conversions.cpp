#include "tilt_laser_perception/ros/conversions.hpp"

#include <cmath>

namespace tilt_laser_perception {

core::ScanView toScanView(const sensor_msgs::LaserScan& scan) {
  core::ScanView v;
  v.ranges = scan.ranges.data();
  v.size = scan.ranges.size();
  v.intensities = scan.intensities.empty() ? nullptr : scan.intensities.data();
  v.intensities_size = scan.intensities.size();
  v.angle_min = scan.angle_min;
  v.angle_max = scan.angle_max;
  v.angle_increment = scan.angle_increment;
  v.range_min = scan.range_min;
  v.range_max = scan.range_max;
  return v;
}

namespace {
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
  static const float palette[6][3] = {{0.9f, 0.6f, 0.0f}, {0.35f, 0.7f, 0.9f}, {0.0f, 0.6f, 0.5f},
                                      {0.95f, 0.9f, 0.25f}, {0.8f, 0.4f, 0.7f}, {0.6f, 0.6f, 0.6f}};
  for (std::size_t i = 0; i < seg.segments.size(); ++i) {
    const float* p = palette[i % 6];
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
      default: edges.colors.push_back(color(0.1f, 0.8f, 0.2f)); break;
    }
  }
}

}  // namespace tilt_laser_perception
