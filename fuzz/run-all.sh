#!/bin/sh
# Runs every fuzz target one after another for SECONDS each (default 600) on the stable toolchain,
# without a sanitizer (Rust bounds checks and debug assertions still trap; ASan mostly adds cost).
# Usage: fuzz/run-all.sh [SECONDS] [TARGET...]     Logs: fuzz/logs/<target>.log
set -u
cd "$(dirname "$0")"
T=${1:-600}
[ $# -gt 0 ] && shift
TARGETS=${*:-"scene_xml mesh_ply mesh_obj ubo2014 plmc btfc image_exr image_png"}
mkdir -p logs
for t in $TARGETS; do
    mkdir -p "corpus/$t"
    RUSTC_BOOTSTRAP=1 cargo fuzz run -s none "$t" "corpus/$t" -- \
        -max_total_time="$T" -rss_limit_mb=2048 -timeout=10 -max_len=65536 \
        > "logs/$t.log" 2>&1
    echo "$t: exit $? $(grep -E '^#[0-9]+.*(DONE|pulse)' "logs/$t.log" | tail -1)"
done
