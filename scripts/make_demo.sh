#!/usr/bin/env bash
# Regenerates the bundled demo (assets/demo/): the mesh from scripts/demo_mesh.py, then photos,
# correspondences and ground-truth cameras rendered by `montage synth` with the solid pattern.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 scripts/demo_mesh.py assets/demo/demo_mesh.obj
build/bin/montage synth --mesh assets/demo/demo_mesh.obj --views 4 --features 120 --seed 1 --size 768 --out assets/demo
