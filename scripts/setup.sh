#!/usr/bin/env bash
# Installs the Debian bookworm packages stillmap needs (only those missing), then configures and
# builds it: scripts/setup.sh [PRESET] (CMakePresets.json: default -> ./build, sanitize ->
# ./build-sanitize). Called by scripts/main_job.sh, test.sh and sanitize.sh; safe to run again.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

packages=(
  build-essential cmake pkg-config ccache
  libeigen3-dev libopencv-dev libopencv-contrib-dev libpcl-dev liboctomap-dev octomap-tools
  # tests: the cloud files are converted by pcl-tools, as users do
  pcl-tools
  libceres-dev libflann-dev libassimp-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libspdlog-dev libfmt-dev libgoogle-glog-dev libtbb-dev libjpeg-dev libpng-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  # recorded bags: their block compressions (and lz4's xxHash checksums), ROS 2's sqlite3 storage
  libbz2-dev liblz4-dev libxxhash-dev libzstd-dev zlib1g-dev libsqlite3-dev
  # tests: scripts/revisit_replay.py makes the revisit replays; the RealSense recorder's bags
  # are written with ROS's own Python writer
  python3 python3-numpy python3-opencv python3-yaml python3-rosbag python3-roslz4
  python3-sensor-msgs python3-geometry-msgs python3-std-msgs python3-diagnostic-msgs
  # tests: bags with a robot's poses (make-bags --poses: /tf, /tf_static, /odom)
  python3-tf2-msgs python3-nav-msgs
  # tests: the view window runs under xvfb-run, which needs xauth (not a dependency of xvfb)
  xvfb xauth
  # tests: scripts/slurm/fleet.sh on a one-node Slurm cluster the test starts (no systemd)
  slurm-wlm munge
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "stillmap setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  sudo_cmd=()
  [ "$(id -u)" -ne 0 ] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends \
    "${missing[@]}"
fi

preset="${1:-default}"
jobs="${STILLMAP_JOBS:-2}"
cd "$root"
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j "$jobs"
