# Precompiled headers: the third-party headers that most of rrslam's
# translation units include are parsed once per build tree instead of once per
# file. Measured alone on the project's 2-core machine (g++ 12, -O3): CLI11
# 6.3 s, nlohmann/json 2.1 s, Eigen 1.6 s, gtest 1.6 s, OpenCV core 1.4 s,
# spdlog 1.2 s per translation unit; bench/results/build-<date>.txt has the
# whole build's figures with and without.
#
# Two headers are built: rrslam_pch for the libraries, tools and benchmarks,
# rrslam_test_pch (the same plus GoogleTest) for the tests, which GoogleTest's
# GTEST_HAS_PTHREAD definition sets apart (g++ refuses a precompiled header
# whose headers see other macro values). Every other C++ target of the tree
# reuses one of them (rrslam_use_pch, called once at the end of the top
# CMakeLists.txt). Ceres, glog and OpenImageIO stay out: their definitions
# (GLOG_*) are only on the targets that link them.
#
# g++ only checks that a precompiled header is valid for the file (-Winvalid-pch
# warns when it is not, and the file is compiled without it): the result is the
# same program either way. -DRRSLAM_PCH=OFF builds without them.
option(RRSLAM_PCH "Precompile the heaviest third-party headers once per build tree" ON)

set(rrslam_pch_headers
  <spdlog/spdlog.h> <Eigen/Core> <Eigen/Geometry> <opencv2/core.hpp> <algorithm> <filesystem>
  <functional> <map> <memory> <optional> <string> <unordered_map> <vector>)

# The two anchors: object libraries that only build the headers.
function(rrslam_add_pch_targets)
  if(NOT RRSLAM_PCH)
    return()
  endif()
  set(anchor ${CMAKE_BINARY_DIR}/generated/pch_anchor.cc)
  file(GENERATE OUTPUT ${anchor} CONTENT "// Anchors the precompiled headers (cmake/RrslamPch.cmake).\n")
  add_library(rrslam_pch OBJECT ${anchor})
  # The interface of rrslam_common's dependencies (imported targets: no build
  # order), so the header sees the definitions every target sees.
  target_link_libraries(rrslam_pch PRIVATE Eigen3::Eigen opencv_core CLI11::CLI11 spdlog::spdlog
                        nlohmann_json::nlohmann_json)
  target_compile_definitions(rrslam_pch PRIVATE ${HDF5_DEFINITIONS})
  target_precompile_headers(rrslam_pch PRIVATE ${rrslam_pch_headers})

  add_library(rrslam_test_pch OBJECT ${anchor})
  target_link_libraries(rrslam_test_pch PRIVATE Eigen3::Eigen opencv_core CLI11::CLI11
                        spdlog::spdlog nlohmann_json::nlohmann_json GTest::gtest)
  target_compile_definitions(rrslam_test_pch PRIVATE ${HDF5_DEFINITIONS})
  target_precompile_headers(rrslam_test_pch PRIVATE ${rrslam_pch_headers} <gtest/gtest.h>)
endfunction()

# Every C++ library and executable below `dir` reuses one of the headers:
# the tests' (those linking rrslam_testing, and rrslam_testing) or the others'.
function(rrslam_use_pch dir)
  if(NOT RRSLAM_PCH)
    return()
  endif()
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  foreach(target ${targets})
    get_target_property(type ${target} TYPE)
    if(NOT type MATCHES "^(STATIC_LIBRARY|SHARED_LIBRARY|EXECUTABLE)$")
      continue()
    endif()
    get_target_property(libs ${target} LINK_LIBRARIES)
    if(target STREQUAL "rrslam_testing" OR "rrslam_testing" IN_LIST libs)
      target_precompile_headers(${target} REUSE_FROM rrslam_test_pch)
    else()
      target_precompile_headers(${target} REUSE_FROM rrslam_pch)
    endif()
  endforeach()
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(subdir ${subdirs})
    rrslam_use_pch(${subdir})
  endforeach()
endfunction()
