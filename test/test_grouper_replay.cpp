// rostest: the planes and height map of the stairs scene, from the shipped
// recording (grouper_replay.test: replay.launch) or from the emulated head
// live (sim_pipeline.test: sim.launch), match the scene: floor at 0, treads at
// 0.15, 0.30, 0.45, 0.60 m (within 1 cm), risers, and the height map's cells.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <mutex>

#include <ros/ros.h>

#include "tilt_laser_perception/HeightMap.h"
#include "tilt_laser_perception/PlanePolygonArray.h"

using tilt_laser_perception::HeightMap;
using tilt_laser_perception::PlanePolygonArray;

namespace {
std::mutex m;
std::vector<PlanePolygonArray> planes;
std::vector<HeightMap> maps;

void onPlanes(const PlanePolygonArray::ConstPtr& p) {
  std::lock_guard<std::mutex> l(m);
  planes.push_back(*p);
}
void onMap(const HeightMap::ConstPtr& h) {
  std::lock_guard<std::mutex> l(m);
  maps.push_back(*h);
}

double cell(const HeightMap& map, double x, double y, int* cls = nullptr) {
  const int ix = static_cast<int>(std::floor((x - map.origin.position.x) / map.resolution));
  const int iy = static_cast<int>(std::floor((y - map.origin.position.y) / map.resolution));
  const std::size_t i = static_cast<std::size_t>(iy) * map.width + ix;
  if (cls) *cls = map.classes.at(i);
  return map.heights.at(i);
}
}  // namespace

TEST(GrouperReplay, PlanesAndHeightMapMatchTheStairs) {
  ros::NodeHandle nh;
  ros::Subscriber s1 = nh.subscribe("planes", 10, onPlanes);
  ros::Subscriber s2 = nh.subscribe("height_map", 10, onMap);
  int want = 3;
  double timeout = 40.0;
  ros::param::param("~sweeps", want, want);
  ros::param::param("~timeout", timeout, timeout);
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && ros::WallTime::now() < end) {
    ros::spinOnce();
    {
      std::lock_guard<std::mutex> l(m);
      if (planes.size() >= static_cast<std::size_t>(want) && maps.size() >= static_cast<std::size_t>(want)) break;
    }
    ros::WallDuration(0.05).sleep();
  }
  std::lock_guard<std::mutex> l(m);
  ASSERT_GE(planes.size(), 1u) << "no planes published";
  ASSERT_GE(maps.size(), 1u) << "no height map published";
  EXPECT_GE(planes.size(), static_cast<std::size_t>(want)) << "fewer sweeps than asked for within the time";
  std::vector<int> tread_seen(4, 0);
  int most_risers = 0;
  for (const PlanePolygonArray& arr : planes) {
    EXPECT_EQ(arr.header.frame_id, "base_footprint");
    // Horizontal planes: the floor (largest) at 0, the treads at their heights.
    double floor_area = 0, floor_z = 1e9;
    std::vector<double> heights;
    int risers = 0;
    for (const auto& p : arr.planes) {
      if (std::abs(p.normal.z) > 0.98 && p.area > 0.05) {
        heights.push_back(p.centroid.z);
        if (p.area > floor_area) {
          floor_area = p.area;
          floor_z = p.centroid.z;
        }
      }
      if (std::abs(p.normal.x) > 0.98 && p.area > 0.03 && std::abs(p.centroid.y) < 0.3)
        for (double x : {1.2, 1.5, 1.8, 2.1}) risers += std::abs(p.centroid.x - x) < 0.02;
    }
    std::printf("sweep at %.3f: %zu planes; horizontal at", arr.header.stamp.toSec(), arr.planes.size());
    for (double h : heights) std::printf(" %.3f", h);
    std::printf(" m; %d risers\n", risers);
    EXPECT_NEAR(floor_z, 0.0, 0.01);
    int treads = 0;
    for (int k = 0; k < 4; ++k) {
      double best = 1e9;
      for (double h : heights) best = std::min(best, std::abs(h - 0.15 * (k + 1)));
      treads += best < 0.01;
      tread_seen[k] += best < 0.01;
    }
    EXPECT_GE(treads, 3) << "fewer than 3 treads found within 1 cm in one sweep";
    // A riser is crossed by two or three scan lines only: some sweeps lose one.
    EXPECT_GE(risers, 1);
    most_risers = std::max(most_risers, risers);
  }
  EXPECT_GE(most_risers, 3) << "no sweep found three of the four risers";
  for (int k = 0; k < 4; ++k) EXPECT_GE(tread_seen[k], 1) << "tread " << k + 1 << " never found within 1 cm";
  for (const HeightMap& map : maps) {
    EXPECT_NEAR(map.resolution, 0.01, 1e-6);
    // Cells (x, y, true height, class) on the floor, the four treads and the box.
    const double cells[6][4] = {{0.95, -0.3, 0.0, HeightMap::CLASS_FLOOR}, {1.35, 0.0, 0.15, HeightMap::CLASS_STEP},
                                {1.65, 0.0, 0.30, HeightMap::CLASS_STEP},  {1.95, 0.0, 0.45, HeightMap::CLASS_STEP},
                                {2.60, 0.0, 0.60, HeightMap::CLASS_STEP},  {1.00, 0.95, 0.30, HeightMap::CLASS_STEP}};
    int right = 0;
    for (const auto& c : cells) {
      int cls = -1;
      const double h = cell(map, c[0], c[1], &cls);
      const bool ok = std::abs(h - c[2]) < 0.01 && cls == static_cast<int>(c[3]);
      if (!ok) std::printf("cell (%.2f, %.2f): %.3f m class %d, expected %.2f m class %.0f\n", c[0], c[1], h, cls, c[2], c[3]);
      right += ok;
    }
    EXPECT_GE(right, 5) << "the height map is wrong at more than one of six cells";
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_grouper_replay");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
