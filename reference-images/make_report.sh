#!/bin/sh
# Regenerates reference-images/REPORT.md and reference-images/report/ in one run: btfpt (raw BTF and
# the fitted LM/PLM/PLM-C models) and Mitsuba 3 side by side against the committed references.
# usage: reference-images/make_report.sh [--spp 64] [--hi-spp 1024] [--threads 2] [--only NAME]
#        [--sections plugin] [--plugin-size 128]  (make_report.py --help: the rest)
# About 10 min wall on 2 shared cores. Needs reference-images/setup.sh (run here if the .venv is missing).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
py="$here/.venv/bin/python"
if [ ! -x "$py" ]; then
    "$here/setup.sh"
fi
(cd "$root" && cargo build --release --quiet)
# The btfpt module (python/) into the same venv, for the section of Mitsuba with btfpt's plugin.
"$here/.venv/bin/pip" install --quiet --disable-pip-version-check "maturin==1.16.0"
(cd "$root" && VIRTUAL_ENV="$here/.venv" PATH="$here/.venv/bin:$PATH" "$here/.venv/bin/maturin" develop --release --quiet)
exec nice -n 5 "$py" "$here/make_report.py" --btfpt "$root/target/release/btfpt" "$@"
