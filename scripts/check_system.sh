#!/usr/bin/env bash
# System packages the set-up needs besides Python wheels: a C/C++ toolchain and CMake (to compile the
# interfaces), Python headers, EGL/Mesa for headless MuJoCo pictures, GLX and Xvfb for the viewer's window
# test, Chromium and chromedriver for the operator console's browser test, and Debian's Cyclone DDS 0.10.2
# (the robot's, for the side environment .venv-cyclone010/). Installs what is missing when run as root
# (Debian), otherwise says what to install.
set -euo pipefail
missing=()
command -v cmake >/dev/null || missing+=(cmake)
command -v g++ >/dev/null || missing+=(g++)
command -v make >/dev/null || missing+=(make)
python3 -c 'import sysconfig, os, sys; sys.exit(0 if os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else 1)' \
  || missing+=(python3-dev)
ldconfig -p | grep -q 'libEGL.so.1 ' || missing+=(libegl1)
ldconfig -p | grep -q 'libEGL_mesa.so.0 ' || missing+=(libegl-mesa0)
compgen -G "/usr/lib/*/dri/swrast_dri.so" >/dev/null || missing+=(libgl1-mesa-dri)
compgen -G "/usr/lib/*/libddsc.so" >/dev/null || missing+=(cyclonedds-dev)  # the robot's Cyclone 0.10.2: side env
command -v Xvfb >/dev/null || missing+=(xvfb)  # the viewer's window test (a virtual display)
ldconfig -p | grep -q 'libGL.so.1 ' || missing+=(libgl1)  # GLX for the viewer's window
ldconfig -p | grep -q 'libGLX_mesa.so.0 ' || missing+=(libglx-mesa0)
# the operator console's browser test (headless, driven by selenium) and its screenshots
[ -x /usr/bin/chromium ] || missing+=(chromium)
[ -x /usr/bin/chromedriver ] || missing+=(chromium-driver)
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
  echo "installing system packages: ${missing[*]}"
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
else
  echo "missing system packages: ${missing[*]} (install them, e.g. sudo apt-get install ${missing[*]})" >&2
  exit 1
fi
