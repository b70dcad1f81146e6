#!/usr/bin/env bash
# Configures and builds kinolab (Release) into build/. Extra arguments go to cmake's configure.
set -euo pipefail
cd "$(dirname "$0")/.."
# Debian's interpreter sees python3-numpy and friends; another python3 on the PATH may not.
python=/usr/bin/python3
[[ -x "$python" ]] || python="$(command -v python3)"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE="$python" "$@"
cmake --build build -j"$(nproc)"
