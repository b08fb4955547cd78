# The ROS-free gtests, listed once for both builds: the catkin one
# (CMakeLists.txt, through catkin_add_gtest) and the ROS-free one
# (ros_free/CMakeLists.txt: the sanitizer builds). An entry is
# NAME:LIB[,LIB...]:SOURCE[,SOURCE...] with sources in test/.
# scripts/ci/check_test_lists.sh fails when a ROS-free test/test_*.cpp is not here.
set(TLP_ROS_FREE_TESTS
  "test_core:tlp_core:test_scan_split.cpp,test_grouping.cpp,test_surface_tests.cpp,test_noise_model.cpp,test_scan_order.cpp,test_sweep.cpp,test_height_map.cpp,test_organized_lines.cpp,test_input_check.cpp,test_fused_map.cpp"
  "test_sim:tlp_sim:test_sim.cpp"
  "test_calibration:tlp_sim:test_calibration.cpp"
  "test_protocols:tlp_scip,tlp_dynamixel:test_scip.cpp,test_dynamixel.cpp,test_time_sync.cpp"
  "test_head:tlp_sim:test_head.cpp,test_emulators.cpp,test_client.cpp"
  "test_drivers:tlp_driver,tlp_sim:test_drivers.cpp")

# Adds every test of the list: with catkin_add_gtest when `catkin` is given,
# else as plain executables and ctest tests (GTest found by the caller).
function(tlp_add_ros_free_tests mode)
  foreach(spec ${TLP_ROS_FREE_TESTS})
    string(REPLACE ":" ";" parts "${spec}")
    list(GET parts 0 name)
    list(GET parts 1 libs)
    list(GET parts 2 srcs)
    string(REPLACE "," ";" libs "${libs}")
    string(REPLACE "," ";" srcs "${srcs}")
    list(TRANSFORM srcs PREPEND "${TLP_ROOT}/test/")
    if(mode STREQUAL "catkin")
      catkin_add_gtest(${name} ${srcs})
      target_link_libraries(${name} ${libs} gtest_main)
    else()
      add_executable(${name} ${srcs})
      target_link_libraries(${name} ${libs} GTest::gtest_main)
      add_test(NAME ${name} COMMAND ${name})
    endif()
    target_compile_definitions(${name} PRIVATE TLP_SOURCE_DIR="${TLP_ROOT}")
  endforeach()
endfunction()
