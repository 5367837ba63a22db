#!/usr/bin/env bash
# Two btfpt binaries side by side on one scene (say main's and a branch's): renders SCENE with A
# and B alternately (A B A B …), RUNS times each, and prints each one's median render-only CPU
# seconds (getrusage, as `btfpt render` reports them, so other processes on a shared machine do
# not count), every run, and the pairwise ratios A/B with their median.
# usage: scripts/bench_ab.sh BIN_A BIN_B SCENE.xml SPP [RUNS=5] [THREADS=1] [btfpt args...]
set -euo pipefail
if [ $# -lt 4 ]; then
    echo "usage: $0 BIN_A BIN_B SCENE.xml SPP [RUNS] [THREADS] [btfpt args...]" >&2
    exit 2
fi
a=$1 b=$2 scene=$3 spp=$4 runs=${5:-5} threads=${6:-1}
shift $(( $# < 6 ? $# : 6 ))
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cpu() {
    "$1" render "$scene" --spp "$spp" --threads "$threads" -o "$tmp/out.exr" "${@:2}" 2> "$tmp/log"
    sed -n 's/.*(cpu \([0-9.]*\) s).*/\1/p' "$tmp/log"
}
ca="" cb="" ratios=""
for ((r = 0; r < runs; r++)); do
    x=$(cpu "$a" "$@")
    y=$(cpu "$b" "$@")
    ca="$ca $x" cb="$cb $y" ratios="$ratios $(echo "$x / $y" | bc -l)"
done
median() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
echo "$(basename "$scene") $spp spp, $threads thread(s), $runs alternated runs, render-only CPU s:"
printf '  A %-40s median %7.3f  runs:%s\n' "$a" "$(echo "$ca" | median)" "$ca"
printf '  B %-40s median %7.3f  runs:%s\n' "$b" "$(echo "$cb" | median)" "$cb"
printf '  A/B median of pairwise ratios %.3f\n' "$(echo "$ratios" | median)"
