# Shared by scripts/demo, scripts/test, scripts/llc and scripts/bench: install what is missing
# (Debian packages, idempotent, quiet when all is present) and build the catkin workspace under
# build/ (git-ignored).
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
# A dot name: roslaunch and rostest search the package folder for files and skip dot folders,
# so they do not follow src/laser_loop_closure back into the package again and again.
WS="$REPO/build/.ws"
DATA="${LLC_DATA_DIR:-$REPO/../shared/data}"
# Debian's ROS lives in /usr; a pyenv python3 first on PATH lacks its modules.
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:$PATH"
export ROS_MASTER_URI="${ROS_MASTER_URI:-http://127.0.0.1:11311}" ROS_IP="${ROS_IP:-127.0.0.1}"

LLC_PACKAGES=(build-essential cmake ros-base-dev ros-core-python-dev
  libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev liblaser-geometry-dev
  python3-rostest libgtest-dev rosbash libeigen3-dev libpcl-dev libpcl-conversions-dev
  libsuitesparse-dev libyaml-cpp-dev libnanoflann-dev libbenchmark-dev libceres-dev zlib1g-dev
  pluginlib-dev libnodeletlib-dev libnodeletlib-tools libmessage-filters-dev
  libdiagnostic-updater-dev librosbag-storage-dev librosbag-dev libnav-msgs-dev libtf2-msgs-dev
  python3-rosbag python3-matplotlib python3-numpy
  rviz xvfb imagemagick x11-apps libvisualization-msgs-dev libstd-srvs-dev libmap-msgs-dev)

llc_install_missing() {
  local missing=() p
  for p in "${LLC_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "Installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

llc_build() {
  mkdir -p "$WS/src"
  [ -e "$WS/src/laser_loop_closure" ] || ln -s "$REPO" "$WS/src/laser_loop_closure"
  local log="$REPO/build/build.log"
  echo "Building (log: build/build.log) ..."
  if ! (cd "$WS" && catkin_make -j"$(nproc)" \
        -DCMAKE_BUILD_TYPE=Release \
        -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
        "$@" >"$log" 2>&1); then
    tail -n 60 "$log"
    echo "Build failed; the whole log is build/build.log" >&2
    return 1
  fi
}

llc_setup() {
  llc_install_missing
  llc_build "$@"
  # shellcheck disable=SC1091
  set +u; source "$WS/devel/setup.bash"; set -u
}

LLC_BIN="$WS/devel/lib/laser_loop_closure"

# Drift seeds (scripts/drifted_logs, scripts/self_training): "1,2,3" into the array seed_list,
# or the message and the usage ($2) on stderr and exit 2.
llc_seed_list() {
  [[ "$1" =~ ^[0-9]+(,[0-9]+)*$ ]] || { echo "--seeds: a comma-separated list of integers, not '$1'" >&2; echo "$2" >&2; exit 2; }
  IFS=, read -r -a seed_list <<<"$1"
}

# Leave-one-log-out models (scripts/drifted_logs, scripts/localization, scripts/multi_robot):
# the labelled pairs of every log given (llc pairs, into DIR/pairs/NAME.csv), then for each log
# a model trained on the pairs of the others only (llc train, defaults: DIR/models/NAME.yaml).
# NAME: the log's file name without -corrected.log.gz.
#   llc_log_out_models DIR LOG...
llc_log_out_models() {
  local dir="$1" log held
  shift
  mkdir -p "$dir/pairs" "$dir/models"
  for log in "$@"; do
    "$LLC_BIN/llc" pairs --log "$log" --out "$dir/pairs/$(basename "$log" -corrected.log.gz).csv" >/dev/null
  done
  for held in "$@"; do
    local args=()
    for log in "$@"; do
      [ "$log" = "$held" ] || args+=(--data "$log:$dir/pairs/$(basename "$log" -corrected.log.gz).csv")
    done
    "$LLC_BIN/llc" train "${args[@]}" --model "$dir/models/$(basename "$held" -corrected.log.gz).yaml" >/dev/null
  done
}
