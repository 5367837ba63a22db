//! A glTF 2.0 file built by the test (hand-written JSON, base64 data-URI buffer), loaded into the
//! expected `Scene`.

use btfpt::bsdf::{Bsdf, Texture};
use btfpt::io::{RgbImage, write_png_srgb};
use btfpt::math::{Vec2, Vec3};
use btfpt::render::camera::ProjectiveCamera;
use btfpt::scene::{self, Emitter, LoadOptions};

fn base64(data: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in data.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= c.len() {
                s.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-4
}

fn gltf_json(buffer: &[u8]) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [
      {{"type": "point", "color": [1, 0.5, 0.25], "intensity": 4}},
      {{"type": "spot", "intensity": 2, "spot": {{"innerConeAngle": 0.2, "outerConeAngle": 0.4}}}},
      {{"type": "directional", "intensity": 3}}
  ]}}}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 1, 2, 3, 4, 5]}}],
  "nodes": [
    {{"camera": 0, "translation": [0, 0, 5]}},
    {{"mesh": 0, "translation": [1, 0, 0], "scale": [2, 2, 2]}},
    {{"mesh": 1, "translation": [0, 3, 0]}},
    {{"extensions": {{"KHR_lights_punctual": {{"light": 0}}}}, "translation": [0, 4, 0]}},
    {{"extensions": {{"KHR_lights_punctual": {{"light": 1}}}}, "rotation": [-0.70710677, 0, 0, 0.70710677]}},
    {{"extensions": {{"KHR_lights_punctual": {{"light": 2}}}}}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.8, "aspectRatio": 2.0, "znear": 0.05}}}}],
  "meshes": [
    {{"name": "tri", "primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "material": 0}}]}},
    {{"name": "lamp", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 3, "material": 1}}]}}
  ],
  "materials": [
    {{"pbrMetallicRoughness": {{"baseColorFactor": [0.5, 1, 1, 1], "baseColorTexture": {{"index": 0}}, "metallicFactor": 0}}}},
    {{"pbrMetallicRoughness": {{"baseColorFactor": [0.9, 0.8, 0.7, 1], "metallicFactor": 1, "roughnessFactor": 0.5}},
      "doubleSided": true, "emissiveFactor": [1, 0.5, 0.25],
      "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 4}}}}}}
  ],
  "textures": [{{"source": 0}}],
  "images": [{{"uri": "tex.png"}}],
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{b64}"}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 36}},
    {{"buffer": 0, "byteOffset": 36, "byteLength": 36}},
    {{"buffer": 0, "byteOffset": 72, "byteLength": 24}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 6}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}},
    {{"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"}}
  ]
}}"#,
        len = buffer.len(),
        b64 = base64(buffer)
    )
}

