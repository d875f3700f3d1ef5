#!/usr/bin/env bash
# The project's main demo: installs the Debian packages, builds the catkin package (build/, the
# configuration .ci/run uses) and runs the ROS demo for a bounded time (default 30 s): simulated
# agents wandering a room, vadop_monitor predicting their impacts, printed as readable lines, and
# rviz when a display exists. Arguments go to scripts/ros_demo.sh: [SECONDS] [roslaunch args...],
# e.g. `bash scripts/demo.sh 60 agents:=40`.
# The broad-phase demo of vadop_core alone is build/core/vadop_broadphase_demo (see docs/design.md).
set -euo pipefail
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:${PATH}
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/install_deps.sh
exec bash scripts/ros_demo.sh "$@"
