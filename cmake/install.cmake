# Install rules, the exported CMake package (find_package(rtukit CONFIG
# COMPONENTS ...)), rtukit.pc for pkg-config, and the Debian packages (CPack):
#   rtukit          the `rtukit` tool, its man page and shell completion
#   librtukit-dev   headers, static libraries, CMake and pkg-config files
# Kept in one place so the library folders' CMakeLists stay about building.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# Every library a consumer can link, lowest layer first, with its component
# name. `profile` is the pure kit; `*_model` the pure half of a device.
set(_rtukit_libs
  rtukit_core:core
  rtukit_base:base
  rtukit_io:io
  rtukit_term:term
  rtukit_driver:driver
  rtukit_profile:profile
  rtukit_profile_host:profile_host
  rtukit_tool:tool
  rtukit_inverjet_model:inverjet_model
  rtukit_inverjet:inverjet
  rtukit_rehand6600_model:rehand6600_model
  rtukit_rehand6600:rehand6600)

set(_rtukit_components "")
set(_rtukit_pc_libs "")
foreach(entry IN LISTS _rtukit_libs)
  string(REPLACE ":" ";" pair "${entry}")
  list(GET pair 0 target)
  list(GET pair 1 component)
  if(NOT TARGET ${target})
    continue()
  endif()
  # Exported targets carry the installed include folder, not the source tree's.
  get_target_property(_dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
  if(_dirs)
    set(_build_dirs "")
    foreach(d IN LISTS _dirs)
      list(APPEND _build_dirs "$<BUILD_INTERFACE:${d}>")
      install(DIRECTORY "${d}/" DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev)
    endforeach()
    list(APPEND _build_dirs "$<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>")
    set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_build_dirs}")
  endif()
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${component})
  install(TARGETS ${target} EXPORT rtukitTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev)
  list(APPEND _rtukit_components ${component})
  # pkg-config: highest layer first, as a linker wants them (a header-only
  # library has no archive to name).
  get_target_property(_type ${target} TYPE)
  if(NOT _type STREQUAL "INTERFACE_LIBRARY")
    list(PREPEND _rtukit_pc_libs "-l${target}")
  endif()
endforeach()
# The warnings target is only ever linked privately; static libraries still
# name it, so it travels in the export (it carries no usage requirements).
install(TARGETS rtukit_warnings EXPORT rtukitTargets COMPONENT dev)

set(RTUKIT_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/rtukit)
install(EXPORT rtukitTargets NAMESPACE rtukit:: DESTINATION ${RTUKIT_CMAKE_DIR} COMPONENT dev)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/rtukitConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/rtukitConfig.cmake INSTALL_DESTINATION ${RTUKIT_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/rtukitConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/rtukitConfig.cmake ${PROJECT_BINARY_DIR}/rtukitConfigVersion.cmake
        DESTINATION ${RTUKIT_CMAKE_DIR} COMPONENT dev)

string(JOIN " " RTUKIT_PC_LIBS ${_rtukit_pc_libs})
# Relocatable: the prefix is found from where the .pc file is, so an install
# into any prefix (or DESTDIR, or a .deb) is right without reconfiguring.
file(RELATIVE_PATH RTUKIT_PC_TO_PREFIX ${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig ${CMAKE_INSTALL_PREFIX})
configure_file(${PROJECT_SOURCE_DIR}/cmake/rtukit.pc.in ${PROJECT_BINARY_DIR}/rtukit.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/rtukit.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)

if(TARGET rtukit)
  install(TARGETS rtukit RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT tool)
endif()

# ---- Debian packages ----
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME rtukit)
set(CPACK_PACKAGE_VENDOR "rtukit")
set(CPACK_PACKAGE_CONTACT "rtukit developers <rtukit@localhost>")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL tool dev)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_TOOL_PACKAGE_NAME rtukit)
set(CPACK_DEBIAN_TOOL_PACKAGE_SECTION utils)
set(CPACK_DEBIAN_TOOL_PACKAGE_SHLIBDEPS ON)
set(CPACK_COMPONENT_TOOL_DESCRIPTION
    "Modbus-RTU / Modbus TCP command line tool\n rtukit reads and writes registers, scans a bus, serves simulated devices\n (Inverjet, Rehand 6600, any register-map file) on a pty, serial port or TCP.")
set(CPACK_DEBIAN_DEV_PACKAGE_NAME librtukit-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS "libboost-dev (>= 1.74), libfmt-dev, nlohmann-json3-dev, libyaml-cpp-dev")
set(CPACK_COMPONENT_DEV_DESCRIPTION
    "Modbus-RTU toolkit: headers and static libraries\n The sans-IO Modbus core, Linux transports, master and slave drivers and the\n device profiles of rtukit, with CMake (find_package(rtukit)) and pkg-config files.")
include(CPack)
