#!/usr/bin/env bash
# Runs the ROS demo (launch/demo.launch) for a bounded time: a simulator of N agents wandering
# a room (several on collision courses), vadop_monitor, and the predicted impacts printed as
# readable lines; rviz (rviz/vadop.rviz) as well when $DISPLAY is set, headless otherwise.
#
#   bash scripts/ros_demo.sh [SECONDS] [roslaunch args...]     e.g. bash scripts/ros_demo.sh 60 agents:=40
#
# SECONDS (default 30) bounds the demo: the simulator stops after it and ends the launch; a
# timeout stops everything 30 s later in any case. Builds the catkin package first (plain
# CMake, into $VADOP_ROS_BUILD, default build/, the same configuration as .ci/run; set
# VADOP_SKIP_BUILD=1 to skip). Needs the Debian packages of scripts/install_deps.sh.
# Starts its own ROS master on port $VADOP_ROS_PORT (default 11411), so that it does not
# disturb a roscore already running on 11311.
set -euo pipefail
# Debian's python (catkin_pkg, rospy) must win over a pyenv python3.
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:${PATH}
cd "$(dirname "${BASH_SOURCE[0]}")/.."

SECONDS_TO_RUN=${1:-30}
if (($# > 0)); then shift; fi
if ! [[ ${SECONDS_TO_RUN} =~ ^[0-9]+$ ]] || ((SECONDS_TO_RUN < 1)); then
  echo "usage: $0 [SECONDS] [roslaunch args...]" >&2
  exit 2
fi
BUILD=${VADOP_ROS_BUILD:-build}
PORT=${VADOP_ROS_PORT:-11411}

if [[ ${VADOP_SKIP_BUILD:-0} != 1 ]]; then
  cmake -S . -B "${BUILD}" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
  cmake --build "${BUILD}" -j "${VADOP_JOBS:-2}"
fi

set +u
# shellcheck disable=SC1091
source "${BUILD}/devel/setup.bash"
set -u
export ROS_PACKAGE_PATH=${ROS_PACKAGE_PATH}:/usr/share # rviz needs media_export etc.
export ROS_MASTER_URI=http://localhost:${PORT}

RVIZ=false
if [[ -n ${DISPLAY:-} ]]; then RVIZ=true; fi
# By path: after .ci/run, build/ also holds an install space with its own copy of the package,
# and `roslaunch vadop demo.launch` would find two.
echo "ros_demo: ${SECONDS_TO_RUN} s, rviz=${RVIZ}, master on port ${PORT}"
rc=0
timeout --signal=INT --kill-after=15 $((SECONDS_TO_RUN + 30)) \
  roslaunch -p "${PORT}" "${PWD}/launch/demo.launch" duration:="${SECONDS_TO_RUN}" rviz:="${RVIZ}" "$@" || rc=$?
# roslaunch exits 0 when the simulator (required) stops after SECONDS; 124 = the timeout hit.
if ((rc != 0)); then echo "ros_demo: roslaunch exited with status ${rc}" >&2; fi
exit "${rc}"
