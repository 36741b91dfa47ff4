#!/usr/bin/env bash
# Runs a folder of projects on this machine with GNU parallel (docs/batch.md): one `montage run` per
# project (scripts/batch_task.sh), results and logs per project, and a summary table of exit codes and
# figures. No scheduler of our own: parallel runs the tasks, its --joblog records them, --resume-failed
# reruns what failed.
#
#   scripts/batch.sh [--jobs N] [--threads T] [--resume] PROJECTS_DIR OUT_DIR [montage run options...]
#       PROJECTS_DIR/NAME/project.json and PROJECTS_DIR/NAME.json are the projects;
#       OUT_DIR/NAME/{result/,log.txt,status.tsv} per project; OUT_DIR/joblog.tsv (GNU parallel's),
#       OUT_DIR/summary.tsv and OUT_DIR/summary.md (printed at the end).
#       --jobs N     runs at a time (default: the number of cores)
#       --threads T  threads per run (default 1: one run per core uses a machine best)
#       --resume     run again only the projects whose last run failed or never ran (parallel --resume-failed)
#       options after OUT_DIR go to every `montage run`: --strict, --set KEY=VALUE, --png-compression N.
#   scripts/batch.sh --summary OUT_DIR
#       only gathers OUT_DIR/*/status.tsv into the summary (after a Slurm array: scripts/batch.slurm).
#
# Exit code: 0 when every project exited 0, 3 when the worst was 3 (warnings under --strict), 1 when one
# failed (exit 1 or 2, or killed), 2 for a usage error of this script.
set -uo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"

usage() {
  sed -n '2,21p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

# OUT_DIR/summary.tsv and .md from the tasks' status lines; prints the markdown; returns the batch's code.
summarise() {
  local out="$1"
  local header=$'project\texit\twall_s\tcpu_s\tpeak_mib\tfaces\tphoto_share\tinpainted_share\twarnings\terror'
  {
    echo "$header"
    for s in "$out"/*/status.tsv; do
      if [[ -f "$s" ]]; then cat "$s"; fi
    done | LC_ALL=C sort -t $'\t' -k1,1
  } >"$out/summary.tsv"
  awk -F '\t' '
    NR == 1 { printf "|"; for (i = 1; i <= NF; ++i) printf " %s |", $i; printf "\n|"; for (i = 1; i <= NF; ++i) printf "---|"; printf "\n"; next }
    { gsub(/\|/, "\\|"); printf "|"; for (i = 1; i <= NF; ++i) printf " %s |", $i; printf "\n" }' \
    "$out/summary.tsv" >"$out/summary.md"
  local n ok
  n=$(($(wc -l <"$out/summary.tsv") - 1))
  ok=$(awk -F '\t' 'NR > 1 && $2 == 0' "$out/summary.tsv" | wc -l)
  {
    echo
    echo "$n projects: $ok done, $(awk -F '\t' 'NR > 1 && $2 == 3' "$out/summary.tsv" | wc -l) done with warnings" \
      "(--strict), $(awk -F '\t' 'NR > 1 && $2 != 0 && $2 != 3' "$out/summary.tsv" | wc -l) failed"
  } >>"$out/summary.md"
  cat "$out/summary.md"
  awk -F '\t' 'NR > 1 { if ($2 != 0 && $2 != 3) bad = 1; else if ($2 == 3) warn = 1 }
               END { exit bad ? 1 : warn ? 3 : 0 }' "$out/summary.tsv"
}

jobs="" threads=1 resume=()
while (($#)); do
  case "$1" in
    --jobs) jobs="${2:-}"; shift 2 ;;
    --threads) threads="${2:-}"; shift 2 ;;
    --resume) resume=(--resume-failed); shift ;;
    --summary) [[ -d "${2:-}" ]] || usage; summarise "$2"; exit $? ;;
    -h|--help) usage ;;
    -*) echo "batch.sh: unknown option $1" >&2; usage ;;
    *) break ;;
  esac
done
(($# >= 2)) || usage
projects="$1" out="$2"
shift 2
[[ -z "$jobs" || "$jobs" =~ ^[1-9][0-9]*$ ]] || { echo "batch.sh: --jobs $jobs: not a positive number" >&2; exit 2; }
[[ "$threads" =~ ^[1-9][0-9]*$ ]] || { echo "batch.sh: --threads $threads: not a positive number" >&2; exit 2; }
command -v parallel >/dev/null || { echo "batch.sh: GNU parallel is not installed (Debian package parallel: scripts/setup.sh --with-tools)" >&2; exit 1; }
[[ -z "$jobs" ]] && jobs=$(nproc)

mkdir -p "$out" || exit 1
out="$(cd "$out" && pwd)"
list="$out/projects.tsv"
"$here/batch_task.sh" --list "$projects" >"$list" || exit 2
count=$(wc -l <"$list")
((count > 0)) || { echo "batch.sh: $projects: no projects (NAME/project.json or NAME.json)" >&2; exit 2; }
echo "batch: $count projects, $jobs at a time, $threads thread(s) each -> $out"

# One line per project: NAME, PROJECT. parallel keeps going when a task fails (--halt never) and records
# every task's exit code and times in its joblog.
parallel --will-cite --quote --jobs "$jobs" --colsep '\t' --halt never --joblog "$out/joblog.tsv" "${resume[@]}" \
  --tagstring '{1}' --line-buffer \
  "$here/batch_task.sh" {1} {2} "$out" --threads "$threads" "$@" :::: "$list" >"$out/parallel.log" 2>&1
summarise "$out"
