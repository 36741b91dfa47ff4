#!/usr/bin/env bash
# kill -9 at random moments (issue 15): of `montage run` on the demo project, and of the editor saving a
# project over and over. After each kill the output must hold exactly one complete result (run: every
# file the manifest lists, a report.json that parses and whose atlas size matches the PNG, a GLB and an
# OBJ that load; editor: a project file that loads and is one of the versions saved), and after the next
# run or save no temporary file may be left.
# Usage: scripts/kill_test.sh [KILLS] [run|save|both] [SAVES]   (default 20 both 400; needs build/bin, xvfb-run
# for save; SAVES is how many times the editor saves per session: fewer make the save part quicker)
set -euo pipefail
cd "$(dirname "$0")/.."
kills=${1:-20}
which=${2:-both}
saves=${3:-400}
montage=$PWD/build/bin/montage
editor=$PWD/build/bin/texturemontage
work=$(mktemp -d /tmp/tm_kill.XXXXXX)
trap 'rm -rf "$work"' EXIT
fail=0

# Two variants of the demo project (atlas 1024 and 2048), so that files of two runs cannot pass for one;
# its relative paths (mesh, photos, masks) made absolute.
for size in 1024 2048; do
  python3 - "$PWD/assets/demo" "$size" "$work/p$size.json" <<'PY'
import json, os, sys
demo, size, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
p = json.load(open(os.path.join(demo, "project.json")))
p["mesh"] = os.path.join(demo, p["mesh"])
for photo in p["photos"]:
    for key in ("path", "mask"):
        if photo.get(key):
            photo[key] = os.path.join(demo, photo[key])
p.setdefault("options", {})["atlasSize"] = size
json.dump(p, open(out, "w"), indent=1)
PY
done

# Prints the atlas size of a complete result in $1, or fails.
check_result() {
  local dir=$1
  [[ -f "$dir/.texturemontage-result" ]] || { echo "no manifest"; return 1; }
  while read -r f; do [[ -e "$dir/$f" ]] || { echo "missing $f"; return 1; }; done <"$dir/.texturemontage-result"
  local size png
  size=$(python3 -c "import json,sys; r=json.load(open('$dir/report.json')); print([s for s in r['stages'] if s['stage']=='bake'][0]['counts']['size'])") ||
    { echo "report.json unreadable"; return 1; }
  png=$("$montage" info "$dir/model_atlas.png" | sed -n 's/^  size: \([0-9]*\) x.*/\1/p')
  [[ "$png" == "$size" ]] || { echo "atlas PNG is $png wide, report says $size"; return 1; }
  "$montage" info "$dir/model.glb" >/dev/null || { echo "model.glb does not load"; return 1; }
  "$montage" info "$dir/model.obj" >/dev/null || { echo "model.obj does not load"; return 1; }
  grep -q "map_Kd" "$dir/model.mtl" || { echo "model.mtl names no texture"; return 1; }
  echo "$size"
}

leftovers() {  # temporary files and folders of killed writers in $1 and below
  find "$1" -name '.*.tmp-*' -o -name '.*.lock' | sort
}

if [[ $which == run || $which == both ]]; then
  out=$work/result
  start=$(date +%s.%N)
  "$montage" run "$work/p1024.json" --out "$out" >/dev/null 2>&1
  span=$(echo "$(date +%s.%N) - $start" | bc)
  first=$(check_result "$out")
  echo "run: one run takes ${span} s; baseline result has atlas $first"
  running=0
  for ((k = 1; k <= kills; k++)); do
    size=$((k % 2 ? 2048 : 1024))
    delay=$(python3 -c "import random; print(round(random.uniform(0, $span), 3))")
    "$montage" run "$work/p$size.json" --out "$out" >/dev/null 2>&1 &
    pid=$!
    sleep "$delay"
    if kill -0 "$pid" 2>/dev/null; then running=$((running + 1)); fi
    kill -9 "$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true
    if got=$(check_result "$out"); then
      echo "  kill $k at ${delay} s (run for atlas $size): complete result, atlas $got"
    else
      echo "  kill $k at ${delay} s (run for atlas $size): BROKEN RESULT: $got"
      fail=1
    fi
  done
  "$montage" run "$work/p1024.json" --out "$out" >/dev/null 2>&1
  left=$(leftovers "$work")
  echo "run: $running of $kills kills hit a running process; after the next run: $(check_result "$out" >/dev/null && echo complete), leftovers: ${left:-none}"
  [[ -z "$left" ]] || fail=1
