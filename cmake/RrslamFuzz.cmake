# libFuzzer targets (clang only), shared by the stages that fuzz a reader.
#
# Targets are built with clang++ -fsanitize=fuzzer,address,undefined into
# ${CMAKE_BINARY_DIR}/fuzz/ when a clang with libFuzzer is found
# (scripts/install-deps.sh installs it); otherwise the custom target only
# says so, and the stage's CTest fuzz tests report themselves skipped (exit
# 77). `make fuzz` (pipelines/fuzz.mk) builds them all (custom target
# `fuzzers`); cmake/run_fuzzer.sh runs one (CTest and `make fuzz-run`).

set(RRSLAM_FUZZ_SECONDS 4 CACHE STRING "Seconds each fuzz target runs in the test suite")
set(RRSLAM_FUZZ_DIR ${CMAKE_BINARY_DIR}/fuzz)
# fuzz/targets.txt lists every target with its seed corpus ("name seed_dir"
# per line, written by rrslam_add_fuzz_test) for bench/fuzz/run.sh (`make
# fuzz-run`); the custom target `fuzzers` builds them all (`make fuzz`).
set(RRSLAM_FUZZ_TARGETS ${RRSLAM_FUZZ_DIR}/targets.txt)
file(WRITE ${RRSLAM_FUZZ_TARGETS} "")
add_custom_target(fuzzers)
find_program(RRSLAM_CLANGXX NAMES clang++ clang++-14)

# Whether clang can link a libFuzzer program (probed once per build tree).
set(RRSLAM_LIBFUZZER_OK FALSE)
if(RRSLAM_CLANGXX)
  set(probe ${CMAKE_BINARY_DIR}/CMakeFiles/libfuzzer_probe.cc)
  file(WRITE ${probe} "#include <cstdint>\n#include <cstddef>\nextern \"C\" int LLVMFuzzerTestOneInput(const uint8_t*, size_t) { return 0; }\n")
  execute_process(COMMAND ${RRSLAM_CLANGXX} -fsanitize=fuzzer,address,undefined ${probe}
                          -o ${CMAKE_BINARY_DIR}/CMakeFiles/libfuzzer_probe
                  RESULT_VARIABLE probe_result OUTPUT_QUIET ERROR_QUIET)
  if(probe_result EQUAL 0)
    set(RRSLAM_LIBFUZZER_OK TRUE)
  endif()
endif()

