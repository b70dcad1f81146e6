#!/usr/bin/env bash
# Configures and builds kinolab (Release) into build/, then installs it under /usr/local (the
# `kinolab` command, its libraries, the 3D viewer, and the Python package where Debian's
# /usr/bin/python3 finds it: `python3 -c "import kinolab"`). Installing needs root or sudo;
# without either it is skipped (use PYTHONPATH=build/python). Extra arguments go to cmake's
# configure.
set -euo pipefail
cd "$(dirname "$0")/.."
# Debian's interpreter sees python3-numpy and friends; another python3 on the PATH may not.
python=/usr/bin/python3
[[ -x "$python" ]] || python="$(command -v python3)"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE="$python" "$@"
cmake --build build -j"$(nproc)"
if [[ "$(id -u)" -eq 0 ]]; then
  cmake --install build >/dev/null
elif sudo -n true 2>/dev/null; then
  sudo cmake --install build >/dev/null
else
  echo "build: not root and no sudo: kinolab is not installed; import it with" \
       "PYTHONPATH=$PWD/build/python" >&2
  exit 0
fi
echo "build: installed under $(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' build/CMakeCache.txt)" \
     "(the kinolab command, the Python package kinolab)"
