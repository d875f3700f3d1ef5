#!/usr/bin/env bash
# Runs the vadop demo: installs the Debian packages, builds vadop_core (build/core) and runs
# the broad-phase demo; arguments are passed through to vadop_broadphase_demo.
# (The ROS monitor demo will be started from here too once vadop_ros exists.)
set -euo pipefail
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:${PATH}
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/install_deps.sh
# Same configuration as .ci/run's core stage, so the two share build/core.
cmake -S vadop_core -B build/core -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVADOP_BUILD_TESTS=ON -DVADOP_SANITIZE=OFF
cmake --build build/core -j "${VADOP_JOBS:-2}" --target vadop_broadphase_demo
exec build/core/vadop_broadphase_demo "$@"