# rrslam_add_fuzzers(<target> SOURCES <library sources...> FUZZERS <fuzzer sources...>
#                    [INCLUDES <dirs...>] [LIBS <libs...>])
# Compiles every source (paths relative to the source root) with the fuzzer
# flags into fuzz/obj/<flags hash>/<source>.o, and links each fuzzer source
# with all the library sources into fuzz/<fuzzer name>. Custom target
# <target>. A source that several groups compile with the same flags (the
# common/ readers: 7 groups) is compiled once, by the first group that names
# it, and the others depend on that group: the groups' compiles were a third
# of `make test`'s compiler time (bench/results/test-fresh-2026-12-03.txt).
# The libraries rrslam's own code calls (OpenCV, HDF5, libpng, ...) are the
# system's, not instrumented: LIBS names them as CMake targets (their file is
# linked and their include directories added: opencv_core, PNG::PNG, an
# INTERFACE target such as Eigen3::Eigen for its headers only) or as library
# files / -l flags (e.g. ${HDF5_CXX_LIBRARIES}); INCLUDES adds directories
# for those given as files. xxhash and pthread are always linked.
function(rrslam_add_fuzzers target)
  cmake_parse_arguments(ARG "" "" "SOURCES;FUZZERS;INCLUDES;LIBS" ${ARGN})
  if(NOT RRSLAM_LIBFUZZER_OK)
    message(STATUS "clang++ with libFuzzer not found: ${target} are not built")
    add_custom_target(${target} COMMAND ${CMAKE_COMMAND} -E echo
      "${target}: clang++ with libFuzzer not found, nothing to build")
    add_dependencies(fuzzers ${target})
    return()
  endif()
  # Every group compiles with the same include directories (those of Eigen,
  # OpenCV and HDF5 first, then its own), so that groups share objects.
  set(include_dirs ${HDF5_INCLUDE_DIRS})
  foreach(lib Eigen3::Eigen opencv_core)
    get_target_property(dirs ${lib} INTERFACE_INCLUDE_DIRECTORIES)
    list(APPEND include_dirs ${dirs})
  endforeach()
  list(APPEND include_dirs ${ARG_INCLUDES})
  set(link_items "")
  foreach(lib ${ARG_LIBS})
    if(TARGET ${lib})
      get_target_property(dirs ${lib} INTERFACE_INCLUDE_DIRECTORIES)
      if(dirs)
        list(APPEND include_dirs ${dirs})
      endif()
      get_target_property(type ${lib} TYPE)
      if(NOT type STREQUAL "INTERFACE_LIBRARY")
        list(APPEND link_items $<TARGET_FILE:${lib}>)
      endif()
    else()
      list(APPEND link_items ${lib})
    endif()
  endforeach()
  # The compiler's own /usr/include stays last (as -isystem it would come
  # before the C++ library's wrappers that #include_next it).
  list(REMOVE_DUPLICATES include_dirs)
  list(REMOVE_ITEM include_dirs /usr/include)
  set(include_flags -I${CMAKE_SOURCE_DIR} -I${CMAKE_BINARY_DIR}/generated)
  foreach(dir ${include_dirs})
    list(APPEND include_flags -isystem${dir})
  endforeach()
  set(flags -std=c++20 -g -O1 -mpopcnt -fsanitize=fuzzer-no-link,address,undefined
      -fno-sanitize-recover=undefined ${include_flags})
  string(MD5 flags_hash "${flags}")
  string(SUBSTRING ${flags_hash} 0 12 flags_hash)
  set(library_objects "")
  set(outputs "")
  set(owners "")  # Groups that compile objects this one links.
  foreach(source ${ARG_SOURCES} ${ARG_FUZZERS})
    string(REGEX REPLACE "\\.[^.]*$" ".o" object_name ${source})
    set(object ${RRSLAM_FUZZ_DIR}/obj/${flags_hash}/${object_name})
    string(MD5 key ${object})
    get_property(owner GLOBAL PROPERTY RRSLAM_FUZZ_OBJECT_${key})
    if(owner)
      list(APPEND owners ${owner})
    else()
      get_filename_component(obj_dir ${object} DIRECTORY)
      add_custom_command(OUTPUT ${object}
        COMMAND ${CMAKE_COMMAND} -E make_directory ${obj_dir}
        COMMAND ${RRSLAM_CLANGXX} ${flags} -MD -MF ${object}.d -c ${CMAKE_SOURCE_DIR}/${source}
                -o ${object}
        DEPENDS ${CMAKE_SOURCE_DIR}/${source}
        DEPFILE ${object}.d
        COMMENT "clang++ (libFuzzer) ${source}"
        VERBATIM)
      set_property(GLOBAL PROPERTY RRSLAM_FUZZ_OBJECT_${key} ${target})
    endif()
    if(source IN_LIST ARG_SOURCES)
      list(APPEND library_objects ${object})
    endif()
  endforeach()
  foreach(source ${ARG_FUZZERS})
    get_filename_component(base ${source} NAME_WE)
    string(REGEX REPLACE "\\.[^.]*$" ".o" object_name ${source})
    set(fuzzer_object ${RRSLAM_FUZZ_DIR}/obj/${flags_hash}/${object_name})
    add_custom_command(OUTPUT ${RRSLAM_FUZZ_DIR}/${base}
      COMMAND ${RRSLAM_CLANGXX} -fsanitize=fuzzer,address,undefined ${fuzzer_object}
              ${library_objects} ${link_items} -lxxhash -pthread -o ${RRSLAM_FUZZ_DIR}/${base}
      DEPENDS ${fuzzer_object} ${library_objects}
      COMMENT "clang++ (libFuzzer) link ${base}"
      VERBATIM)
    list(APPEND outputs ${RRSLAM_FUZZ_DIR}/${base})
  endforeach()
  add_custom_target(${target} ALL DEPENDS ${outputs})
  add_dependencies(fuzzers ${target})
  list(REMOVE_DUPLICATES owners)
  list(REMOVE_ITEM owners ${target})
  if(owners)
    add_dependencies(${target} ${owners})
  endif()
endfunction()

# rrslam_add_fuzz_test(<module> <fuzzer name> <seed dir>)
# CTest test <module>/fuzz_<name without _fuzzer>: cmake/run_fuzzer.sh runs
# fuzz/<fuzzer name> for RRSLAM_FUZZ_SECONDS with seed 1 from <seed dir> (work
# files in fuzz/work/<fuzzer name>/); skipped (77) when it was not built.
# Also lists the target in fuzz/targets.txt.
function(rrslam_add_fuzz_test module fuzzer seeds)
  file(APPEND ${RRSLAM_FUZZ_TARGETS} "${fuzzer} ${seeds}\n")
  string(REGEX REPLACE "_fuzzer$" "" short ${fuzzer})
  add_test(NAME ${module}/fuzz_${short}
    COMMAND ${CMAKE_SOURCE_DIR}/cmake/run_fuzzer.sh ${RRSLAM_FUZZ_DIR}/${fuzzer} ${seeds}
            ${RRSLAM_FUZZ_DIR}/work/${fuzzer} ${RRSLAM_FUZZ_SECONDS})
  set_tests_properties(${module}/fuzz_${short} PROPERTIES SKIP_RETURN_CODE 77 TIMEOUT 120)
endfunction()
