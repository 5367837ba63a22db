#!/bin/sh
# Runs `btfpt fit ARGS` and reports its wall and CPU time and its peak memory split into
# anonymous memory (what the fit allocates: decoded views, buffers) and file-backed pages (the
# memory-mapped .btfc cache, reclaimable page cache), sampled from /proc every 0.2 s, beside
# /usr/bin/time's max RSS (which counts both).
#
#   scripts/fit_memory.sh w14.btfc -o w14.plmc
set -e
exe=${BTFPT:-$(dirname "$0")/../target/release/btfpt}
log=$(mktemp)
trap 'rm -f "$log"' EXIT
/usr/bin/time -f "%e %U %S %M" -o "$log" "$exe" fit "$@" &
tpid=$!
sleep 0.2
pid=$(pgrep -P "$tpid" | head -n 1)
anon=0
file=0
while kill -0 "$tpid" 2>/dev/null; do
    if [ -n "$pid" ] && [ -r "/proc/$pid/status" ]; then
        a=$(awk '/^RssAnon:/ { print $2 }' "/proc/$pid/status" 2>/dev/null || echo 0)
        f=$(awk '/^RssFile:/ { print $2 }' "/proc/$pid/status" 2>/dev/null || echo 0)
        [ "${a:-0}" -gt "$anon" ] && anon=$a
        [ "${f:-0}" -gt "$file" ] && file=$f
    fi
    sleep 0.2
done
wait "$tpid"
read -r wall user sys maxrss <"$log"
echo "wall $wall s, CPU $(echo "$user $sys" | awk '{ print $1 + $2 }') s, load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "max RSS $((maxrss / 1024)) MiB; peak anonymous $((anon / 1024)) MiB, peak file-backed (mapped cache) $((file / 1024)) MiB"
