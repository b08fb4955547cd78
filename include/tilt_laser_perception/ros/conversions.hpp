/**
 * @file conversions.hpp
 * @brief Conversions between the ROS-free core types and ROS messages.
 */
#pragma once

#include <sensor_msgs/LaserScan.h>
#include <visualization_msgs/MarkerArray.h>

#include "tilt_laser_perception/ScanSegments.h"
#include "tilt_laser_perception/core/scan_split.hpp"

namespace tilt_laser_perception {

/// A view of a LaserScan for the splitter (points into the message).
core::ScanView toScanView(const sensor_msgs::LaserScan& scan);

/// Fills a ScanSegments message from a split result (header copied as given).
void toMsg(const core::SplitResult& result, const core::SplitParams& params, const std_msgs::Header& header,
           ScanSegments& msg);

/// rviz markers of a ScanSegments message: a LINE_LIST of the segments (one
/// colour per segment) and a SPHERE_LIST of the edge points coloured by kind
/// (jump red, occluded orange, crease blue, boundary green).
void segmentMarkers(const ScanSegments& segments, visualization_msgs::MarkerArray& markers);

}  // namespace tilt_laser_perception
