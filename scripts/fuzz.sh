#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz with clang (ASan + UBSan + libFuzzer) into build-fuzz/ and
# runs each for SECONDS (default 60), or only the TARGETs named (e.g. fuzz_mesh_ply).
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]     (FUZZ_NO_BUILD=1 runs the binaries already built)
# Installs clang and its sanitizer/libFuzzer runtime (libclang-rt-14-dev) when missing. Grown corpora
# stay in build-fuzz/corpus/<target>/, findings go to build-fuzz/crashes/<target>/, and every run adds a
# line to build-fuzz/fuzz-stats.tsv; the totals per target are printed at the end. Exit status 1 when a
# target found something.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
all=(fuzz_mesh_obj fuzz_mesh_ply fuzz_mesh_off fuzz_mesh_stl fuzz_project fuzz_model_obj fuzz_model_gltf fuzz_photo)
targets=("$@")
if ((${#targets[@]} == 0)); then targets=("${all[@]}"); fi

# clang 14 and its runtime (Debian 12), installed only when missing.
missing=()
for p in clang libclang-rt-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""
  if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
scripts/setup.sh

if [[ "${FUZZ_NO_BUILD:-0}" != 1 ]]; then
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DTM_FUZZ=ON -DTM_BUILD_TESTS=OFF -DTM_BUILD_EDITOR=OFF "${launcher[@]}" >/dev/null
build_targets=()
for t in "${targets[@]}"; do build_targets+=(--target "$t"); done
cmake --build build-fuzz -j"$(nproc)" "${build_targets[@]}"
fi

corpus_of() {  # seed folder and dictionary of a target
  case "$1" in
    fuzz_mesh_*) echo "mesh_${1#fuzz_mesh_} ${1#fuzz_mesh_}" ;;
    fuzz_project) echo "project json" ;;
    fuzz_model_obj) echo "model_obj mtl" ;;
    fuzz_model_gltf) echo "model_gltf gltf" ;;
    fuzz_photo) echo "photo image" ;;
  esac
}
max_len_of() {
  case "$1" in
    fuzz_mesh_*) echo 16384 ;;
    *) echo 65536 ;;
  esac
}

stats=build-fuzz/fuzz-stats.tsv
[[ -f $stats ]] || printf 'date\ttarget\tseconds\texecutions\tcrashes\n' >"$stats"
status=0
for t in "${targets[@]}"; do
  read -r seeds dict <<<"$(corpus_of "$t")"
  mkdir -p "build-fuzz/corpus/$t" "build-fuzz/crashes/$t"
  log="build-fuzz/crashes/$t/last.log"
  set +e
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "build-fuzz/bin/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -malloc_limit_mb=2048 \
    -max_len="$(max_len_of "$t")" -dict="tests/fuzz/dict/$dict.dict" -print_final_stats=1 \
    -artifact_prefix="build-fuzz/crashes/$t/" "build-fuzz/corpus/$t" "tests/fuzz/corpus/$seeds" >"$log" 2>&1
  rc=$?
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  crashes=0
  if ((rc != 0)); then
    crashes=1
    status=1
    echo "$t: FOUND SOMETHING (exit $rc), see $log and build-fuzz/crashes/$t/" >&2
    grep -E "ERROR|SUMMARY|runtime error|Test unit written" "$log" | head -5 >&2 || true
  fi
  printf '%s\t%s\t%s\t%s\t%s\n' "$(date -u +%FT%TZ)" "$t" "$seconds" "${execs:-0}" "$crashes" >>"$stats"
  echo "$t: ${execs:-0} executions in ${seconds} s, corpus $(ls "build-fuzz/corpus/$t" | wc -l) inputs, exit $rc"
done

echo "totals over all runs (build-fuzz/fuzz-stats.tsv):"
awk -F'\t' 'NR > 1 { e[$2] += $4; c[$2] += $5; s[$2] += $3 } END { for (t in e) printf "  %-16s %12d executions %6d s %d crashes\n", t, e[t], s[t], c[t] }' "$stats" | sort
exit $status
