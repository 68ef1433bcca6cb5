# Helpers that give every drape target the same include root and warnings.

set(DRAPE_SOURCE_ROOT ${CMAKE_CURRENT_LIST_DIR}/..)

# drape_warnings(TARGET): -Wall -Wextra on drape's own code, errors unless DRAPE_WERROR
# is OFF (the option in CMakeLists.txt). Third-party headers come in through imported
# targets, i.e. as -isystem, so their warnings are not reported.
function(drape_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra $<$<BOOL:${DRAPE_WERROR}>:-Werror>)
endfunction()

# drape_library(NAME SOURCES ... DEPS ...): a stage library; headers are included
# from the repository root, e.g. #include "garments/garment.h".
function(drape_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${DRAPE_SOURCE_ROOT})
  drape_warnings(${name})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
endfunction()

# drape_source_dir: drape::SourceDir() (common/source_dir.h), the repository's path for
# the fixtures of tests and benchmarks. The path is compiled into this one object only:
# a -DDRAPE_SOURCE_DIR on every test would make each clone's compile commands differ:
# ccache's direct mode would miss on all of them (preprocessing again on each).
function(drape_source_dir_library)
  if(TARGET drape_source_dir)
    return()
  endif()
  add_library(drape_source_dir STATIC ${DRAPE_SOURCE_ROOT}/common/source_dir.cpp)
  target_include_directories(drape_source_dir PUBLIC ${DRAPE_SOURCE_ROOT})
  drape_warnings(drape_source_dir)
  get_filename_component(root ${DRAPE_SOURCE_ROOT} REALPATH)
  target_compile_definitions(drape_source_dir PRIVATE DRAPE_SOURCE_DIR="${root}")
endfunction()

# drape_test(NAME SOURCES ... DEPS ... [LABELS ...] [TIMEOUT s]): a GoogleTest executable
# registered with CTest. Tests run from the build tree; fixtures are found through
# drape::SourceDir().
function(drape_test name)
  if(NOT DRAPE_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  drape_source_dir_library()
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} drape_source_dir GTest::gtest GTest::gtest_main)
  drape_warnings(${name})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 600)
  endif()
  # LABELS: "slow" for suites of whole builds/simulations (the sanitizer run skips them).
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS unit)
  if(ARG_LABELS)
    # gtest_discover_tests flattens a list-valued property ("unit;slow" became the pair
    # LABELS unit plus a stray "slow"): a CTest include file, read after the discovered
    # tests' own, sets the whole list on ${name}_TESTS.
    set(labels_file ${CMAKE_CURRENT_BINARY_DIR}/${name}_labels.cmake)
    file(WRITE ${labels_file} "set_tests_properties(\${${name}_TESTS} PROPERTIES LABELS \"unit;${ARG_LABELS}\")\n")
    set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${labels_file})
  endif()
endfunction()

# drape_bench(NAME SOURCES ... DEPS ...): a Google Benchmark program (not a test).
function(drape_bench name)
  if(NOT DRAPE_BUILD_BENCH)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  drape_source_dir_library()
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} drape_source_dir benchmark::benchmark)
  drape_warnings(${name})
endfunction()
