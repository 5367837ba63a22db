#!/usr/bin/env bash
# Growth with the scene: for each triangle count, a noisy height field (scripts/heightfield_ply.py,
# binary PLY, made here, no downloads) rendered at 128x128, 16 spp under a constant sky, timed as
# a whole process with /usr/bin/time: wall seconds, CPU seconds (user + sys: the figure that
# holds on a shared, loaded machine) and peak resident memory, for the release
# btfpt (with its loading split: reading, BVH build, rest) and, when the reference venv exists,
# Mitsuba 3 (llvm_ad_rgb) on the same scene file. Prints a Markdown table.
# usage: scripts/scaling.sh [TRIANGLES ...]   (default: 10000 100000 1000000 4000000 16000000)
# env:   RUNS=1 (median of RUNS runs per cell), MITSUBA=auto|off, SPP=16,
#        BTFPT=path (a btfpt binary to time instead of building this checkout's),
#        VENV=path (the Mitsuba venv made by reference-images/setup.sh; default the checkout's)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(10000 100000 1000000 4000000 16000000)
runs=${RUNS:-1}
spp=${SPP:-16}
venv=${VENV:-$root/reference-images/.venv}
py=python3
mitsuba=${MITSUBA:-auto}
if [ -x "$venv/bin/python" ]; then
    py=$venv/bin/python   # its numpy makes the generator fast
else
    mitsuba=off
fi
[ -x /usr/bin/time ] || { echo "$0: needs /usr/bin/time (GNU time)" >&2; exit 2; }
bin=${BTFPT:-}
if [ -z "$bin" ]; then
    (cd "$root" && cargo build --release --quiet)
    bin=$root/target/release/btfpt
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
median() { sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
# run NAME CMD...: RUNS runs; sets $wall, $cpu (s) and $peak (MiB), medians; keeps the last log.
run() {
    local name=$1; shift
    local w=() c=() m=()
    for ((r = 0; r < runs; r++)); do
        /usr/bin/time -f "%e %U %S %M" -o "$tmp/$name.time" "$@" > "$tmp/$name.log" 2>&1 || {
            echo "$0: $name failed:" >&2; tail -5 "$tmp/$name.log" >&2; exit 1; }
        read -r a u k b < "$tmp/$name.time"
        w+=("$a"); c+=("$(awk -v u="$u" -v k="$k" 'BEGIN {print u + k}')"); m+=("$b")
    done
    wall=$(printf '%s\n' "${w[@]}" | median)
    cpu=$(printf '%s\n' "${c[@]}" | median)
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
echo "| triangles | btfpt wall / cpu / peak | btfpt load: read + BVH + rest | btfpt bytes/triangle | Mitsuba 3 llvm wall / cpu / peak |"
echo "|---|---|---|---|---|"
for n in "${sizes[@]}"; do
    d=$tmp/hf-$n
    tris=$("$py" "$root/scripts/heightfield_ply.py" "$n" "$d" --spp "$spp")
    run btfpt "$bin" render "$d/scene.xml" -o "$d/btfpt.exr"
    bw=$wall bc=$cpu bp=$peak
    split=$(sed -n 's/.*loaded in \([0-9.]*\) s (reading \([0-9.]*\) s, BVH \([0-9.]*\) s, rest \([0-9.]*\) s).*/\1 s: \2 + \3 + \4/p' "$tmp/btfpt.log")
    per=$(awk -v m="$bp" -v t="$tris" 'BEGIN {printf "%.0f", m * 1048576 / t}')
    mts="—"
    if [ "$mitsuba" != off ]; then
        run mitsuba "$venv/bin/python" "$mts_script" "$d/scene.xml" "$d/mitsuba.exr"
        mts="$wall s / $cpu s / $peak MiB"
    fi
    echo "| $tris | $bw s / $bc s / $bp MiB | $split | $per | $mts |"
    rm -rf "$d"
done
