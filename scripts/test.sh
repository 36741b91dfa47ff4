#!/usr/bin/env bash
# Command (2) of the README (and what CI runs): installs what is missing, including the test tools,
# builds, and runs the whole test suite with ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --with-tools
scripts/build.sh
cd build
ctest --output-on-failure -j"$(nproc)" --timeout 900
