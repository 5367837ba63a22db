#!/bin/sh
# Acceptance of the seamless tiles (issue 5), release build:
#  - seam ratio (wrap-around / inside neighbour differences, stored encoding, all 81×81 images of
#    the PLM-C model) ≤ 1.25 for a 32² tile of the impalla crop and of 3 synth materials (96²);
#  - a 32² PLM-C tile of a 256² synth sample compresses the sample's 8-bit raw data ≥ 1:200,
#    reported with the MAE of the tile vs its original region.
# Synth samples are measured once into $DATA (default /tmp/btfpt-tiling-data; 256² takes minutes).
# IMPALLA points at the real crop (never committed; skipped if absent). Results go to $OUT.
set -e
cd "$(dirname "$0")/.."
cargo build --release --quiet
B=./target/release/btfpt
DATA=${DATA:-/tmp/btfpt-tiling-data}
OUT=${OUT:-$(mktemp -d)}
IMPALLA=${IMPALLA:-/work/shared/data/ubo2003/impalla-crop64}
mkdir -p "$DATA" "$OUT"
fail=0

# check NAME JSON: prints the figures, fails if the seam ratio is above 1.25
check() {
    python3 - "$1" "$2" <<'EOF' || fail=1
import json, sys
name, path = sys.argv[1], sys.argv[2]
r = json.load(open(path))
t = r.get("tile", {})
s = r["seams"]
print(f"{name:10} seam_ratio {r['seam_ratio']:.3f} (data {s['seam_ratio_data']:.3f}, plain crop "
      f"{s['seam_ratio_crop']:.3f})  PLM-C MAE vs tile {r['models']['plmc']['mae']:.4f}  "
      f"tile vs region {s['region_mae']:.4f}  file {t['file_bytes']} B  "
      f"1:{t['ratio_vs_sample']:.0f} of the {t['sample_w']}x{t['sample_h']} sample")
sys.exit(0 if r["seam_ratio"] <= 1.25 else 1)
EOF
}

run() { # NAME DATA TILE [extra fit args]
    name=$1 data=$2 tile=$3
    shift 3
    $B fit "$data" -o "$OUT/$name.plmc" --model plmc --tile "$tile" "$@" > "$OUT/$name.fit.log" 2>&1
    $B eval "$OUT/$name.plmc" --against "$data" --json "$OUT/$name.json" > "$OUT/$name.eval.log" 2>&1
    $B tile-preview "$OUT/$name.plmc" -o "$OUT/$name-tiles.png" --repeat 4x4 --view 0 --light 0 \
        --zoom 2 > /dev/null
    check "$name" "$OUT/$name.json"
}

if [ -d "$IMPALLA" ]; then
    run impalla "$IMPALLA" 32x32
else
    echo "impalla: $IMPALLA not found, skipped"
fi
for m in leather wood corduroy; do
    [ -d "$DATA/${m}96" ] || $B synth "$m" --size 96 -o "$DATA/${m}96" > /dev/null
    run "$m" "$DATA/${m}96" 32x32
done
run wood-4tiles "$DATA/wood96" 32x32 --tiles 4

[ -d "$DATA/wool256" ] || $B synth wool --size 256 -o "$DATA/wool256" > /dev/null
run wool256 "$DATA/wool256" 32x32
python3 - "$OUT/wool256.json" <<'EOF' || fail=1
import json, sys
t = json.load(open(sys.argv[1]))["tile"]
ok = t["ratio_vs_sample"] >= 200
print(f"compression: 32² tile of the 256² wool: {t['file_bytes']} B vs {t['sample_raw_bytes']} B raw "
      f"= 1:{t['ratio_vs_sample']:.0f} ({'ok' if ok else 'FAIL'}, need ≥ 1:200)")
sys.exit(0 if ok else 1)
EOF
echo "results and previews in $OUT"
[ $fail -eq 0 ] && echo "tiling acceptance: PASS" || { echo "tiling acceptance: FAIL"; exit 1; }
