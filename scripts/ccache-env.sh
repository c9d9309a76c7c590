# Sourced by scripts/build.sh and .ci/run: compile through ccache when it is
# installed. CMake takes the launcher from the environment at configure time;
# CCACHE_BASEDIR makes paths under the source folder relative in the cache's
# key, and CCACHE_NOHASHDIR leaves the working folder out of it, so a clone in
# another folder hits what this one compiled. Without ccache nothing changes.
if command -v ccache >/dev/null 2>&1; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache
  export CCACHE_BASEDIR="$(pwd)"
  export CCACHE_NOHASHDIR=1
  export CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-8G}"
fi
