#!/usr/bin/env bash
# Instancing at scale: a UV sphere of about 100k triangles (binary PLY, written here into a
# temporary folder, nothing committed) in one shapegroup, placed by N instances on a grid
# (default: 1 and 1000), rendered at 64x64, 1 spp under a constant sky. Prints per N the whole
# process's wall and CPU seconds and peak resident memory (/usr/bin/time) and btfpt's own
# loading line (read + BVH + rest) and resident mesh/BVH megabytes: the mesh is stored once, so
# memory must not grow with N.
# usage: scripts/instancing.sh [N ...]   env: BTFPT=path (default: build this checkout's),
#        RINGS=224 SEGMENTS=224 (the sphere: 2·SEGMENTS·(RINGS−1) triangles)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(1 1000)
rings=${RINGS:-224}
segments=${SEGMENTS:-224}
[ -x /usr/bin/time ] || { echo "$0: needs /usr/bin/time (GNU time)" >&2; exit 2; }
bin=${BTFPT:-}
if [ -z "$bin" ]; then
    (cd "$root" && cargo build --release --quiet)
    bin=$root/target/release/btfpt
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 - "$tmp/sphere.ply" "$rings" "$segments" <<'PY'
import math, struct, sys
path, rings, segs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
verts = [(0.0, 0.0, 1.0)]
for r in range(1, rings):
    th = math.pi * r / rings
    for s in range(segs):
        ph = 2 * math.pi * s / segs
        verts.append((math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)))
verts.append((0.0, 0.0, -1.0))
faces = []
ring = lambda r, s: 1 + (r - 1) * segs + s % segs
for s in range(segs):
    faces.append((0, ring(1, s), ring(1, s + 1)))
for r in range(1, rings - 1):
    for s in range(segs):
        a, b, c, d = ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1)
        faces += [(a, c, d), (a, d, b)]
last = len(verts) - 1
for s in range(segs):
    faces.append((last, ring(rings - 1, s + 1), ring(rings - 1, s)))
with open(path, "wb") as f:
    f.write(b"ply\nformat binary_little_endian 1.0\n")
    f.write(b"element vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % len(verts))
    f.write(b"element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(faces))
    f.write(b"".join(struct.pack("<3f", *v) for v in verts))
    f.write(b"".join(struct.pack("<B3i", 3, *t) for t in faces))
print(f"sphere: {len(verts)} vertices, {len(faces)} triangles", file=sys.stderr)
PY
echo "| instances | triangles placed | wall / cpu (s) | peak RSS (MiB) | btfpt load line | btfpt resident |"
echo "|---|---|---|---|---|---|"
tris=$((2 * segments * (rings - 1)))
for n in "${counts[@]}"; do
    scene=$tmp/scene-$n.xml
    python3 - "$scene" "$n" <<'PY'
import math, sys
path, n = sys.argv[1], int(sys.argv[2])
side = math.ceil(n ** (1 / 3))
inst = []
for i in range(n):
    x, y, z = i % side, (i // side) % side, i // (side * side)
    inst.append(f'<shape type="instance"><ref id="g"/><transform name="to_world">'
                f'<scale value="0.4"/><rotate y="1" angle="{(i * 37) % 360}"/>'
                f'<translate x="{x - side / 2}" y="{y - side / 2}" z="{z - side / 2}"/></transform></shape>')
open(path, "w").write(f"""<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="3"/></integrator>
<sensor type="perspective"><float name="fov" value="60"/>
<transform name="to_world"><lookat origin="0, 0, {2.5 * side}" target="0, 0, 0" up="0, 1, 0"/></transform>
<sampler type="independent"><integer name="sample_count" value="1"/></sampler>
<film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="64"/><rfilter type="box"/></film>
</sensor>
<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
<shape type="shapegroup" id="g"><shape type="ply"><string name="filename" value="sphere.ply"/></shape></shape>
{chr(10).join(inst)}
</scene>
""")
PY
    /usr/bin/time -f "%e %U %S %M" -o "$tmp/time" "$bin" render "$scene" -o "$tmp/out-$n.exr" > "$tmp/log" 2>&1 || {
        echo "$0: $n instances failed:" >&2; tail -5 "$tmp/log" >&2; exit 1; }
    read -r wall user sys kib < "$tmp/time"
    load=$(grep -i "load" "$tmp/log" | head -1 | tr -s ' ' | sed 's/|/\\|/g')
    res=$(grep -i "resident\|MiB" "$tmp/log" | head -1 | tr -s ' ' | sed 's/|/\\|/g')
    echo "| $n | $((n * tris)) | $wall / $(awk -v u="$user" -v s="$sys" 'BEGIN {print u + s}') | $((kib / 1024)) | $load | $res |"
done
