#!/usr/bin/env bash
# One task of a batch (docs/batch.md): one `montage run` of one project, its results and log in a folder
# of its own, and one summary line. Run by scripts/batch.sh (GNU parallel) and scripts/batch.slurm (a
# Slurm array task); usable alone.
#
#   batch_task.sh NAME PROJECT OUT_ROOT [montage run options...]
#       runs `montage run PROJECT --out OUT_ROOT/NAME/result [options]`, with
#       OUT_ROOT/NAME/log.txt     everything montage printed (stdout and stderr)
#       OUT_ROOT/NAME/status.tsv  one line: the summary's columns (batch.sh --summary gathers them)
#       and exits with montage's exit code (0 done, 1 error, 2 usage, 3 done with warnings under --strict).
#   batch_task.sh --list PROJECTS_DIR
#       prints "NAME<TAB>PROJECT" for every project of the folder, sorted by name: DIR/NAME/project.json
#       and DIR/NAME.json. The same list for batch.sh and every array task of batch.slurm.
#
# Global montage options go first among the options: --threads N, --strict (docs/command-line.md).
# MONTAGE names the binary (default: build/bin/montage of this checkout).
set -uo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
montage="${MONTAGE:-$here/../build/bin/montage}"

if [[ "${1:-}" == "--list" ]]; then
  dir="${2:?usage: batch_task.sh --list PROJECTS_DIR}"
  [[ -d "$dir" ]] || { echo "batch_task.sh: $dir: not a folder" >&2; exit 2; }
  dir="$(cd "$dir" && pwd)"
  {
    for p in "$dir"/*/project.json; do
      if [[ -f "$p" ]]; then printf '%s\t%s\n' "$(basename "$(dirname "$p")")" "$p"; fi
    done
    for p in "$dir"/*.json; do
      if [[ -f "$p" ]]; then printf '%s\t%s\n' "$(basename "$p" .json)" "$p"; fi
    done
  } | LC_ALL=C sort -t $'\t' -k1,1 | awk -F '\t' '
    $1 == last { print "batch_task.sh: two projects are named " $1 ": rename one" > "/dev/stderr"; bad = 1 }
    { last = $1; print }
    END { exit bad }'
  exit $?
fi

if (($# < 3)); then
  echo "usage: batch_task.sh NAME PROJECT OUT_ROOT [montage run options...] | batch_task.sh --list DIR" >&2
  exit 2
fi
name="$1" project="$2" root="$3"
shift 3
[[ -x "$montage" ]] || { echo "batch_task.sh: $montage: no montage binary (build first, or set MONTAGE)" >&2; exit 1; }
task="$root/$name"
mkdir -p "$task" || exit 1
log="$task/log.txt"
times="$task/time.txt"
rm -rf "$task/result" "$times"

# Global options (--threads N, --strict) before the command, the rest after it.
global=() rest=()
while (($#)); do
  case "$1" in
    --strict) global+=("$1") ;;
    --threads) global+=("$1" "${2:-}"); shift ;;
    --threads=*) global+=("$1") ;;
    *) rest+=("$1") ;;
  esac
  shift
done
cmd=("$montage" "${global[@]}" run "$project" --out "$task/result" "${rest[@]}")

# Wall and CPU time of the run (and its peak memory, with GNU time).
{
  echo "# $(date -u +%FT%TZ) on $(hostname): ${cmd[*]}"
} >"$log"
if [[ -x /usr/bin/time ]]; then
  /usr/bin/time -o "$times" -f '%e %U %S %M' "${cmd[@]}" >>"$log" 2>&1
  code=$?
  read -r wall user sys rss < <(tail -n 1 "$times")
  cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }')
  peak=$(awk -v k="$rss" 'BEGIN { printf "%.0f", k / 1024 }')
else
  TIMEFORMAT='%R %U %S'
  { time "${cmd[@]}" >>"$log" 2>&1; } 2>"$times"
  code=$?
  read -r wall user sys < <(tail -n 1 "$times")
  cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }')
  peak=-
fi
[[ "$wall" =~ ^[0-9.]+$ ]] || wall=- cpu=- peak=-  # killed before time wrote its line
echo "# exit code $code" >>"$log"

# Figures of the result (report.json), "-" when there is none.
photo=- inpainted=- faces=-
report="$task/result/report.json"
if [[ -f "$report" ]] && command -v python3 >/dev/null; then
  read -r photo inpainted faces < <(python3 - "$report" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
s = r.get("surface", {})
faces = next((st["counts"].get("faces") for st in r.get("stages", []) if st.get("stage") == "load"), None)
f = lambda v, fmt: "-" if v is None else fmt % v
print(f(s.get("photo_share"), "%.4f"), f(s.get("inpainted_share"), "%.4f"), f(faces, "%d"))
EOF
  )
fi
warnings=$(grep -c '^ *warning:' "$log")
error=$(grep -m 1 -E '^(error|usage error):' "$log" | cut -c1-200 | tr '\t' ' ')
printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$code" "$wall" "$cpu" "$peak" "$faces" "$photo" \
  "$inpainted" "$warnings" "${error:--}" >"$task/status.tsv"
exit "$code"
