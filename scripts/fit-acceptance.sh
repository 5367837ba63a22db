#!/bin/sh
# Acceptance run of issue 4, as a new user runs it (release binary): for each synth material
# (64², EXR) and the real impalla crop, `btfpt fit --model plmc --clusters 256 --features 20`
# then `btfpt eval --json --plot`, and one summary table (MAE stored/linear, RMSE, bytes, ratio
# per model) plus fit wall and CPU seconds. CPU seconds / 2 is the wall time on an idle 2-core
# machine (wall time is only meaningful when the machine is not shared).
#
# usage: scripts/fit-acceptance.sh [OUT_DIR]   (default: a new temp dir; materials are kept there)
# env:   MATERIALS="wool corduroy leather"  IMPALLA=/path/to/ubo2003/impalla-crop64 (skipped if absent)
set -eu
cd "$(dirname "$0")/.."
out=${1:-$(mktemp -d "${TMPDIR:-/tmp}/fit-acceptance.XXXXXX")}
mkdir -p "$out"
materials=${MATERIALS:-wool corduroy leather}
impalla=${IMPALLA:-/work/shared/data/ubo2003/impalla-crop64}
cargo build --release --quiet
bin=./target/release/btfpt
echo "output in $out"

run() { # name data
    name=$1
    data=$2
    /usr/bin/time -f "%e %U %S" -o "$out/$name.fit-time" \
        "$bin" fit "$data" -o "$out/$name.plmc" --model plmc --clusters 256 --features 20 \
        >"$out/$name.fit.log" 2>/dev/null
    /usr/bin/time -f "%e %U %S" -o "$out/$name.eval-time" \
        "$bin" eval "$out/$name.plmc" --against "$data" --json "$out/$name.json" \
        --plot "$out/$name.png" >"$out/$name.eval.log" 2>/dev/null
    cat "$out/$name.fit.log" "$out/$name.eval.log"
}

names=""
for m in $materials; do
    if [ ! -d "$out/$m-data" ]; then
        "$bin" synth "$m" --size 64 --format exr -o "$out/$m-data" >/dev/null 2>&1
    fi
    echo "== $m"
    run "$m" "$out/$m-data"
    names="$names $m"
done
if [ -d "$impalla" ]; then
    echo "== impalla"
    run impalla "$impalla"
    names="$names impalla"
fi

echo
echo "material model    MAE  MAE-lin    RMSE     bytes   ratio | fit wall/cpu s | eval wall/cpu s"
for n in $names; do
    fit=$(awk '{printf "%.1f/%.1f", $1, $2 + $3}' "$out/$n.fit-time")
    ev=$(awk '{printf "%.1f/%.1f", $1, $2 + $3}' "$out/$n.eval-time")
    jq -r --arg n "$n" --arg fit "$fit" --arg ev "$ev" '
        .models as $m | ["lm", "plm", "plmc", "pca"][] as $k | $m[$k] |
        "\($n) \($k) \(.mae*1e4|round/1e4) \(.mae_linear*1e4|round/1e4) \(.rmse*1e4|round/1e4) \(.bytes) 1:\(.ratio*10|round/10) | \($fit) | \($ev)"' \
        "$out/$n.json" | column -t
done
