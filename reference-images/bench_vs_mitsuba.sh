#!/bin/sh
# btfpt (release, 2 threads) vs Mitsuba 3 llvm_ad_rgb on the same scene, 3 interleaved runs each:
# median wall times, their ratio and each renderer's relMSE against the committed reference.
# usage: reference-images/bench_vs_mitsuba.sh SCENE.xml SPP [--runs N] [--threads T] [-D name=value]
# Needs reference-images/setup.sh (the .venv); see bench_vs_mitsuba.py for what is timed.
set -eu
if [ $# -lt 2 ]; then
    echo "usage: $0 SCENE.xml SPP [--runs N] [--threads T] [-D name=value ...]" >&2
    exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
py="$here/.venv/bin/python"
if [ ! -x "$py" ]; then
    echo "$py not found: run reference-images/setup.sh first" >&2
    exit 1
fi
(cd "$root" && cargo build --release --quiet)
exec "$py" "$here/bench_vs_mitsuba.py" "$@" --btfpt "$root/target/release/btfpt"
