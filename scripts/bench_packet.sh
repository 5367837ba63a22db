#!/usr/bin/env bash
# Packet vs scalar integrator, side by side in one run: the release binary renders SCENE with
# `--integrator scalar`, `packet` (refill on) and `packet --packet-refill off`, interleaved, RUNS
# times each, one thread; prints the median render-only CPU seconds (getrusage, as `btfpt render`
# reports them, so other processes on a shared machine do not count), the ratios to scalar and
# the packet integrator's lane utilisation.
# usage: scripts/bench_packet.sh SCENE.xml SPP [RUNS=3] [THREADS=1] [extra btfpt args...]
set -euo pipefail
if [ $# -lt 2 ]; then
    echo "usage: $0 SCENE.xml SPP [RUNS] [THREADS] [btfpt args...]" >&2
    exit 2
fi
scene=$1 spp=$2 runs=${3:-3} threads=${4:-1}
shift $(( $# < 4 ? $# : 4 ))
root=$(cd "$(dirname "$0")/.." && pwd)
(cd "$root" && cargo build --release --quiet)
bin=$root/target/release/btfpt
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
declare -A cpu
modes=(scalar packet packet-norefill)
for ((r = 0; r < runs; r++)); do
    for m in "${modes[@]}"; do
        case $m in
            scalar) a=(--integrator scalar) ;;
            packet) a=(--integrator packet) ;;
            packet-norefill) a=(--integrator packet --packet-refill off) ;;
        esac
        "$bin" render "$scene" --spp "$spp" --threads "$threads" --seed "$r" -o "$tmp/$m.exr" \
            "${a[@]}" "$@" 2> "$tmp/$m.log"
        c=$(sed -n 's/.*(cpu \([0-9.]*\) s).*/\1/p' "$tmp/$m.log")
        cpu[$m]="${cpu[$m]:-} $c"
        if [ "$r" = 0 ] && [ "$m" != scalar ]; then
            echo "$m: $(grep 'lane utilisation' "$tmp/$m.log")"
        fi
    done
done
median() { tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END {print (NR%2) ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2}'; }
s=$(echo "${cpu[scalar]}" | median)
echo "$(basename "$(dirname "$scene")") $spp spp, $threads thread(s), $runs runs, render-only CPU s (median):"
for m in "${modes[@]}"; do
    v=$(echo "${cpu[$m]}" | median)
    printf '  %-16s %7.3f s  runs:%s  scalar/this %.3f\n' "$m" "$v" "${cpu[$m]}" "$(echo "$s / $v" | bc -l)"
done
