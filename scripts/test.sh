#!/usr/bin/env bash
# Command (2) of the README (and what CI runs): installs what is missing, including the test tools,
# builds, and runs the whole test suite with ctest.
# Usage: scripts/test.sh [--sanitize] [--with-blender] [ctest args...]
#   --sanitize  builds into build-sanitize/ with TM_SANITIZE (AddressSanitizer + UndefinedBehaviorSanitizer,
#               any undefined behaviour aborts) and runs the whole suite there. Not part of CI: the
#               instrumented build and suite take several times as long (docs/robustness.md).
#   --with-blender  also installs Blender, so that the test importing the exports into it runs (it skips
#               without; not part of CI: Blender adds 87 MB and about 10 s to the suite)
set -euo pipefail
cd "$(dirname "$0")/.."
sanitize=0
setup=(--with-tools)
while [[ "${1:-}" == --sanitize || "${1:-}" == --with-blender ]]; do
  if [[ "$1" == --sanitize ]]; then sanitize=1; else setup+=(--with-blender); fi
  shift
done
scripts/setup.sh "${setup[@]}"
if ((sanitize)); then
  cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTM_SANITIZE=ON >/dev/null
  cmake --build build-sanitize -j"$(nproc)"
  cd build-sanitize
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  ctest --output-on-failure -j"$(nproc)" --timeout 3600 "$@"
else
  scripts/build.sh
  cd build
  ctest --output-on-failure -j"$(nproc)" --timeout 900 "$@"
fi
