#!/usr/bin/env bash
# Build the side environment on the robot's Cyclone DDS 0.10.2: a venv from the same Python holding the
# cyclonedds 0.10.2 binding (sdist, compiled against Debian's libddsc from cyclonedds-dev) and the Unitree
# SDK2 Python code (--no-deps). The binding's setup looks for $CYCLONEDDS_HOME/include and
# $CYCLONEDDS_HOME/lib/libddsc.so; Debian keeps the library in the multiarch dir, so CYCLONEDDS_HOME is a
# folder of links. Built into a staging dir and renamed, so a failed build never leaves a half venv.
set -euo pipefail
python=${1:?usage: build_cyclone010.sh PYTHON VENV}
venv=$(realpath -m "${2:?usage: build_cyclone010.sh PYTHON VENV}")
top=$(cd "$(dirname "$0")/.." && pwd)
multiarch=$(gcc -print-multiarch 2>/dev/null || dpkg-architecture -qDEB_HOST_MULTIARCH)
test -e "/usr/lib/$multiarch/libddsc.so" || { echo "libddsc.so missing: install cyclonedds-dev" >&2; exit 1; }
staging="$venv.partial"
rm -rf "$staging" "$venv"
"$python" -m venv "$staging"
home="$staging/cyclonedds_home"
mkdir -p "$home"
ln -s /usr/include "$home/include"
ln -s "/usr/lib/$multiarch" "$home/lib"
ln -s /usr/bin "$home/bin"
# The sdist's build backend from pins too (no build isolation, which would fetch the newest setuptools).
"$staging/bin/python" -m pip install -q setuptools==79.0.1 wheel==0.45.1
CYCLONEDDS_HOME="$home" "$staging/bin/python" -m pip install -q --no-cache-dir --no-build-isolation \
  -r "$top/requirements-cyclone010.txt" -c "$top/requirements-cyclone010.txt"
"$staging/bin/python" -m pip install -q --no-deps -r "$top/requirements-nodeps.txt"
mv "$staging" "$venv"
# venv scripts carry absolute paths: after the rename only `bin/python` is used, which needs none.
"$venv/bin/python" -c "import cyclonedds.core, unitree_sdk2py.core.channel" \
  || { echo "side environment built but the SDK does not import" >&2; exit 1; }
echo "Cyclone DDS 0.10.2 side environment in $venv"
