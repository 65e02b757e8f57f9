# `cmake --install` makes a CMake package: find_package(pnsplat) then gives pnsplat::refine and
# pnsplat::engine (static libraries with their public headers; the shaders are compiled in), and
# the `pnsplat` program goes to bin/. Versions 0.y are compatible only within one y.
include(CMakePackageConfigHelpers)
set(pnsplat_package_dir ${CMAKE_INSTALL_LIBDIR}/cmake/pnsplat)
install(EXPORT pnsplatTargets NAMESPACE pnsplat:: DESTINATION ${pnsplat_package_dir})
configure_package_config_file(cmake/pnsplatConfig.cmake.in ${PROJECT_BINARY_DIR}/pnsplatConfig.cmake
  INSTALL_DESTINATION ${pnsplat_package_dir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/pnsplatConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/pnsplatConfig.cmake ${PROJECT_BINARY_DIR}/pnsplatConfigVersion.cmake
  DESTINATION ${pnsplat_package_dir})
