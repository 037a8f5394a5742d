#!/usr/bin/env bash
# Compile the g1_mode_manager_msgs interface package (msg_defs/) into the venv prefix, so that the
# generated Python modules and their C type support import from the venv like any other ROS package.
set -euo pipefail
venv=$(cd "${1:?usage: build_msgs.sh VENV}" && pwd)
top=$(cd "$(dirname "$0")/.." && pwd)
build="$top/build/msgs"
mkdir -p "$build"
export AMENT_PREFIX_PATH="$venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export CMAKE_PREFIX_PATH="$venv${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
export PATH="$venv/bin:$PATH"
cmake -S "$top/msg_defs" -B "$build" -G "Unix Makefiles" \
  -DCMAKE_INSTALL_PREFIX="$venv" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
  -DPython3_EXECUTABLE="$venv/bin/python" -DPython3_FIND_VIRTUALENV=ONLY >"$build.log" 2>&1 \
  || { tail -40 "$build.log"; exit 1; }
cmake --build "$build" -j "$(nproc)" >>"$build.log" 2>&1 || { tail -40 "$build.log"; exit 1; }
cmake --install "$build" >>"$build.log" 2>&1 || { tail -40 "$build.log"; exit 1; }
"$venv/bin/python" -c "from g1_mode_manager_msgs.msg import Mode; from g1_mode_manager_msgs.srv import SetMode" \
  || { echo "g1_mode_manager_msgs built but does not import; see $build.log"; exit 1; }
echo "g1_mode_manager_msgs installed into $venv"
