#!/usr/bin/env bash
# Installs the Debian 12 packages kinolab needs to build, test and report. Idempotent: it
# asks apt only for what is missing, so a second run does nothing. Runs as root, or through
# sudo otherwise.
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake pkg-config git
  # C++ libraries
  libeigen3-dev liboctomap-dev libyaml-cpp-dev libpng-dev libxxhash-dev libcli11-dev
  nlohmann-json3-dev libboost-dev libfcl-dev libgtest-dev libbenchmark-dev
  # the TGK analogue: OMPL (and the Boost libraries it links) and Ceres
  libompl-dev libboost-serialization-dev libboost-filesystem-dev libboost-system-dev
  libceres-dev
  # the corridor_minco and ego_bspline back ends' L-BFGS
  liblbfgs-dev
  # OMPL's ompl_benchmark_statistics: the export test turns kinolab's OMPL logs into Planner
  # Arena's database with it
  ompl-demos
  # the experiment runner's results database
  libsqlite3-dev
  # Python (Debian's interpreter and packages; the Python package index is not needed)
  python3 python3-numpy python3-scipy python3-yaml python3-pytest python3-pandas
  python3-matplotlib python3-pil python3-jinja2
  # the scene format test validates both scene writers against viewer/scene.schema.json
  python3-jsonschema
  # the Python bindings (pybind11) and the 3D viewer (three.js r111, inlined at build time)
  python3-dev pybind11-dev python3-pybind11 libjs-three
  # the report and viewer tests render HTML in a headless browser (the viewer's clicked
  # through Selenium and ChromeDriver)
  chromium chromium-driver python3-selenium
)

missing=()
for package in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#PACKAGES[@]} packages are installed"
  exit 0
fi

as_root=()
if [[ "$(id -u)" -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "setup: not root and no sudo; install: ${missing[*]}" >&2; exit 1; }
  as_root=(sudo)
fi
echo "setup: installing ${missing[*]}"
"${as_root[@]}" apt-get update -qq
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive \
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