fn buffer() -> Vec<u8> {
    let mut b = Vec::new();
    let f =
        |b: &mut Vec<u8>, v: &[f32]| v.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
    f(&mut b, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    f(&mut b, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    f(&mut b, &[0.0, 0.0, 1.0, 0.0, 0.0, 0.5]);
    for i in [0u16, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b.extend_from_slice(&[0, 0]);
    b
}

#[test]
fn gltf_scene_maps_to_expected_values() {
    let dir = tempfile::tempdir().unwrap();
    let mut tex = RgbImage::new(2, 2);
    tex.set(1, 0, [1.0, 1.0, 1.0]);
    write_png_srgb(&dir.path().join("tex.png"), &tex).unwrap();
    let p = dir.path().join("s.gltf");
    std::fs::write(&p, gltf_json(&buffer())).unwrap();
    let s = scene::load(
        &p,
        &LoadOptions::with_defines(&[("width".into(), "200".into()), ("spp".into(), "8".into())]),
    )
    .unwrap();

    assert_eq!(s.spp, 8);
    let c = &s.camera;
    assert_eq!(
        (c.width, c.height),
        (200, 100),
        "height from the camera's aspectRatio"
    );
    let expect = 2.0 * ((0.4f32).tan() * 2.0).atan();
    assert!((c.fov_x_deg.to_radians() - expect).abs() < 1e-5);
    assert!((c.near_clip - 0.05).abs() < 1e-7);
    // The renderer's camera, built from what the loader produced; rays start on the near plane.
    let rc = ProjectiveCamera::new(c).unwrap();
    let (o, d, _) = rc.ray(100.0, 50.0);
    assert!(
        close(o, Vec3::new(0.0, 0.0, 4.95)) && close(d, -Vec3::Z),
        "{o:?} {d:?}"
    );
    // glTF +x is to the right: the left image edge must see world −x
    let (_, d, _) = rc.ray(0.0, 50.0);
    assert!(d.x < -0.5, "{d:?}");
    let (_, d, _) = rc.ray(100.0, 0.0);
    assert!(d.y > 0.3, "{d:?}");

    assert_eq!(s.meshes.len(), 2);
    let tri = &s.meshes[0];
    assert_eq!(tri.name, "tri");
    assert!(close(tri.positions[1], Vec3::new(3.0, 0.0, 0.0)));
    assert_eq!(
        tri.uvs[2],
        Vec2::new(0.0, 0.5),
        "glTF uvs are used as stored"
    );
    assert!(close(tri.normals[0], Vec3::Z));
    match &s.bsdfs[tri.bsdf as usize] {
        Bsdf::Diffuse(dif) => match &dif.reflectance {
            Texture::Bitmap(img) => {
                // white texel × base colour factor (0.5, 1, 1)
                let px = img.get(1, 0);
                assert!(
                    (px[0] - 0.5).abs() < 1e-3 && (px[1] - 1.0).abs() < 1e-3,
                    "{px:?}"
                );
            }
            t => panic!("{t:?}"),
        },
        b => panic!("{b:?}"),
    }
    let lamp = &s.meshes[1];
    assert!(lamp.normals.is_empty(), "no NORMAL → flat normals");
    assert_eq!(lamp.emitter, Some(Vec3::new(4.0, 2.0, 1.0)));
    match &s.bsdfs[lamp.bsdf as usize] {
        Bsdf::TwoSided(t) => match &*t.front {
            Bsdf::RoughConductor(r) => {
                let uv = Vec2::ZERO;
                let (au, av) = (r.alpha_u.eval_1(uv), r.alpha_v.eval_1(uv));
                assert!((au - 0.25).abs() < 1e-6 && au == av);
                assert!(
                    matches!(r.specular_reflectance, Texture::Constant(v) if close(v, Vec3::new(0.9, 0.8, 0.7)))
                );
            }
            b => panic!("{b:?}"),
        },
        b => panic!("{b:?}"),
    }

    assert_eq!(s.emitters.len(), 3);
    assert!(
        matches!(s.emitters[0], Emitter::Point { position, intensity }
        if close(position, Vec3::new(0.0, 4.0, 0.0)) && close(intensity, Vec3::new(4.0, 2.0, 1.0)))
    );
    match &s.emitters[1] {
        Emitter::Spot {
            to_world,
            cutoff_angle,
            beam_width,
            intensity,
            ..
        } => {
            // rotation −90° about x turns −z into −y: the spot shines down
            assert!(close(to_world.transform_vector3(Vec3::Z), -Vec3::Y));
            assert!((cutoff_angle - 0.4f32.to_degrees()).abs() < 1e-4);
            assert!((beam_width - 0.2f32.to_degrees()).abs() < 1e-4);
            assert_eq!(*intensity, Vec3::splat(2.0));
        }
        e => panic!("{e:?}"),
    }
    assert!(
        matches!(s.emitters[2], Emitter::Directional { direction, irradiance }
        if close(direction, -Vec3::Z) && irradiance == Vec3::splat(3.0))
    );
}

/// An emissive texture times the emissive factor (and strength) becomes the lamp's radiance
/// texture; the mesh's constant radiance is then 1.
#[test]
fn gltf_emissive_texture_scales_the_emissive_factor() {
    let dir = tempfile::tempdir().unwrap();
    let mut tex = RgbImage::new(2, 2);
    tex.set(1, 0, [1.0, 1.0, 1.0]);
    write_png_srgb(&dir.path().join("tex.png"), &tex).unwrap();
    let p = dir.path().join("s.gltf");
    let json = gltf_json(&buffer()).replace(
        r#""emissiveFactor": [1, 0.5, 0.25],"#,
        r#""emissiveFactor": [1, 0.5, 0.25], "emissiveTexture": {"index": 0},"#,
    );
    assert!(json.contains("emissiveTexture"));
    std::fs::write(&p, json).unwrap();
    let s = scene::load(&p, &LoadOptions::default()).unwrap();
    assert_eq!(s.meshes[1].emitter, Some(Vec3::ONE));
    match s.emission_textures.as_slice() {
        [(1, Texture::Bitmap(img))] => {
            assert!(close(Vec3::from(img.get(1, 0)), Vec3::new(4.0, 2.0, 1.0)));
            assert_eq!(img.get(0, 0), [0.0; 3]);
        }
        t => panic!("{t:?}"),
    }
}

#[test]
fn gltf_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.gltf");
    std::fs::write(&p, "{ not json").unwrap();
    let e = scene::load(&p, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.gltf"), "{e}");
    let p = dir.path().join("nocam.gltf");
    std::fs::write(
        &p,
        r#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": []}]}"#,
    )
    .unwrap();
    let e = scene::load(&p, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("nocam.gltf") && e.contains("camera"), "{e}");
    let e = scene::load(
        &p,
        &LoadOptions::with_defines(&[("bogus".into(), "1".into())]),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("bogus"), "{e}");
    let e = scene::load(&dir.path().join("missing.glb"), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.glb"), "{e}");
}
