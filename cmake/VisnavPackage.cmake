# `make install` / `cmake --install`: the runtime library, SDK headers, the CLI, plugins and
# a CMake package so that out-of-tree plugins do `find_package(visnav)` and link visnav::sdk.
#
# Everything except the plugins is in the install component `sdk`, so
#   cmake --install <build> --component sdk --prefix <dir>
# installs just what an out-of-tree plugin needs to build and run (the CLI included); a plain
# `cmake --install <build>` installs the plugins as well.
include(CMakePackageConfigHelpers)

install(TARGETS visnav_runtime EXPORT visnavTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT sdk
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT sdk
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS visnav RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT sdk)
install(DIRECTORY runtime/include/visnav DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT sdk)
# The (possibly empty) installed plugin directory, so VISNAV_PLUGIN_INSTALL_DIR always exists.
install(DIRECTORY DESTINATION ${VISNAV_INSTALL_PLUGIN_DIR} COMPONENT sdk)
install(EXPORT visnavTargets NAMESPACE visnav:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visnav COMPONENT sdk)

configure_package_config_file(cmake/visnavConfig.cmake.in
  "${CMAKE_CURRENT_BINARY_DIR}/visnavConfig.cmake"
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visnav
  PATH_VARS VISNAV_INSTALL_PLUGIN_DIR)
write_basic_package_version_file("${CMAKE_CURRENT_BINARY_DIR}/visnavConfigVersion.cmake"
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES "${CMAKE_CURRENT_BINARY_DIR}/visnavConfig.cmake" "${CMAKE_CURRENT_BINARY_DIR}/visnavConfigVersion.cmake"
        cmake/VisnavHelpers.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visnav COMPONENT sdk)
