#!/usr/bin/env bash
# Rebuilds the showcase materials: each is measured by btfpt's virtual gonioreflectometer
# (btfpt synth, 64² texels, 81 × 81 UBO2003 directions, EXR) and fitted to PLM-C (btfpt fit).
# With the argument "all" it also keeps the raw data (as a .btfc cache, for render's btf-model
# raw option) and fits LM and PLM (NAME.lm.plmc, NAME.plm.plmc); those are large and not committed.
# Usage: scenes/showcase/materials/make_materials.sh [all]      (takes ~5 min per material)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
btfpt="$root/target/release/btfpt"
[ -x "$btfpt" ] || (cd "$root" && cargo build --release)
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
for m in leather wood foil corduroy; do
    "$btfpt" synth "$m" --size 64 --format exr -o "$tmp/$m"
    "$btfpt" fit "$tmp/$m" --model plmc -o "$here/$m.plmc"
    if [ "${1:-}" = all ]; then
        "$btfpt" convert "$tmp/$m" "$here/$m.btfc"
        "$btfpt" fit "$tmp/$m" --model lm -o "$here/$m.lm.plmc"
        "$btfpt" fit "$tmp/$m" --model plm -o "$here/$m.plm.plmc"
    fi
    rm -rf "$tmp/$m"
done
