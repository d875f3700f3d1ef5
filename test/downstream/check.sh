#!/usr/bin/env bash
# A dependent catkin package (test/downstream: find_package(catkin REQUIRED COMPONENTS vadop),
# vadop/ImpactArray.h and vadop/world.h, linking vadop_core) builds and runs against vadop's
# install space and against its devel space.
#
#   bash test/downstream/check.sh BUILD_DIR     e.g. bash test/downstream/check.sh build
#
# BUILD_DIR: an already built plain-CMake build of the root package (as .ci/run's catkin-build);
# nothing of vadop is rebuilt. Work files go to BUILD_DIR/downstream/.
#   1. install: catkin bakes the install prefix into the install space at configure time
#      (setup.sh, vadopConfig.cmake's library paths), so `cmake --install --prefix` elsewhere
#      would give a broken install space. BUILD_DIR is configured again with
#      CMAKE_INSTALL_PREFIX=BUILD_DIR/downstream/install, `install` is built (a no-op build, then
#      the install) and the original prefix is restored afterwards.
#   2. the downstream package with plain CMake after `source <prefix>/setup.bash`, and run;
#   3. the same after `source BUILD_DIR/devel/setup.bash`.
# Exit status 0 only when both builds and both runs succeed.
set -euo pipefail
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:${PATH} # Debian's python (catkin_pkg), not pyenv's

if (($# != 1)) || [[ ! -f $1/CMakeCache.txt || ! -f $1/devel/setup.bash ]]; then
  echo "usage: $0 BUILD_DIR   (a configured and built build of the vadop package)" >&2
  exit 2
fi
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
BUILD=$(cd "$1" && pwd)
WORK=${BUILD}/downstream
PREFIX=${WORK}/install
JOBS=${VADOP_JOBS:-1}

rm -rf "${WORK}"
mkdir -p "${WORK}"

# --- 1. install space ------------------------------------------------------------------------
old_prefix=$(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' "${BUILD}/CMakeCache.txt")
src_dir=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "${BUILD}/CMakeCache.txt")
restore_prefix() {
  echo "--- restoring CMAKE_INSTALL_PREFIX=${old_prefix} in ${BUILD}"
  cmake -S "${src_dir}" -B "${BUILD}" -DCMAKE_INSTALL_PREFIX="${old_prefix}" >"${WORK}/restore.log" 2>&1 ||
    { tail -n 30 "${WORK}/restore.log"; return 1; }
}
echo "--- installing ${BUILD} into ${PREFIX}"
trap restore_prefix EXIT
cmake -S "${src_dir}" -B "${BUILD}" -DCMAKE_INSTALL_PREFIX="${PREFIX}" >"${WORK}/install-configure.log" 2>&1 ||
  { tail -n 30 "${WORK}/install-configure.log"; exit 1; }
cmake --build "${BUILD}" --target install -j "${JOBS}" >"${WORK}/install.log" 2>&1 ||
  { tail -n 30 "${WORK}/install.log"; exit 1; }
trap - EXIT
restore_prefix
for f in setup.bash lib/libvadop_core.so include/vadop/world.h include/vadop/ImpactArray.h \
  share/vadop/cmake/vadopConfig.cmake; do
  [[ -e ${PREFIX}/${f} ]] || { echo "not installed: ${PREFIX}/${f}" >&2; exit 1; }
done

# --- 2. and 3. the dependent package against each space -----------------------------------------
# Each in a fresh shell: a setup.bash adds to the environment, it does not replace it.
build_and_run() { # SPACE_NAME SETUP_BASH
  local name=$1 setup=$2 out=${WORK}/build-$1
  echo "--- ${name} space: source ${setup}; cmake -S ${HERE} -B ${out}"
  env -i HOME="${HOME}" PATH="${PATH}" TERM="${TERM:-dumb}" bash -c '
    set -euo pipefail
    setup=$1 src=$2 out=$3 jobs=$4
    set +u; source "${setup}"; set -u
    cmake -S "${src}" -B "${out}" -DCMAKE_BUILD_TYPE=RelWithDebInfo >"${out}.configure.log" 2>&1 ||
      { tail -n 30 "${out}.configure.log"; exit 1; }
    grep -E "^vadop_DIR:" "${out}/CMakeCache.txt" || true
    cmake --build "${out}" -j "${jobs}" >"${out}.build.log" 2>&1 || { tail -n 30 "${out}.build.log"; exit 1; }
    # Which vadop_core the executable links: the one of this space.
    ldd "${out}/devel/lib/vadop_downstream_check/vadop_downstream_check" | grep vadop_core
    "${out}/devel/lib/vadop_downstream_check/vadop_downstream_check"
  ' check "${setup}" "${HERE}" "${out}" "${JOBS}"
}
build_and_run install "${PREFIX}/setup.bash"
build_and_run devel "${BUILD}/devel/setup.bash"
echo "downstream: install space and devel space ok"
