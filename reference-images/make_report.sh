#!/bin/sh
# Regenerates reference-images/REPORT.md and reference-images/report/ in one run: btfpt (raw BTF and
# the fitted LM/PLM/PLM-C models) and Mitsuba 3 side by side against the committed references.
# usage: reference-images/make_report.sh [--spp 64] [--hi-spp 1024] [--threads 2] [--only NAME]
# About 10 min wall on 2 shared cores. Needs reference-images/setup.sh (run here if the .venv is missing).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
py="$here/.venv/bin/python"
if [ ! -x "$py" ]; then
    "$here/setup.sh"
fi
(cd "$root" && cargo build --release --quiet)
exec nice -n 5 "$py" "$here/make_report.py" --btfpt "$root/target/release/btfpt" "$@"
