# Source this file (bash/sh) to use the workspace: venv, colcon install space, DDS on this host.
#   . scripts/env.sh
_pd_repo="$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")/.." && pwd)"
export HOME="${HOME:-$_pd_repo}"
# DDS discovery stays on this host unless the user asks for more (multi-host tests).
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
export VIRTUAL_ENV="$_pd_repo/.venv"
export PATH="$VIRTUAL_ENV/bin:$PATH"
export AMENT_PREFIX_PATH="$VIRTUAL_ENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
# colcon's setup script reads unset variables: relax `set -u` while sourcing it.
case $- in *u*) _pd_nounset=1; set +u ;; *) _pd_nounset= ;; esac
# shellcheck disable=SC1091
. "$_pd_repo/ros2_ws/install/setup.sh"
[ -n "$_pd_nounset" ] && set -u
unset _pd_nounset
export PD_REPO="$_pd_repo"
unset _pd_repo
