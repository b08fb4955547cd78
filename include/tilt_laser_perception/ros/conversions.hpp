/**
 * @file conversions.hpp
 * @brief Conversions between the ROS-free core types and ROS messages.
 */
#pragma once

#include <cstdint>

#include <sensor_msgs/LaserScan.h>
#include <visualization_msgs/MarkerArray.h>

#include "tilt_laser_perception/ScanSegments.h"
#include "tilt_laser_perception/core/scan_split.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

namespace tilt_laser_perception {

/// The scans (and their splits) a subscriber queues: 1.25 s at 40 Hz. A
/// loaded machine's stall of a few hundred milliseconds (seen in CI's replay
/// with 10) is caught up, not a good scan lost. The splitter, the grouper and
/// the grouper's pairing of scans with their splits all hold this many.
constexpr std::uint32_t kScanQueue = 50;

/// A view of a LaserScan for the splitter (points into the message). Intensities of
/// another length than the ranges are left out (the ranges are kept).
core::ScanView toScanView(const sensor_msgs::LaserScan& scan);
/// A scan's fields as the sweep assembler takes them (its segments and edges
/// left to the caller); intensities of another length than the ranges are left out.
core::LineInput toLineInput(const sensor_msgs::LaserScan& scan);

/// Fills a ScanSegments message from a split result (header copied as given).
void toMsg(const core::SplitResult& result, const core::SplitParams& params, const std_msgs::Header& header,
           ScanSegments& msg);

/// rviz markers of a ScanSegments message: a LINE_LIST of the segments (one
/// colour per segment) and a SPHERE_LIST of the edge points coloured by kind
/// (jump red, occluded orange, crease blue, boundary green).
void segmentMarkers(const ScanSegments& segments, visualization_msgs::MarkerArray& markers);

}  // namespace tilt_laser_perception

#include <sensor_msgs/PointCloud2.h>
#include <urdf/model.h>

#include <nav_msgs/MapMetaData.h>
#include <nav_msgs/OccupancyGrid.h>

#include "tilt_laser_perception/HeightMap.h"
#include "tilt_laser_perception/PlanePolygonArray.h"
#include "tilt_laser_perception/core/height_map.hpp"
#include "tilt_laser_perception/core/sweep.hpp"

namespace tilt_laser_perception {

/// A URDF origin as an isometry.
Eigen::Isometry3d toIsometry(const urdf::Pose& p);

/// The tilt chain from a URDF: the joint's parent link (whose pose comes from
/// tf), the joint's origin and axis, and the fixed joints from its child link
/// to `laser_frame`. False with a message when the joint is missing, not
/// revolute, or a joint between it and the laser is not fixed.
bool tiltChainFromUrdf(const urdf::Model& model, const std::string& joint, const std::string& laser_frame,
                       core::TiltChain& chain, std::string& parent_link, std::string& error);

/// Planes as messages (in the sweep's frame).
void toMsg(const std::vector<core::Plane>& planes, PlanePolygonArray& msg);
/// The height map as a message.
void toMsg(const core::HeightMapGrid& grid, HeightMap& msg);
/// The grid's size and place (map_load_time left to the caller).
void toMsg(const core::HeightMapGrid& grid, nav_msgs::MapMetaData& info);
/// The classes as occupancy (core::occupancyOfClass), for costmaps and rviz's Map display.
void toOccupancyGrid(const core::HeightMapGrid& grid, nav_msgs::OccupancyGrid& msg);
/// The steppable layer (core::steppableCells: 1, 0, 255) as occupancy: a
/// foot fits 0 (free), it does not 100, unknown -1.
void steppableGrid(const core::HeightMapGrid& grid, const std::vector<std::uint8_t>& steppable,
                   nav_msgs::OccupancyGrid& msg);
/// The height map as a cloud of its known cells (x y z rgb, coloured by height).
void heightMapCloud(const core::HeightMapGrid& grid, sensor_msgs::PointCloud2& cloud);
/// The sweep as an organized cloud: a row per scan line, a column per beam;
/// fields x y z intensity ring time (time since the sweep's start [s]); NaN where there was no return.
void sweepCloud(const core::SweepResult& sweep, sensor_msgs::PointCloud2& cloud);
/// The edge points of the sweep: x y z kind (1 jump, 2 occluded, 3 crease, 4 boundary).
void edgeCloud(const core::SweepResult& sweep, sensor_msgs::PointCloud2& cloud);
/// rviz markers: filled plane polygons (one colour per plane), outlines, normals and ids.
void planeMarkers(const std::vector<core::Plane>& planes, const std_msgs::Header& header,
                  visualization_msgs::MarkerArray& markers);

}  // namespace tilt_laser_perception
