#!/usr/bin/env bash
# Installs every Debian package vadop needs (build, tests, ROS node, demos, benchmarks).
# Idempotent: when all of them are installed already it does not touch apt at all.
# ROS 1 comes from Debian's own packages (under /usr); rosdep is not used.
# Needs root, or sudo (non-interactive when there is no terminal).
set -euo pipefail
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:${PATH}
export DEBIAN_FRONTEND=noninteractive

PACKAGES=(
  # toolchain
  build-essential cmake g++ make pkg-config clang libclang-rt-14-dev ccache
  # ROS 1 (Debian packages)
  ros-core-dev ros-base-dev catkin libroscpp-dev libstd-msgs-dev
  ros-message-generation ros-message-runtime
  ros-nav-msgs ros-geometry-msgs ros-visualization-msgs
  libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev
  liburdfdom-dev liburdf-dev libresource-retriever-dev libdiagnostic-updater-dev
  libkdl-parser-dev liborocos-kdl-dev libsensor-msgs-dev python3-sensor-msgs
  libtrajectory-msgs-dev python3-trajectory-msgs libshape-msgs-dev python3-shape-msgs
  liblaser-geometry-dev
  libnodeletlib-dev libnodeletlib-tools pluginlib-dev
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  librostest-dev python3-rostest python3-rosbag librosbag-dev rosbash
  python3-roslaunch python3-rosmaster
  python3-rospy python3-std-msgs python3-geometry-msgs python3-nav-msgs
  python3-visualization-msgs python3-diagnostic-msgs python3-tf2-ros
  python3-tf2-msgs python3-rosgraph-msgs python3-rosunit
  librviz-dev rviz xvfb imagemagick python3-pil python3-yaml
  # libraries
  libeigen3-dev libfcl-dev libccd-dev libbullet-dev libassimp-dev
  nlohmann-json3-dev libyaml-cpp-dev libcli11-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev googletest libbenchmark-dev catkin-lint
  # plots
  python3-matplotlib python3-numpy
)

declare -A installed=()
while read -r name status; do
  [[ ${status} == ii ]] && installed[${name%%:*}]=1
done < <(dpkg-query -W -f='${Package} ${db:Status-Abbrev}\n' "${PACKAGES[@]}" 2>/dev/null || true)

missing=()
for p in "${PACKAGES[@]}"; do
  [[ -n ${installed[$p]:-} ]] || missing+=("${p}")
done

if ((${#missing[@]} == 0)); then
  echo "install_deps: all ${#PACKAGES[@]} Debian packages already installed"
  exit 0
fi

SUDO=()
if ((EUID != 0)); then
  if [[ -t 0 ]]; then SUDO=(sudo); else SUDO=(sudo -n); fi
fi
APT=("${SUDO[@]}" apt-get -o DPkg::Lock::Timeout=600)

echo "install_deps: installing ${#missing[@]} missing package(s): ${missing[*]}"
"${APT[@]}" update
"${APT[@]}" install -y --no-install-recommends "${missing[@]}"
echo "install_deps: done"
