#!/bin/sh
# Times `btfpt fit` (PLM-C, default options) on a simulated wool sample and prints the median
# wall and CPU seconds of RUNS runs, plus the load average. With BASE=/path/to/old/btfpt the old
# and the new binary run alternately on the same data, so their medians and the ratio are measured
# side by side under the same load (the machine is shared: compare ratios, and CPU rather than
# wall time).
#
#   scripts/bench_fit.sh [SIZE] [RUNS]          e.g. scripts/bench_fit.sh 64 3
#   BASE=/tmp/btfpt-old scripts/bench_fit.sh 64 3
set -e
cd "$(dirname "$0")/.."
size=${1:-64}
runs=${2:-3}
cargo build --release --quiet
new=$PWD/target/release/btfpt
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$new" synth wool --size "$size" --seed 1 -o "$work/wool" >/dev/null 2>&1
bins="new"
[ -n "$BASE" ] && bins="base new"
i=0
while [ "$i" -lt "$runs" ]; do
    for b in $bins; do
        exe=$new
        [ "$b" = base ] && exe=$BASE
        /usr/bin/time -f "%e %U %S" -o "$work/t" "$exe" fit "$work/wool" -o "$work/$b.plmc" >/dev/null 2>&1
        awk -v b="$b" '{ printf "%s %s %.2f\n", b, $1, $2 + $3 }' "$work/t" >>"$work/times"
        rm -f "$work/$b.plmc"
    done
    i=$((i + 1))
done
median() { sort -n | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
echo "fit of wool ${size}², $runs runs, load average $(cut -d' ' -f1-3 /proc/loadavg)"
for b in $bins; do
    w=$(awk -v b="$b" '$1 == b { print $2 }' "$work/times" | median)
    c=$(awk -v b="$b" '$1 == b { print $3 }' "$work/times" | median)
    echo "$b: median wall $w s, median CPU $c s"
    eval "cpu_$b=$c"
done
[ -n "$BASE" ] && awk -v a="$cpu_base" -v b="$cpu_new" 'BEGIN { printf "CPU ratio new/base: %.3f\n", b / a }'
exit 0
