# What `cmake --install` installs (docs/api.md): the hapvox command (tools/CMakeLists.txt),
# the bundled data, the libraries with their public headers and a CMake package
# (find_package(hapvox): hapvox::engine, hapvox::render, hapvox::haptics and their _static
# twins), the docs; and the Debian package cpack makes of it all.

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(HAPVOX_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/hapvox)
install(TARGETS ${HAPVOX_INSTALLED_LIBRARIES} EXPORT hapvoxTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
# `cmake --install --strip`, and always the .deb (CPACK_STRIP_FILES, as Debian's packages
# are), installs without the RelWithDebInfo build's debug info, which made the package
# 545 MB. CMake strips executables and shared libraries only (stripping an archive's
# symbols would break it): the static archives lose their debug sections alone.
foreach(target ${HAPVOX_INSTALLED_LIBRARIES})
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "STATIC_LIBRARY")
    install(CODE "if(CMAKE_INSTALL_DO_STRIP)
  execute_process(COMMAND \"${CMAKE_STRIP}\" --strip-debug
    \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR}/$<TARGET_FILE_NAME:${target}>\"
    COMMAND_ERROR_IS_FATAL ANY)
endif()")
  endif()
endforeach()
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/hapvox DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h")
install(FILES ${PROJECT_BINARY_DIR}/include/hapvox/version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/hapvox)
install(EXPORT hapvoxTargets NAMESPACE hapvox:: DESTINATION ${HAPVOX_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/hapvoxConfig.cmake.in
  ${PROJECT_BINARY_DIR}/hapvoxConfig.cmake INSTALL_DESTINATION ${HAPVOX_CMAKE_DIR})
# 0.x: a minor release may break the API (include/hapvox/version.h), so only the same
# minor version is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/hapvoxConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/hapvoxConfig.cmake
        ${PROJECT_BINARY_DIR}/hapvoxConfigVersion.cmake DESTINATION ${HAPVOX_CMAKE_DIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/LICENSE
        ${PROJECT_SOURCE_DIR}/NOTICE DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/examples/embed DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples)

# The Debian package (cpack -G DEB in the build folder): everything above under /usr, its
# dependencies on Debian's shared libraries worked out by dpkg-shlibdeps, plus what the
# Python module needs at run time (the Python it was built for, numpy).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME hapvox)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "hapvox developers <hapvox@example.org>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "haptic forces on 3D images at 1 kHz: the hapvox command, C++ libraries, Python module")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# Our own libraries link each other: dpkg-shlibdeps finds them in the package.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ${PROJECT_BINARY_DIR}/lib)
if(TARGET hapvox_python)
  math(EXPR next_minor "${Python3_VERSION_MINOR} + 1")
  set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3 (>= ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR}), \
python3 (<< ${Python3_VERSION_MAJOR}.${next_minor}), python3-numpy")
endif()
include(CPack)
