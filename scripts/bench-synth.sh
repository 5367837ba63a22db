#!/bin/sh
# Times a full 64² × 81 × 81 synth measurement per material (release build). Reports wall and
# CPU seconds; CPU seconds / 2 is the wall time on an idle 2-core machine. The UBO2003 write step
# runs after the timed measurement (its own cost is not included in the "in N s" line).
set -e
cd "$(dirname "$0")/.."
cargo build --release --quiet
out=$(mktemp -d)
for m in ${*:-wool corduroy leather wood foil}; do
    /usr/bin/time -f "$m: wall %e s, cpu %U s" ./target/release/btfpt synth "$m" --size 64 \
        --format exr -o "$out/$m" 2>&1 | grep -E "^synth|wall" || true
done
rm -rf "$out"
