// rostest: the planes and height map of the stairs scene, from the shipped
// recording (grouper_replay.test: replay.launch) or from the emulated head
// live (sim_pipeline.test: sim.launch), match the scene: floor at 0, treads at
// 0.15, 0.30, 0.45, 0.60 m (within 1 cm), risers, and the height map's cells.
// With ~check_grid (namespaced_head.test: the head under a namespace, the
// laser given by urg_node's parameter names): scans come in the namespace,
// nothing in the root, and the OccupancyGrid's cells agree with the height
// map's classes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <mutex>

#include <nav_msgs/OccupancyGrid.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>

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
  const int ix = static_cast<int>(std::floor((x - map.info.origin.position.x) / map.info.resolution));
  const int iy = static_cast<int>(std::floor((y - map.info.origin.position.y) / map.info.resolution));
  const std::size_t i = static_cast<std::size_t>(iy) * map.info.width + ix;
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
  // A spinning head: a sweep each half turn, so planes every pi / speed seconds.
  double period = 0.0;
  ros::param::param("~sweep_period", period, period);
  if (period > 0.0) {
    ASSERT_GE(planes.size(), 3u);
    std::vector<double> gaps;
    for (std::size_t i = 1; i < planes.size(); ++i)
      gaps.push_back((planes[i].header.stamp - planes[i - 1].header.stamp).toSec());
    std::sort(gaps.begin(), gaps.end());
    std::printf("planes every %.3f s (median; shortest %.3f, longest %.3f), a half turn %.3f s\n", gaps[gaps.size() / 2],
                gaps.front(), gaps.back(), period);
    EXPECT_NEAR(gaps[gaps.size() / 2], period, 0.05 * period);
    EXPECT_NEAR(gaps.front(), period, 0.1 * period);
    EXPECT_NEAR(gaps.back(), period, 0.1 * period);
  }
  for (int k = 0; k < 4; ++k) EXPECT_GE(tread_seen[k], 1) << "tread " << k + 1 << " never found within 1 cm";
  for (const HeightMap& map : maps) {
    EXPECT_NEAR(map.info.resolution, 0.01, 1e-6);
    // The sweep's own map carries its uncertainty layer: a sigma for every known cell.
    ASSERT_EQ(map.sigmas.size(), map.heights.size());
    for (std::size_t c = 0; c < map.heights.size(); ++c)
      if (std::isfinite(map.heights[c])) {
        ASSERT_TRUE(map.sigmas[c] > 0.005f && map.sigmas[c] < 0.05f) << "cell " << c << ": " << map.sigmas[c];
      } else {
        ASSERT_TRUE(std::isnan(map.sigmas[c]));
      }
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

TEST(GrouperReplay, InItsNamespaceTheOccupancyGridsAgreeWithTheHeightMap) {
  bool check = false;
  ros::param::param("~check_grid", check, check);
  if (!check) GTEST_SKIP() << "~check_grid not set";
  ros::NodeHandle nh;
  std::mutex gm;
  std::vector<HeightMap> hmaps;
  std::vector<nav_msgs::OccupancyGrid> grids, steppable;
  int scans = 0;
  ros::Subscriber s1 = nh.subscribe<HeightMap>("height_map", 10, [&](const HeightMap::ConstPtr& h) {
    std::lock_guard<std::mutex> l(gm);
    hmaps.push_back(*h);
  });
  ros::Subscriber s2 = nh.subscribe<nav_msgs::OccupancyGrid>("height_map_grid", 10,
                                                             [&](const nav_msgs::OccupancyGrid::ConstPtr& g) {
                                                               std::lock_guard<std::mutex> l(gm);
                                                               grids.push_back(*g);
                                                             });
  ros::Subscriber s4 = nh.subscribe<nav_msgs::OccupancyGrid>("steppable_grid", 10,
                                                             [&](const nav_msgs::OccupancyGrid::ConstPtr& g) {
                                                               std::lock_guard<std::mutex> l(gm);
                                                               steppable.push_back(*g);
                                                             });
  ros::Subscriber s3 = nh.subscribe<sensor_msgs::LaserScan>("scan", 10, [&](const sensor_msgs::LaserScan::ConstPtr&) {
    std::lock_guard<std::mutex> l(gm);
    ++scans;
  });
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(60.0);
  int matched = 0;
  while (ros::ok() && ros::WallTime::now() < end && matched < 2) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
    std::lock_guard<std::mutex> l(gm);
    matched = 0;
    for (const auto& g : grids)
      for (const auto& h : hmaps)
        for (const auto& st : steppable)
          matched += g.header.stamp == h.header.stamp && st.header.stamp == h.header.stamp;
  }
  std::lock_guard<std::mutex> l(gm);
  EXPECT_GT(scans, 40) << "scans in " << nh.getNamespace();
  ASSERT_GE(matched, 2) << grids.size() << " grids, " << hmaps.size() << " height maps with no common stamp";
  for (const auto& g : grids)
    for (const auto& h : hmaps) {
      if (g.header.stamp != h.header.stamp) continue;
      EXPECT_EQ(g.header.frame_id, h.header.frame_id);
      EXPECT_EQ(g.info.width, h.info.width);
      EXPECT_EQ(g.info.height, h.info.height);
      EXPECT_FLOAT_EQ(g.info.resolution, h.info.resolution);
      EXPECT_DOUBLE_EQ(g.info.origin.position.x, h.info.origin.position.x);
      ASSERT_EQ(g.data.size(), h.classes.size());
      std::size_t known = 0, wrong = 0, obstacles = 0;
      for (std::size_t i = 0; i < g.data.size(); ++i) {
        const int want = h.classes[i] == HeightMap::CLASS_FLOOR      ? 0
                         : h.classes[i] == HeightMap::CLASS_STEP     ? 50
                         : h.classes[i] == HeightMap::CLASS_OBSTACLE ? 100
                                                                     : -1;
        wrong += g.data[i] != want;
        known += want >= 0;
        obstacles += want == 100;
      }
      EXPECT_EQ(wrong, 0u);
      EXPECT_GT(known, g.data.size() / 10) << "the stairs fill more than a tenth of the map";
      std::printf("grid at %.3f: %zu of %zu cells known, %zu obstacles, agreeing with the height map\n",
                  g.header.stamp.toSec(), known, g.data.size(), obstacles);
    }
  // The steppable layer: unknown where the map is, steppable only on the
  // floor and the treads (never an obstacle), and on a good part of them.
  for (const auto& st : steppable)
    for (const auto& h : hmaps) {
      if (st.header.stamp != h.header.stamp) continue;
      ASSERT_EQ(st.data.size(), h.classes.size());
      std::size_t fits = 0, wrong = 0, walkable = 0;
      for (std::size_t i = 0; i < st.data.size(); ++i) {
        const bool unknown = h.classes[i] == HeightMap::CLASS_UNKNOWN;
        const bool surface = h.classes[i] == HeightMap::CLASS_FLOOR || h.classes[i] == HeightMap::CLASS_STEP;
        wrong += (st.data[i] == -1) != unknown || (st.data[i] == 0 && !surface);
        fits += st.data[i] == 0;
        walkable += surface;
      }
      EXPECT_EQ(wrong, 0u);
      EXPECT_GT(fits, walkable / 3) << "a foot fits on a third of the walkable cells at least";
      EXPECT_LT(fits, walkable) << "not next to edges";
      std::printf("steppable at %.3f: %zu of %zu walkable cells\n", st.header.stamp.toSec(), fits, walkable);
    }
  // Everything the head publishes is in the namespace: nothing of it in the root.
  ros::master::V_TopicInfo topics;
  ASSERT_TRUE(ros::master::getTopics(topics));
  const std::string ns = nh.getNamespace();
  for (const auto& t : topics)
    for (const char* name :
         {"/scan", "/planes", "/height_map", "/height_map_grid", "/steppable_grid", "/joint_states", "/scan_segments"})
      EXPECT_NE(t.name, name) << "published in the root namespace, not in " << ns;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_grouper_replay");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
