# Shared build settings, applied per target (no global flags).

# visnav_target_settings(<target>): C++20, warnings, optional -Werror and sanitizers.
function(visnav_target_settings target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wno-deprecated-enum-enum-conversion)
  if(VISNAV_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(VISNAV_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
endfunction()

# visnav_add_subdirectories(): add_subdirectory() for every immediate child folder that has
# a CMakeLists.txt, so new plugins and test folders drop in without editing a shared list.
function(visnav_add_subdirectories)
  file(GLOB children LIST_DIRECTORIES true RELATIVE "${CMAKE_CURRENT_SOURCE_DIR}" "${CMAKE_CURRENT_SOURCE_DIR}/*")
  list(SORT children)
  foreach(child IN LISTS children)
    if(IS_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}/${child}" AND EXISTS "${CMAKE_CURRENT_SOURCE_DIR}/${child}/CMakeLists.txt")
      add_subdirectory(${child})
    endif()
  endforeach()
endfunction()

# visnav_add_plugin(<name> SOURCES ... [LIBS ...]): a MODULE library written to the plugin
# directory of the build tree and installed to the plugin directory.
function(visnav_add_plugin name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_library(${name} MODULE ${ARG_SOURCES})
  visnav_target_settings(${name})
  target_link_libraries(${name} PRIVATE visnav::sdk ${ARG_LIBS})
  set_target_properties(${name} PROPERTIES
    PREFIX "libvisnav_"
    LIBRARY_OUTPUT_DIRECTORY "${VISNAV_BUILD_PLUGIN_DIR}"
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON
    INSTALL_RPATH "$ORIGIN/../..")
  install(TARGETS ${name} LIBRARY DESTINATION "${VISNAV_INSTALL_PLUGIN_DIR}")
endfunction()

# visnav_add_test(<name> SOURCES ... [LIBS ...] [LABELS ...] [TIMEOUT s] [LSAN_OPTIONS opts]):
# a GoogleTest binary whose cases are registered with CTest one by one. With VISNAV_SANITIZE the
# cases run with LSAN_OPTIONS naming cmake/sanitizers/lsan.supp (third-party leaks only) plus
# the test's own `LSAN_OPTIONS` (colon-separated, e.g. fast_unwind_on_malloc=0).
function(visnav_add_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT;LSAN_OPTIONS" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  visnav_target_settings(${name})
  target_link_libraries(${name} PRIVATE visnav::runtime GTest::gtest GTest::gtest_main ${ARG_LIBS})
  # tests/support: shared scaffolding (fake devices, error expectations).
  target_include_directories(${name} PRIVATE "${PROJECT_SOURCE_DIR}/tests/support")
  target_compile_definitions(${name} PRIVATE
    VISNAV_TEST_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    VISNAV_TEST_BINARY_DIR="${PROJECT_BINARY_DIR}"
    VISNAV_TEST_PLUGIN_DIR="${VISNAV_BUILD_PLUGIN_DIR}"
    VISNAV_TEST_FIXTURE_PLUGIN_DIR="${VISNAV_BUILD_PLUGIN_DIR}/fixtures"
    VISNAV_TEST_CLI="$<TARGET_FILE:visnav>")
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  if(VISNAV_SANITIZE)
    # Sanitized code runs several times slower (a `visnav validate` 6x the CPU of the Release
    # build), so the time limits, meant to catch hangs, scale with it.
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 4")
  endif()
  include(GoogleTest)
  # gtest_discover_tests flattens list-valued properties (CMake 3.25 splits "a;b" into separate
  # set_tests_properties arguments), so several labels are joined into one: "closed_loop-dds".
  # `ctest -L` takes a regular expression, so `-L dds` and `-L closed_loop` both still select it.
  string(REPLACE ";" "-" label_joined "${ARG_LABELS}")
  # An empty value would be dropped by the same flattening, shifting the next key into its
  # place, so optional properties are only appended when set.
  set(properties TIMEOUT ${ARG_TIMEOUT})
  if(label_joined)
    list(APPEND properties LABELS "${label_joined}")
  endif()
  if(VISNAV_SANITIZE)
    set(lsan "suppressions=${PROJECT_SOURCE_DIR}/cmake/sanitizers/lsan.supp:print_suppressions=0")
    if(ARG_LSAN_OPTIONS)
      string(APPEND lsan ":${ARG_LSAN_OPTIONS}")
    endif()
    list(APPEND properties ENVIRONMENT "LSAN_OPTIONS=${lsan}")
  endif()
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES ${properties})
endfunction()

# visnav_add_benchmark(<name> SOURCES ... [LIBS ...])
function(visnav_add_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  visnav_target_settings(${name})
  target_link_libraries(${name} PRIVATE visnav::runtime benchmark::benchmark ${ARG_LIBS})
  target_compile_definitions(${name} PRIVATE
    VISNAV_TEST_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    VISNAV_TEST_PLUGIN_DIR="${VISNAV_BUILD_PLUGIN_DIR}")
endfunction()
