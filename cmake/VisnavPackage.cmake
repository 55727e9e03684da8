# `make install` / `cmake --install`: the runtime library, SDK headers, the CLI, plugins and
# a CMake package so that out-of-tree plugins do `find_package(visnav)` and link visnav::sdk.
include(CMakePackageConfigHelpers)

install(TARGETS visnav_runtime EXPORT visnavTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS visnav RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY runtime/include/visnav DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT visnavTargets NAMESPACE visnav:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visnav)

configure_package_config_file(cmake/visnavConfig.cmake.in
  "${CMAKE_CURRENT_BINARY_DIR}/visnavConfig.cmake"
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visnav
  PATH_VARS VISNAV_INSTALL_PLUGIN_DIR)
write_basic_package_version_file("${CMAKE_CURRENT_BINARY_DIR}/visnavConfigVersion.cmake"
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES "${CMAKE_CURRENT_BINARY_DIR}/visnavConfig.cmake" "${CMAKE_CURRENT_BINARY_DIR}/visnavConfigVersion.cmake"
        cmake/VisnavHelpers.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/visnav)
