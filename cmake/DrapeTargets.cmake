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

# drape_test(NAME SOURCES ... DEPS ... [LABELS ...] [TIMEOUT s]): a GoogleTest executable
# registered with CTest.
# Tests run from the build tree; DRAPE_SOURCE_DIR points at the repository for fixtures.
function(drape_test name)
  if(NOT DRAPE_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  drape_warnings(${name})
  target_compile_definitions(${name} PRIVATE DRAPE_SOURCE_DIR="${DRAPE_SOURCE_ROOT}")
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 600)
  endif()
  # LABELS: "slow" for suites of whole builds/simulations (the sanitizer run skips them).
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "unit;${ARG_LABELS}")
endfunction()

# drape_bench(NAME SOURCES ... DEPS ...): a Google Benchmark program (not a test).
function(drape_bench name)
  if(NOT DRAPE_BUILD_BENCH)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark)
  drape_warnings(${name})
  target_compile_definitions(${name} PRIVATE DRAPE_SOURCE_DIR="${DRAPE_SOURCE_ROOT}")
endfunction()
