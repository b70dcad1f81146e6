#!/usr/bin/env bash
# Install what is missing, build, and run every test: unit, conformance and integration
# (GoogleTest), the command line and the runner (pytest), the analysis package and the report
# in headless Chromium, a real local Slurm cluster (its test installs Debian's Slurm packages
# when missing), the cmake export and a benchmark smoke run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_debian.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)"
