#!/usr/bin/env bash
# Re-renders every committed reference (run setup.sh first). About 15-20 min wall on 2 cores.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
py="$here/.venv/bin/python"
spp="${SPP:-16384}"
"$py" "$here/render.py" "$here/../scenes/cornell-box/scene.xml" --spp "$spp"
"$py" "$here/render.py" "$here/../scenes/cornell-box-all/scene.xml" --spp "$spp"
"$py" "$here/render.py" "$here/../scenes/cornell-box-all/scene-constant.xml" --spp "$spp"
# afterwards refresh the test bounds: calibrate.py on each scene (rewrites <name>_calibration.json)
