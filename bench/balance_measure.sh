#!/usr/bin/env bash
# Colour balance measurements for docs/pipeline.md ("Balance"): on synthetic scenes whose photos were
# taken at different exposures (photo 0 locked), seam Delta E between photos and covered PSNR with
# balance off / on and levelling off / on, against the same scene at equal exposure.
#   bench/balance_measure.sh [MESH_NAME...]   (spot bob; needs ../shared/data and build/bin/montage)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
montage=$root/build/bin/montage
data=$root/../shared/data/meshes
work=${TM_WORK:-/tmp/tm_balance_measure}
exposure=${TM_EXPOSURE:-1,0.55,1.3,0.8}
features=${TM_FEATURES:-150}
searches=${TM_SEARCHES:-4}
mkdir -p "$work"
meshes=("$@")
[[ ${#meshes[@]} -gt 0 ]] || meshes=(spot bob)

# set_options PROJECT OUT BALANCE LEVEL: a copy of the project with photo 0 locked and the two options set.
set_options() {
  python3 - "$1" "$2" "$3" "$4" "$searches" <<'PY'
import json, sys
src, out, balance, level, searches = sys.argv[1:]
p = json.load(open(src))
p["version"] = 3
p["photos"][0]["colorLocked"] = True
p.setdefault("options", {})
p["options"]["colorBalance"] = balance
p["options"]["seamLevelling"] = level
p["options"]["stretchSearches"] = int(searches)
p["options"]["exportTopology"] = "refined"  # a source per face: montage eval's photo-seam figures need it
json.dump(p, open(out, "w"), indent=2)
PY
}

for name in "${meshes[@]}"; do
  case $name in
    spot) mesh=$data/spot/spot_triangulated.obj; tex=$data/spot/spot_texture.png ;;
    bob) mesh=$data/bob/bob_tri.obj; tex=$data/bob/bob_diffuse.png ;;
    *) echo "unknown mesh $name"; exit 2 ;;
  esac
  for scene in equal exposed; do
    args=()
    [[ $scene == exposed ]] && args=(--exposure "$exposure")
    "$montage" synth --mesh "$mesh" --texture "$tex" --views 4 --features "$features" --seed 1 "${args[@]}" \
      --out "$work/$name-$scene" >/dev/null 2>&1
  done
  printf '%-6s %-8s %-12s %-7s %10s %12s %14s\n' mesh scene balance level "seam dE" "PSNR cov" "balance s"
  for scene in equal exposed; do
    for balance in off gain-offset; do
      for level in off vertex; do
        dir=$work/$name-$scene/run-$balance-$level
        set_options "$work/$name-$scene/project.json" "$work/$name-$scene/p-$balance-$level.json" $balance $level
        "$montage" run "$work/$name-$scene/p-$balance-$level.json" --out "$dir" >"$dir.log" 2>&1  # montage run replaces $dir as a whole
        "$montage" eval --result "$dir/model.obj" --truth "$mesh" --truth-texture "$tex" --json "$dir/eval.json" >/dev/null
        python3 - "$dir" "$name" "$scene" "$balance" "$level" <<'PY'
import json, sys
d, name, scene, balance, level = sys.argv[1:]
e = json.load(open(d + "/eval.json"))
r = json.load(open(d + "/report.json"))
b = [s for s in r["stages"] if s["stage"] == "balance"][0]
print("%-6s %-8s %-12s %-7s %10.2f %12.2f %14.3f" % (name, scene, balance, level, e["photo_seam_mismatch"],
      e["psnr_covered"], b["seconds"]))
PY
      done
    done
  done
done
