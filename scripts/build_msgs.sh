#!/usr/bin/env bash
# Compile the g1_mode_manager_msgs interface package (msg_defs/) into the venv prefix, so that the
# generated Python modules and their C type support import from the venv like any other ROS package.
# Also tf2_msgs (msg_defs/tf2_msgs: TFMessage, for odom's /tf), but only where none imports already:
# ROS 2 from PyPI wheels has none, a full ROS install has its own.
set -euo pipefail
venv=$(cd "${1:?usage: build_msgs.sh VENV}" && pwd)
top=$(cd "$(dirname "$0")/.." && pwd)
export AMENT_PREFIX_PATH="$venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$venv${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
export PATH="$venv/bin:$PATH"

build() {  # build SOURCE_DIR NAME PYTHON_CHECK
  local src=$1 name=$2 check=$3 build="$top/build/$2"
  mkdir -p "$build"
  cmake -S "$src" -B "$build" -G "Unix Makefiles" \
    -DCMAKE_INSTALL_PREFIX="$venv" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
    -DPython3_EXECUTABLE="$venv/bin/python" -DPython3_FIND_VIRTUALENV=ONLY >"$build.log" 2>&1 \
    || { tail -40 "$build.log"; exit 1; }
  cmake --build "$build" -j "$(nproc)" >>"$build.log" 2>&1 || { tail -40 "$build.log"; exit 1; }
  cmake --install "$build" >>"$build.log" 2>&1 || { tail -40 "$build.log"; exit 1; }
  "$venv/bin/python" -c "$check" || { echo "$name built but does not import; see $build.log"; exit 1; }
  echo "$name installed into $venv"
}

tf_check="from tf2_msgs.msg import TFMessage"
if "$venv/bin/python" -c "$tf_check" 2>/dev/null && [ ! -f "$venv/share/tf2_msgs/g1_mode_manager_built" ]; then
  echo "tf2_msgs: the installed one is used"
else
  build "$top/msg_defs/tf2_msgs" tf2_msgs "$tf_check"
  touch "$venv/share/tf2_msgs/g1_mode_manager_built"
fi
build "$top/msg_defs" msgs "from g1_mode_manager_msgs.msg import Mode; from g1_mode_manager_msgs.srv import SetMode"
