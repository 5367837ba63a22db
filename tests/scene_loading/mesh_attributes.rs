//! `mesh_attribute` textures over PLY attributes: the attribute names and grouping Mitsuba
//! 3.9.1 gives a PLY's extra fields, their values at a hit (vertex attributes interpolated,
//! face attributes constant, integer colours kept as their values, as Mitsuba keeps them), and the
//! errors for a missing attribute, a bad name and a place that cannot look it up.

use crate::common::attributed_grid_ply;
use crate::fixtures::{load, load_err};
use btfpt::bsdf::{Bsdf, Texture};
use btfpt::geometry::SurfaceInteraction;
use btfpt::math::{Vec2, Vec3};
use std::path::Path;

fn scene(dir: &Path, name: &str, shapes: &str) -> std::path::PathBuf {
    std::fs::write(dir.join("grid.ply"), attributed_grid_ply(2)).unwrap();
    let p = dir.join(name);
    std::fs::write(
        &p,
        format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\">\
             <integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"/></film>\
             </sensor>\n{shapes}\n</scene>\n"
        ),
    )
    .unwrap();
    p
}

/// The hit on triangle `prim` at barycentrics `b`.
fn hit(prim: u32, b: Vec2) -> SurfaceInteraction {
    let mut si = SurfaceInteraction::for_tests(Vec3::Z, Vec2::ZERO);
    si.prim = prim;
    si.bary = b;
    si
}

#[test]
fn ply_attributes_are_named_grouped_and_interpolated_as_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene(
        dir.path(),
        "a.xml",
        r#"<shape type="ply"><string name="filename" value="grid.ply"/>
             <bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">
               <string name="name" value="vertex_color"/></texture></bsdf></shape>
           <shape type="ply"><string name="filename" value="grid.ply"/>
             <bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">
               <string name="name" value="face_weight"/><float name="scale" value="2"/></texture></bsdf></shape>"#,
    );
    let s = load(&p);
    let names: Vec<&str> = s.meshes[0]
        .attributes
        .iter()
        .map(|a| a.name.as_str())
        .collect();
    assert_eq!(names, ["vertex_color", "face_weight"]);
    let tex = |m: usize| match &s.bsdfs[s.meshes[m].bsdf as usize] {
        Bsdf::Diffuse(d) => d.reflectance.clone(),
        b => panic!("{b:?}"),
    };
    // Grid 2×2: vertex (i, j) has r = i·255/2, g = j·255/2 as uchar (kept as those values,
    // as Mitsuba 3.9.1 keeps them); the quad (0, 0) is fanned into triangles (0, 1, 4), (0, 4, 3).
    let c = |v: u8| v as f32;
    let (t0, b) = (tex(0), Vec2::new(0.25, 0.5));
    let Texture::MeshAttribute(_) = t0 else {
        panic!("expected a mesh attribute, got {t0:?}")
    };
    let v = t0.eval_at(&hit(0, b));
    // Corners 0 (r 0, g 0), 1 (r 127, g 0), 4 (r 127, g 127) with weights 0.25, 0.25, 0.5.
    let expect_r = c(0) * 0.25 + (c(127) * 0.25 + c(127) * 0.5);
    let expect_g = c(0) * 0.25 + (c(0) * 0.25 + c(127) * 0.5);
    assert!((v.x - expect_r).abs() < 1e-4, "{v} vs r {expect_r}");
    assert!((v.y - expect_g).abs() < 1e-4, "{v} vs g {expect_g}");
    // Face (i, j) weight ((7i + 3j) mod 10) / 9, the same on both triangles of its fan, × 2.
    let t1 = tex(1);
    let face_01 = 3.0 / 9.0 * 2.0; // quad i = 0, j = 1: triangles 4 and 5
    for prim in [4, 5] {
        let w = t1.eval_at(&hit(prim, Vec2::new(0.1, 0.2)));
        assert!((w.x - face_01).abs() < 1e-6 && w.x == w.z, "{w}");
    }
}

#[test]
fn mesh_attribute_errors_name_the_file_line_and_problem() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let missing = scene(
        d,
        "missing.xml",
        r#"<shape type="ply"><string name="filename" value="grid.ply"/>
<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_uv2"/></texture></bsdf></shape>"#,
    );
    let e = load_err(&missing, &[]);
    assert!(
        e.contains("missing.xml:3")
            && e.contains("no attribute \"vertex_uv2\"")
            && e.contains("vertex_color, face_weight"),
        "{e}"
    );
    let bad_name = scene(
        d,
        "name.xml",
        r#"<shape type="ply"><string name="filename" value="grid.ply"/>
<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="color"/></texture></bsdf></shape>"#,
    );
    let e = load_err(&bad_name, &[]);
    assert!(
        e.contains("name.xml:4") && e.contains("must start with"),
        "{e}"
    );
    let elsewhere = scene(
        d,
        "where.xml",
        r#"<shape type="ply"><string name="filename" value="grid.ply"/>
<bsdf type="roughplastic"><texture type="mesh_attribute" name="diffuse_reflectance"><string name="name" value="vertex_color"/></texture></bsdf></shape>"#,
    );
    let e = load_err(&elsewhere, &[]);
    assert!(
        e.contains("where.xml:4") && e.contains("supported as a diffuse BSDF's reflectance"),
        "{e}"
    );
    // An analytic sphere has no attributes.
    let sphere = scene(
        d,
        "sphere.xml",
        r#"<shape type="sphere">
<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/></texture></bsdf></shape>"#,
    );
    let e = load_err(&sphere, &[]);
    assert!(e.contains("has no attribute") && e.contains("none"), "{e}");
}
