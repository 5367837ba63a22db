use super::*;
use crate::math::Pcg32;

const NV: usize = 300;
const NT: usize = 500;

/// A buffer with positions and normals interleaved (stride 24), f32 uvs, u16, u8 and u32
/// indices and normalized-u16 uvs, and the glTF JSON describing them; `count` is what the
/// POSITION accessor declares and `index_count` what the u16 index accessor declares.
fn document(count: usize, index_count: u64) -> (::gltf::Document, Vec<Data>, Vec<f32>, Vec<u32>) {
    let mut rng = Pcg32::new(9, 4);
    let floats: Vec<f32> = (0..NV * 8).map(|_| rng.next_f32() * 2.0 - 1.0).collect();
    let tris: Vec<u32> = (0..NT * 3).map(|_| rng.next_below(NV as u32)).collect();
    let mut b: Vec<u8> = Vec::new();
    for i in 0..NV {
        for k in 0..6 {
            b.extend_from_slice(&floats[i * 8 + k].to_le_bytes());
        }
    }
    let uv_at = b.len();
    for i in 0..NV {
        for k in 6..8 {
            b.extend_from_slice(&floats[i * 8 + k].to_le_bytes());
        }
    }
    let u16_at = b.len();
    for &t in &tris {
        b.extend_from_slice(&(t as u16).to_le_bytes());
    }
    let u8_at = b.len();
    for &t in &tris {
        b.push((t % 256) as u8);
    }
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let u32_at = b.len();
    for &t in &tris {
        b.extend_from_slice(&t.to_le_bytes());
    }
    let n16_at = b.len();
    for i in 0..NV * 2 {
        b.extend_from_slice(&((i * 97 % 65536) as u16).to_le_bytes());
    }
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "buffers": [{{"uri": "mesh.bin", "byteLength": {len}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": {il}, "byteStride": 24}},
    {{"buffer": 0, "byteOffset": {uv_at}, "byteLength": {uvl}}},
    {{"buffer": 0, "byteOffset": {u16_at}, "byteLength": {l16}}},
    {{"buffer": 0, "byteOffset": {u8_at}, "byteLength": {l8}}},
    {{"buffer": 0, "byteOffset": {u32_at}, "byteLength": {l32}}},
    {{"buffer": 0, "byteOffset": {n16_at}, "byteLength": {ln16}}}
  ],
  "accessors": [
    {{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": {count}, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1]}},
    {{"bufferView": 0, "byteOffset": 12, "componentType": 5126, "count": {NV}, "type": "VEC3"}},
    {{"bufferView": 1, "componentType": 5126, "count": {NV}, "type": "VEC2"}},
    {{"bufferView": 2, "componentType": 5123, "count": {index_count}, "type": "SCALAR"}},
    {{"bufferView": 3, "componentType": 5121, "count": {ni}, "type": "SCALAR"}},
    {{"bufferView": 4, "componentType": 5125, "count": {ni}, "type": "SCALAR"}},
    {{"bufferView": 5, "componentType": 5123, "normalized": true, "count": {NV}, "type": "VEC2"}}
  ],
  "meshes": [{{"primitives": [
    {{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3}},
    {{"attributes": {{"POSITION": 0, "TEXCOORD_0": 6}}, "indices": 4}},
    {{"attributes": {{"POSITION": 0, "NORMAL": 1}}, "indices": 5}},
    {{"attributes": {{"POSITION": 0}}}}
  ]}}]
}}"#,
        len = b.len(),
        il = NV * 24,
        uvl = NV * 8,
        l16 = NT * 6,
        l8 = NT * 3,
        l32 = NT * 12,
        ln16 = NV * 4,
        ni = NT * 3,
    );
    let doc = ::gltf::Gltf::from_slice(json.as_bytes()).unwrap().document;
    (doc, vec![Data(b)], floats, tris)
}

#[test]
fn parallel_decoding_gives_the_meshes_the_crate_reader_gives() {
    let (doc, buffers, floats, tris) = document(NV, (NT * 3) as u64);
    let mesh = doc.meshes().next().unwrap();
    for prim in mesh.primitives() {
        for mirror in [false, true] {
            let want = read_with(&prim, &buffers, mirror, None, false).unwrap();
            let got = read_with(&prim, &buffers, mirror, None, true).unwrap();
            assert_eq!(got.positions, want.positions);
            assert_eq!(got.normals, want.normals);
            assert_eq!(got.uvs, want.uvs);
            assert_eq!(got.indices, want.indices);
            assert_eq!(got.positions.len(), NV);
        }
    }
    // And both give the values written.
    let prim = mesh.primitives().next().unwrap();
    let m = read(&prim, &buffers, true, None).unwrap();
    assert_eq!(
        m.positions[7],
        Vec3::new(floats[56], floats[57], floats[58])
    );
    assert_eq!(m.normals[7], Vec3::new(floats[59], floats[60], floats[61]));
    assert_eq!(m.uvs[7], Vec2::new(floats[62], floats[63]));
    assert_eq!(m.indices[4], [tris[12], tris[14], tris[13]]);
    let unindexed = read(&mesh.primitives().nth(3).unwrap(), &buffers, false, None).unwrap();
    assert_eq!(unindexed.indices.len(), NV / 3);
    assert_eq!(unindexed.indices[2], [6, 7, 8]);
}

/// The error `read` gives for the first primitive of `doc`'s first mesh.
fn first_error(doc: &::gltf::Document, buffers: &[Data], avail: Option<u64>) -> String {
    let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
    read(&prim, buffers, false, avail).unwrap_err()
}

#[test]
fn lying_or_huge_counts_fail_before_allocating() {
    let (doc, buffers, ..) = document(1_000_000, (NT * 3) as u64);
    let e = first_error(&doc, &buffers, None);
    assert!(
        e.contains("declares 1000000 elements") && e.contains("POSITION"),
        "{e}"
    );
    let (doc, buffers, ..) = document(NV, 1 << 31);
    let e = first_error(&doc, &buffers, None);
    assert!(e.contains("2^31"), "{e}");
    let (doc, buffers, ..) = document(NV, (NT * 3 + 3) as u64);
    let e = first_error(&doc, &buffers, None);
    assert!(e.contains("(indices) declares"), "{e}");
    let (doc, buffers, ..) = document(NV, (NT * 3) as u64);
    let e = first_error(&doc, &buffers, Some(1000));
    assert!(e.contains("memory is available"), "{e}");
    // A buffer shorter than its views.
    let short = vec![Data(buffers[0].0[..100].to_vec())];
    let e = first_error(&doc, &short, None);
    assert!(e.contains("past the end of its buffer"), "{e}");
}

#[test]
fn a_lying_count_in_a_file_names_the_file() {
    let (_, buffers, ..) = document(NV, (NT * 3) as u64);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.bin"), &buffers[0].0).unwrap();
    // The same document as `document(1_000_000, ..)`, with a scene, a node and a camera.
    let gltf = dir.path().join("liar.gltf");
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}],
  "buffers": [{{"uri": "mesh.bin", "byteLength": {len}}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {il}, "byteStride": 24}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 1000000, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}]}}"#,
        len = buffers[0].0.len(),
        il = NV * 24
    );
    std::fs::write(&gltf, json).unwrap();
    let e = crate::scene::gltf::load(&gltf, &Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("liar.gltf") && e.contains("1000000"), "{e}");
}
