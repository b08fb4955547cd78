# The ROS-free libraries of tilt_laser_perception: the core algorithms, the
# SCIP and Dynamixel protocols, the driver loops and the simulator. Included by
# the catkin CMakeLists.txt and by ros_free/CMakeLists.txt (sanitizer builds,
# fuzzers). Needs Eigen3, yaml-cpp and Threads found, and TLP_SHARE_DIR set.
get_filename_component(TLP_ROOT "${CMAKE_CURRENT_LIST_DIR}/.." ABSOLUTE)
include_directories(${TLP_ROOT}/include)
include_directories(SYSTEM ${EIGEN3_INCLUDE_DIRS})

# ---- ROS-free core: Eigen and the standard library only -------------------
add_library(tlp_core
  ${TLP_ROOT}/src/core/scan_split.cpp
  ${TLP_ROOT}/src/core/tilt_profile.cpp
  ${TLP_ROOT}/src/core/plane.cpp
  ${TLP_ROOT}/src/core/grouping.cpp
  ${TLP_ROOT}/src/core/surface_tests.cpp
  ${TLP_ROOT}/src/core/noise_model.cpp
  ${TLP_ROOT}/src/core/scan_order.cpp
  ${TLP_ROOT}/src/core/sweep.cpp
  ${TLP_ROOT}/src/core/height_map.cpp
  ${TLP_ROOT}/src/core/fused_map.cpp
  ${TLP_ROOT}/src/core/polyline_split.cpp
  ${TLP_ROOT}/src/core/input_check.cpp
  ${TLP_ROOT}/src/core/calibration.cpp
  ${TLP_ROOT}/src/core/load_count.cpp)
# `#pragma omp simd` loops (no OpenMP runtime): the per-beam transforms.
target_compile_options(tlp_core PRIVATE -fopenmp-simd)
# segmentOrganized's second thread.
target_link_libraries(tlp_core Threads::Threads)
# The split of organized clouds' rows: -O3 unrolls its per-point loops
# (compare_pcl --organized 500: the split alone 7.0 -> 6.0 ms).
set_source_files_properties(${TLP_ROOT}/src/core/polyline_split.cpp PROPERTIES COMPILE_OPTIONS -O3)

# ---- ROS-free SCIP 2.0 codec and Dynamixel protocol library ----------------
add_library(tlp_scip ${TLP_ROOT}/src/scip/codec.cpp ${TLP_ROOT}/src/scip/time_sync.cpp ${TLP_ROOT}/src/scip/transport.cpp ${TLP_ROOT}/src/scip/client.cpp)
add_library(tlp_dynamixel ${TLP_ROOT}/src/dynamixel/protocol.cpp ${TLP_ROOT}/src/dynamixel/mx64.cpp ${TLP_ROOT}/src/dynamixel/bus.cpp
  ${TLP_ROOT}/src/dynamixel/termios2.cpp)

# ---- ROS-free driver loops (laser and servo threads) -----------------------
add_library(tlp_driver ${TLP_ROOT}/src/driver/laser_driver.cpp ${TLP_ROOT}/src/driver/servo_driver.cpp)
target_link_libraries(tlp_driver tlp_core tlp_scip tlp_dynamixel Threads::Threads)

# ---- ROS-free scene simulator and evaluation ------------------------------
add_library(tlp_sim
  ${TLP_ROOT}/src/sim/scene.cpp
  ${TLP_ROOT}/src/sim/lidar_sim.cpp
  ${TLP_ROOT}/src/sim/evaluation.cpp
  ${TLP_ROOT}/src/sim/head.cpp
  ${TLP_ROOT}/src/sim/walk.cpp
  ${TLP_ROOT}/src/sim/utm_emulator.cpp
  ${TLP_ROOT}/src/sim/mx64_emulator.cpp
  ${TLP_ROOT}/src/sim/scene_eval.cpp)
target_link_libraries(tlp_sim tlp_core tlp_scip tlp_dynamixel yaml-cpp util Threads::Threads)
target_compile_definitions(tlp_sim PRIVATE
  TLP_SOURCE_DIR="${TLP_ROOT}"
  TLP_INSTALL_SHARE_DIR="${TLP_SHARE_DIR}")

