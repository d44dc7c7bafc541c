# Sourced by the scripts: one place for paths and the environment the ROS tools need.
CCIR_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
CCIR_WS="${CCIR_WS:-$CCIR_ROOT/.ws}"
CCIR_LOG_DIR="${CCIR_LOG_DIR:-$CCIR_WS/logs}"
CCIR_BUILD_TYPE="${CCIR_BUILD_TYPE:-Release}"
CCIR_JOBS="${CCIR_JOBS:-$(nproc)}"
export CCIR_DATA_DIR="${CCIR_DATA_DIR:-$(cd "$CCIR_ROOT/.." && pwd)/shared/data}"
export CCACHE_DIR="${CCACHE_DIR:-$HOME/.cache/ccir_mapping_ccache}"
# The python3 first on PATH may be a pyenv interpreter without the ROS modules; Debian's has them.
export PATH="/usr/bin:$PATH"
export ROS_HOME="${ROS_HOME:-$CCIR_WS/ros_home}"
mkdir -p "$CCIR_LOG_DIR"

# Puts the built workspace on the ROS package path (after scripts/setup has run).
ccir_source_workspace() {
  set +u
  # shellcheck disable=SC1091
  source "$CCIR_WS/devel/setup.bash"
  set -u
}
