# Sourced (from the repository's root) by setup.sh and fuzz/sanitize_env.sh.
# ccache_launcher: sets the array DRAPE_LAUNCHER to the CMake flags that compile through
# ccache when the machine has it (empty without). base_dir (this checkout) turns the paths
# on every compile line into relative ones and hash_dir off leaves the build folder's path
# out, so the commands are the same in every clone and a second clone's build finds the
# first's objects, also on a machine whose ccache.conf sets neither. A function, not run
# on sourcing: setup.sh installs ccache after it sources this.
ccache_launcher() {
  DRAPE_LAUNCHER=()
  if command -v ccache >/dev/null; then
    local l="env;CCACHE_BASEDIR=$(pwd);CCACHE_NOHASHDIR=1;ccache"
    DRAPE_LAUNCHER=("-DCMAKE_CXX_COMPILER_LAUNCHER=$l" "-DCMAKE_C_COMPILER_LAUNCHER=$l")
  fi
}
