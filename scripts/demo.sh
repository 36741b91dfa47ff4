#!/usr/bin/env bash
# Command (1) of the README: installs what is missing, builds, and runs the bundled demo.
# With a display and the editor built, it opens the editor on the demo project; otherwise it runs
# the pipeline headless and writes the result, plus a rendered preview, under out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
project=assets/demo/project.json
if [[ -n "${DISPLAY:-}" && -x build/bin/texturemontage && -z "${TM_HEADLESS:-}" ]]; then
  exec build/bin/texturemontage "$project"
fi
build/bin/montage run "$project" --out out/demo
build/bin/montage render out/demo/model.glb --yaw 90 --pitch 10 --size 1024x768 --out out/demo/preview.png
build/bin/montage render out/demo/model.glb --turntable 8 --pitch 10 --size 400 --out out/demo/turntable.png
build/bin/montage render out/demo/model.obj --layer --turntable 4 --yaw 90 --pitch 10 --size 400 \
  --out out/demo/layer.png
echo "demo: results in out/demo/ (model.obj, model.glb, report.json, preview.png, turntable.png, layer.png)"
