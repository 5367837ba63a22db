#!/usr/bin/env bash
# Growth with the scene: for each triangle count, a noisy height field (scripts/heightfield_ply.py,
# binary PLY, made here, no downloads) rendered at 128x128, 16 spp under a constant sky, timed as
# a whole process with /usr/bin/time: wall seconds and peak resident memory, for the release
# btfpt (with its loading split: reading, BVH build, rest) and, when the reference venv exists,
# Mitsuba 3 (llvm_ad_rgb) on the same scene file. Prints a Markdown table.
# usage: scripts/scaling.sh [TRIANGLES ...]   (default: 10000 100000 1000000 4000000 16000000)
# env:   RUNS=1 (median of RUNS runs per cell), MITSUBA=auto|off, SPP=16
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(10000 100000 1000000 4000000 16000000)
runs=${RUNS:-1}
spp=${SPP:-16}
venv=$root/reference-images/.venv
py=python3
mitsuba=${MITSUBA:-auto}
if [ -x "$venv/bin/python" ]; then
    py=$venv/bin/python   # its numpy makes the generator fast
else
    mitsuba=off
fi
[ -x /usr/bin/time ] || { echo "$0: needs /usr/bin/time (GNU time)" >&2; exit 2; }
(cd "$root" && cargo build --release --quiet)
bin=$root/target/release/btfpt
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
# run NAME CMD...: RUNS runs; sets $wall (s) and $peak (MiB), medians; keeps the last run's log.
run() {
    local name=$1; shift
    local w=() m=()
    for ((r = 0; r < runs; r++)); do
        /usr/bin/time -f "%e %M" -o "$tmp/$name.time" "$@" > "$tmp/$name.log" 2>&1 || {
            echo "$0: $name failed:" >&2; tail -5 "$tmp/$name.log" >&2; exit 1; }
        read -r a b < "$tmp/$name.time"
        w+=("$a"); m+=("$b")
    done
    wall=$(printf '%s\n' "${w[@]}" | median)
    peak=$(printf '%s\n' "${m[@]}" | median | awk '{printf "%.0f", $1 / 1024}')
}
mts_script=$tmp/mitsuba_render.py
cat > "$mts_script" <<'PY'
import sys
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
scene = mi.load_file(sys.argv[1])
img = mi.render(scene)
mi.Bitmap(img).write(sys.argv[2])
PY
echo "| triangles | btfpt wall / peak | btfpt load: read + BVH + rest | bytes/triangle | Mitsuba 3 llvm wall / peak |"
echo "|---|---|---|---|---|"
for n in "${sizes[@]}"; do
    d=$tmp/hf-$n
    tris=$("$py" "$root/scripts/heightfield_ply.py" "$n" "$d" --spp "$spp")
    run btfpt "$bin" render "$d/scene.xml" -o "$d/btfpt.exr"
    bw=$wall bp=$peak
    split=$(sed -n 's/.*loaded in \([0-9.]*\) s (reading \([0-9.]*\) s, BVH \([0-9.]*\) s, rest \([0-9.]*\) s).*/\1 s: \2 + \3 + \4/p' "$tmp/btfpt.log")
    per=$(awk -v m="$bp" -v t="$tris" 'BEGIN {printf "%.0f", m * 1048576 / t}')
    mts="—"
    if [ "$mitsuba" != off ]; then
        run mitsuba "$venv/bin/python" "$mts_script" "$d/scene.xml" "$d/mitsuba.exr"
        mts="$wall s / $peak MiB"
    fi
    echo "| $tris | $bw s / $bp MiB | $split | $per | $mts |"
    rm -rf "$d"
done
