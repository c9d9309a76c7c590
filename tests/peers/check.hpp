// CHECK for the libmodbus peers: on failure, one line on stderr naming the
// peer (`kPeer`, defined by the including file), what failed and libmodbus'
// reason, and `return 1` from main.
#pragma once

#include <modbus/modbus.h>

#include <cerrno>
#include <cstdio>

#define CHECK(cond, ...)                                       \
  do {                                                         \
    if (!(cond)) {                                             \
      std::fprintf(stderr, "%s: ", kPeer);                     \
      std::fprintf(stderr, __VA_ARGS__);                       \
      std::fprintf(stderr, " (%s)\n", modbus_strerror(errno)); \
      return 1;                                                \
    }                                                          \
  } while (0)
