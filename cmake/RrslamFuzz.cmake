# libFuzzer targets (clang only), shared by the stages that fuzz a reader.
#
# Targets are built with clang++ -fsanitize=fuzzer,address,undefined into
# ${CMAKE_BINARY_DIR}/fuzz/ when a clang with libFuzzer is found
# (scripts/install-deps.sh installs it); otherwise the custom target only
# says so, and the stage's CTest fuzz test reports itself skipped (exit 77).
# `make fuzz` (pipelines/fuzz.mk) builds every <stage>_fuzzers target.

set(RRSLAM_FUZZ_SECONDS 4 CACHE STRING "Seconds each fuzz target runs in the test suite")
set(RRSLAM_FUZZ_DIR ${CMAKE_BINARY_DIR}/fuzz)
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

# rrslam_add_fuzzers(<target> SOURCES <library sources...> FUZZERS <fuzzer sources...>)
# Compiles every source (paths relative to the source root) with the fuzzer
# flags into fuzz/<target>_obj/, and links each fuzzer source with all the
# library sources into fuzz/<fuzzer name>. Custom target <target>.
function(rrslam_add_fuzzers target)
  cmake_parse_arguments(ARG "" "" "SOURCES;FUZZERS" ${ARGN})
  if(NOT RRSLAM_LIBFUZZER_OK)
    message(STATUS "clang++ with libFuzzer not found: ${target} are not built")
    add_custom_target(${target} COMMAND ${CMAKE_COMMAND} -E echo
      "${target}: clang++ with libFuzzer not found, nothing to build")
    return()
  endif()
  set(flags -std=c++20 -g -O1 -mpopcnt -fsanitize=fuzzer-no-link,address,undefined
      -fno-sanitize-recover=undefined -I${CMAKE_SOURCE_DIR})
  set(obj_dir ${RRSLAM_FUZZ_DIR}/${target}_obj)
  set(library_objects "")
  set(outputs "")
  foreach(source ${ARG_SOURCES} ${ARG_FUZZERS})
    get_filename_component(base ${source} NAME_WE)
    set(object ${obj_dir}/${base}.o)
    add_custom_command(OUTPUT ${object}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${obj_dir}
      COMMAND ${RRSLAM_CLANGXX} ${flags} -MD -MF ${object}.d -c ${CMAKE_SOURCE_DIR}/${source}
              -o ${object}
      DEPENDS ${CMAKE_SOURCE_DIR}/${source}
      DEPFILE ${object}.d
      COMMENT "clang++ (libFuzzer) ${source}"
      VERBATIM)
    if(source IN_LIST ARG_SOURCES)
      list(APPEND library_objects ${object})
    endif()
  endforeach()
  foreach(source ${ARG_FUZZERS})
    get_filename_component(base ${source} NAME_WE)
    add_custom_command(OUTPUT ${RRSLAM_FUZZ_DIR}/${base}
      COMMAND ${RRSLAM_CLANGXX} -fsanitize=fuzzer,address,undefined ${obj_dir}/${base}.o
              ${library_objects} -lxxhash -pthread -o ${RRSLAM_FUZZ_DIR}/${base}
      DEPENDS ${obj_dir}/${base}.o ${library_objects}
      COMMENT "clang++ (libFuzzer) link ${base}"
      VERBATIM)
    list(APPEND outputs ${RRSLAM_FUZZ_DIR}/${base})
  endforeach()
  add_custom_target(${target} ALL DEPENDS ${outputs})
endfunction()