fi

if [[ $which == save || $which == both ]]; then
  if ! command -v xvfb-run >/dev/null || [[ ! -x $editor ]]; then
    echo "save: skipped (needs xvfb-run and build/bin/texturemontage)"
  else
    # A large project (200 strokes of 2000 vertices: about 10 MB), saved SAVES times with a changing seed.
    python3 - "$work/p1024.json" "$work/big.json" <<'PY'
import json, sys
p = json.load(open(sys.argv[1]))
p["strokes"] = [{"vertices": list(range(k, k + 2000))} for k in range(0, 200)]
json.dump(p, open(sys.argv[2], "w"), indent=2)
PY
    script=$work/save.script
    : >"$script"
    for ((i = 1; i <= saves; i++)); do printf 'set_option seed %d\nsave %s/saved.json\n' "$i" "$work" >>"$script"; done
    echo quit >>"$script"
    run_editor() { (cd "$work" && XDG_STATE_HOME="$work/state" TM_NO_ZENITY=1 xvfb-run -a "$editor" "$work/big.json" --script "$1" >/dev/null 2>&1); }
    # Baseline session: how long the saves take once the first one is on disk (the editor first loads
    # the project and runs its pipeline); kills land in that phase.
    rm -f "$work/saved.json"
    run_editor "$script" &
    until [[ -f "$work/saved.json" ]]; do kill -0 $! 2>/dev/null || { echo "save: the editor never saved"; exit 1; }; sleep 0.05; done
    first=$(date +%s.%N)
    wait
    span=$(echo "$(date +%s.%N) - $first" | bc)
    echo "save: the editor saves $saves times in ${span} s after its first save"
    for ((k = 1; k <= kills; k++)); do
      delay=$(python3 -c "import random; print(round(random.uniform(0, $span), 3))")
      before=$(date -r "$work/saved.json" +%s%N)
      (cd "$work" && XDG_STATE_HOME="$work/state" TM_NO_ZENITY=1 exec xvfb-run -a "$editor" "$work/big.json" --script "$script" >/dev/null 2>&1) &
      session=$!
      # Until the first save of this session (or the editor is gone).
      until [[ $(date -r "$work/saved.json" +%s%N) != "$before" ]] || ! kill -0 "$session" 2>/dev/null; do sleep 0.05; done
      sleep "$delay"
      pid=$(pgrep -f "^$editor $work/big.json" | head -1 || true)  # the editor started just above
      if [[ -n $pid ]]; then kill -9 "$pid" 2>/dev/null || true; fi
      wait 2>/dev/null || true
      seed=$(python3 -c "import json; p=json.load(open('$work/saved.json')); assert p['format']=='texturemontage-project' and len(p['strokes'])==200; print(p['options']['seed'])" 2>&1) ||
        { echo "  kill $k ${delay} s after the first save: BROKEN PROJECT FILE: $seed"; fail=1; continue; }
      echo "  kill $k ${delay} s after the first save: saved.json is complete (version $seed), temporary files now: $(find "$work" -maxdepth 1 -name '.saved.json.tmp-*' | wc -l)"
    done
    printf 'save %s/saved.json\nquit\n' "$work" >"$work/once.script"
    run_editor "$work/once.script"
    left=$(find "$work" -maxdepth 1 -name '.saved.json.tmp-*')
    echo "save: after the next save, leftovers: ${left:-none}"
    [[ -z "$left" ]] || fail=1
  fi
fi
exit $fail
