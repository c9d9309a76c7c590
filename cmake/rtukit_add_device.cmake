# The device registry: one rtukit_add_device() line per device.
#
#   rtukit_add_device(TARGET rtukit::inverjet
#                     HEADER rtukit/devices/inverjet/device.hpp
#                     ENTRY  rtukit::inverjet::device_entry)
#
# TARGET is the device's library, HEADER declares ENTRY, a function
# `const rtukit::profile::DeviceEntry& ENTRY()`. The registry library
# (devices/registry, added after every device and example) links each
# TARGET and lists each ENTRY in the order the lines ran; the CLI, the
# simulator, the sniffer and the docs generator read that list.
function(rtukit_add_device)
  cmake_parse_arguments(DEV "" "TARGET;HEADER;ENTRY" "" ${ARGN})
  if(NOT DEV_TARGET OR NOT DEV_HEADER OR NOT DEV_ENTRY)
    message(FATAL_ERROR "rtukit_add_device: TARGET, HEADER and ENTRY are required")
  endif()
  set_property(GLOBAL APPEND PROPERTY RTUKIT_DEVICE_TARGETS ${DEV_TARGET})
  set_property(GLOBAL APPEND PROPERTY RTUKIT_DEVICE_HEADERS ${DEV_HEADER})
  set_property(GLOBAL APPEND PROPERTY RTUKIT_DEVICE_ENTRIES ${DEV_ENTRY})
endfunction()
