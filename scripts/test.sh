#!/usr/bin/env bash
# Install what is missing, build, and run every test (unit, command line, cmake export,
# benchmark smoke run).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_debian.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)"
