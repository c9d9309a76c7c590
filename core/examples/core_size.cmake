# cmake -DMAP=firmware.map -DOUT=core_size.txt -P core_size.cmake
#
# Sums, from a GNU ld map, the flash the core takes in a linked firmware:
# the sizes of the input sections the link kept (.text*, .rodata*, .data*,
# .ARM.exidx/extab; .data counts once, for its flash copy) that come from
# librtukit_core.a, or from another object but hold a function of namespace
# rtukit (the inline code of the core's headers, e.g. RegisterBank's defaults).
# Writes the sum to OUT and prints it, with what the firmware took from the C
# library's mem* functions (memcpy, memmove, memset, memcmp: the core calls
# them, startup code may too) beside it.
file(STRINGS "${MAP}" lines)
set(in_map FALSE)
set(pending "")
set(core 0)
set(libc_mem 0)
foreach(line IN LISTS lines)
  if(line MATCHES "^Linker script and memory map")
    set(in_map TRUE)
    continue()
  endif()
  if(NOT in_map)
    continue()  # the discarded input sections come first: not in the image
  endif()
  if(line MATCHES "^ (\\.[^ ]+)$")
    set(pending "${CMAKE_MATCH_1}")  # a long section name: address, size, file on the next line
    continue()
  endif()
  if(line MATCHES "^ (\\.[^ ]+)? +0x[0-9a-f]+ +0x([0-9a-f]+) (.+)$")
    set(section "${CMAKE_MATCH_1}")
    set(size "${CMAKE_MATCH_2}")
    set(file "${CMAKE_MATCH_3}")
    if(section STREQUAL "")
      set(section "${pending}")
    endif()
    set(pending "")
    if(NOT section MATCHES "^\\.(text|rodata|data|ARM\\.exidx|ARM\\.extab)")
      continue()
    endif()
    math(EXPR bytes "0x${size}")
    if(file MATCHES "librtukit_core\\.a\\(" OR section MATCHES "^\\.[a-z.]+\\._ZN?K?6rtukit")
      math(EXPR core "${core} + ${bytes}")
    elseif(file MATCHES "libc(_nano)?\\.a\\(lib_a-mem(cpy|move|set|cmp)\\.o\\)")
      math(EXPR libc_mem "${libc_mem} + ${bytes}")
    endif()
  else()
    set(pending "")
  endif()
endforeach()
file(WRITE "${OUT}" "${core}\n")
get_filename_component(name "${MAP}" NAME_WE)
message(STATUS "${name}: the core takes ${core} B of flash (its text, rodata and data the link kept); "
               "the C library's mem* functions beside it: ${libc_mem} B")
