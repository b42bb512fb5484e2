#!/usr/bin/env bash
# Builds OpenVINS without ROS (its ov_msckf library, with ov_core and ov_init) at a pinned commit,
# and the two small programs of this folder that feed it `vio export` data: `ov_feature_driver`
# (our feature tracks) and `ov_image_driver` (the rendered images, through its own front end).
#
#   bash tools/peer/openvins/build.sh
#
# Source: OPENVINS_SRC=/path/to/open_vins (a checkout) or, by default, a clone of the public
# repository at $OPENVINS_COMMIT into $OPENVINS_WORK/src. Debian/Ubuntu packages are installed
# when missing (Eigen, OpenCV, Boost, Ceres, CMake; root or sudo needed). Prints the drivers'
# path last. Idempotent: a second run only rebuilds what changed.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
work=${OPENVINS_WORK:-$root/target/peer/openvins}
commit=${OPENVINS_COMMIT:-69488123ed9362dd44b6f28e7f4680abbff1442b}
jobs=${JOBS:-$(nproc)}

packages=(cmake g++ libeigen3-dev libopencv-dev libboost-filesystem-dev libboost-system-dev
  libboost-thread-dev libboost-date-time-dev libceres-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "build.sh: installing ${missing[*]}" >&2
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

mkdir -p "$work"
src=${OPENVINS_SRC:-$work/src}
if [ -z "${OPENVINS_SRC:-}" ]; then
  if [ -d "$src/.git" ]; then
    git -C "$src" checkout --quiet "$commit"
  elif [ -f "$src/ov_msckf/CMakeLists.txt" ]; then
    # A source tree put there by hand (an archive of the pinned commit, say): used as it is.
    echo "build.sh: $src is not a git checkout: building it as it is (the commit is not checked)" >&2
  else
    git clone --quiet https://github.com/rpng/open_vins.git "$src"
    git -C "$src" checkout --quiet "$commit"
  fi
fi
[ -f "$src/ov_msckf/CMakeLists.txt" ] || { echo "build.sh: $src is not an OpenVINS checkout (no ov_msckf/CMakeLists.txt)" >&2; exit 2; }
echo "build.sh: OpenVINS $(git -C "$src" rev-parse HEAD 2>/dev/null || echo '(not a git checkout)') from $src" >&2

# OpenVINS's own CMake, as its authors build it without ROS; only the library is needed.
cmake -S "$src/ov_msckf" -B "$work/build-ov" -DCMAKE_BUILD_TYPE=Release -DENABLE_ROS=OFF \
  -DENABLE_ARUCO_TAGS=OFF >"$work/cmake-ov.log" 2>&1 || { cat "$work/cmake-ov.log" >&2; exit 1; }
cmake --build "$work/build-ov" --target ov_msckf_lib -j"$jobs"

cmake -S "$here" -B "$work/build-driver" -DCMAKE_BUILD_TYPE=Release -DOPENVINS_SRC="$src" \
  -DOPENVINS_LIB_DIR="$work/build-ov" >"$work/cmake-driver.log" 2>&1 || { cat "$work/cmake-driver.log" >&2; exit 1; }
cmake --build "$work/build-driver" -j"$jobs"
echo "$work/build-driver/ov_feature_driver"
echo "$work/build-driver/ov_image_driver"
