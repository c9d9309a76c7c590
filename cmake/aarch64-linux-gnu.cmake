# Cross-compiling for the RK3588 (aarch64 Linux, Debian): the whole project
# with Debian's g++-aarch64-linux-gnu against arm64 multiarch packages
# (scripts/setup.sh aarch64 installs both). Tests and the programs the tests
# start run under qemu-aarch64: CMAKE_CROSSCOMPILING_EMULATOR for what CMake
# runs itself, binfmt_misc for the rest (scripts/setup.sh aarch64 registers it).
# Usage: cmake --preset aarch64 (or -DCMAKE_TOOLCHAIN_FILE=cmake/aarch64-linux-gnu.cmake)
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# Debian multiarch: arm64 libraries and their CMake/pkg-config files live in
# /usr/lib/aarch64-linux-gnu, headers in /usr/include (shared by every arch).
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(CMAKE_IGNORE_PATH /usr/lib/x86_64-linux-gnu /usr/lib/x86_64-linux-gnu/cmake /lib/x86_64-linux-gnu)
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
# No -L sysroot: it remaps absolute paths (ptys, /tmp) and hangs the pty tests;
# the arm64 dynamic loader and libraries are where multiarch puts them.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64)
# The .deb packages name their architecture from this, not from the build machine.
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
