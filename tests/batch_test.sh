#!/usr/bin/env bash
# ctest `batch` (docs/batch.md): four projects through GNU parallel -j2 with scripts/batch.sh, three copies
# of the bundled demo and one broken (a click on a vertex the mesh does not have); the summary must have
# every project's exit code and figures, the three results the same bytes. Then scripts/batch.slurm's
# array-task logic by hand (SLURM_ARRAY_TASK_ID set, no Slurm: it cannot run here).
# Usage: batch_test.sh MONTAGE SOURCE_DIR. Exit 77 (skipped) when GNU parallel is absent.
set -uo pipefail
montage="$1" src="$2"
export MONTAGE="$montage"

if ! command -v parallel >/dev/null; then
  echo "SKIPPED: GNU parallel is absent (Debian package parallel: scripts/setup.sh --with-tools)"
  exit 77
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/tm_batch_XXXXXX")
trap 'rm -rf "$work"' EXIT
fails=0
check() {  # check DESCRIPTION COMMAND...
  if "${@:2}"; then echo "ok: $1"; else echo "FAILED: $1"; fails=$((fails + 1)); fi
}

mkdir -p "$work/projects/broken"
for name in cat_a cat_b cat_c; do cp -r "$src/assets/demo" "$work/projects/$name"; done
cp "$src/assets/demo/"*.png "$src/assets/demo/cat.obj" "$work/projects/broken/"
sed '0,/"vertex": [0-9]*/s//"vertex": 99999/' "$src/assets/demo/project.json" >"$work/projects/broken/project.json"

bash "$src/scripts/batch.sh" --jobs 2 --threads 1 "$work/projects" "$work/out" --png-compression 1
code=$?
summary="$work/out/summary.tsv"
check "batch.sh exits 1 when a project failed (got $code)" test "$code" -eq 1
check "GNU parallel ran the four tasks (joblog)" test "$(tail -n +2 "$work/out/joblog.tsv" | wc -l)" -eq 4
check "the summary has a header and four projects" test "$(wc -l <"$summary")" -eq 5

# Every row: project, exit, wall_s, cpu_s, peak_mib, faces, photo_share, inpainted_share, warnings, error.
row() { awk -F '\t' -v n="$1" '$1 == n' "$summary"; }
num='^[0-9]+(\.[0-9]+)?$'
for name in cat_a cat_b cat_c; do
  IFS=$'\t' read -r p code wall cpu peak faces photo inpainted warnings error < <(row "$name")
  check "$name: exit 0" test "$code" = 0
  for v in wall cpu peak faces photo inpainted warnings; do
    check "$name: $v is a number (${!v})" eval '[[ "${!v}" =~ $num ]]'
  done
  check "$name: 15894 faces" test "$faces" = 15894
  check "$name: photo share of the demo (0.55..0.75: $photo)" awk -v x="$photo" 'BEGIN { exit !(x > 0.55 && x < 0.75) }'
  check "$name: its warnings counted (${warnings})" test "$warnings" -gt 0
  check "$name: result and log" test -f "$work/out/$name/result/model.glb" -a -s "$work/out/$name/log.txt"
done
IFS=$'\t' read -r p code wall cpu peak faces photo inpainted warnings error < <(row broken)
check "broken: exit 1" test "$code" = 1
check "broken: times measured ($wall s, $cpu s)" eval '[[ "$wall" =~ $num && "$cpu" =~ $num ]]'
check "broken: no figures without a result" test "$faces$photo$inpainted" = "---"
check "broken: the error names the field ($error)" eval '[[ "$error" == *"points[0].vertex: 99999 is out of range"* ]]'
check "summary.md has the five rows and the tally" grep -q "4 projects: 3 done, 0 done with warnings (--strict), 1 failed" "$work/out/summary.md"
for f in model.obj model.glb model_atlas.png; do
  check "same bytes in the three results: $f" eval 'cmp -s "$work/out/cat_a/result/$f" "$work/out/cat_b/result/$f" && cmp -s "$work/out/cat_a/result/$f" "$work/out/cat_c/result/$f"'
done

# --strict: the demo's warnings make each run exit 3, and the batch too (one project is enough).
mkdir -p "$work/strict"
cp -r "$work/projects/cat_a" "$work/strict/cat"
bash "$src/scripts/batch.sh" --jobs 1 "$work/strict" "$work/strict_out" --strict --png-compression 1 >/dev/null
code=$?
check "--strict: batch exit 3 (got $code)" test "$code" -eq 3
check "--strict: the project's exit 3" test "$(awk -F '\t' 'NR == 2 { print $2 }' "$work/strict_out/summary.tsv")" = 3

# The Slurm array task, by hand: task 1 of the sorted list is cat_a.
SLURM_ARRAY_TASK_ID=1 SLURM_SUBMIT_DIR="$src" SLURM_CPUS_PER_TASK=1 \
  bash "$src/scripts/batch.slurm" "$work/projects" "$work/slurm_out" --png-compression 1 >/dev/null 2>&1
code=$?
check "batch.slurm task 1 ran cat_a (exit $code)" test "$code" -eq 0 -a -f "$work/slurm_out/cat_a/result/model.glb"
bash "$src/scripts/batch.sh" --summary "$work/slurm_out" >/dev/null
check "batch.sh --summary after the array" test "$(awk -F '\t' 'NR == 2 { print $1 "/" $2 }' "$work/slurm_out/summary.tsv")" = cat_a/0

echo "--- summary.md:"
cat "$work/out/summary.md"
if ((fails > 0)); then
  echo "$fails checks failed"
  exit 1
fi
echo "all checks passed"
