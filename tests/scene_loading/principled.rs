//! Mitsuba's `principled` and `principledthin` BSDFs read from a scene file: every parameter, constant or textured,
//! `specular` mapped to `eta`; and its bad inputs (a message naming the file, line and problem).

use btfpt::bsdf::{Bsdf, Texture};
use btfpt::math::Vec2;
use btfpt::scene::{self, LoadOptions};
use std::path::Path;

fn scene_text(bsdf: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="45"/><film type="hdrfilm"/></sensor>
    <shape type="sphere">
{bsdf}
    </shape>
</scene>
"#
    )
}

fn load_bsdf(dir: &Path, bsdf: &str) -> Result<Bsdf, String> {
    let p = dir.join("scene.xml");
    std::fs::write(&p, scene_text(bsdf)).unwrap();
    scene::load(&p, &LoadOptions::default())
        .map(|s| s.bsdfs[s.meshes[0].bsdf as usize].clone())
        .map_err(|e| e.to_string())
}

#[test]
fn principled_reads_every_parameter() {
    let dir = tempfile::tempdir().unwrap();
    let b = load_bsdf(
        dir.path(),
        r#"<bsdf type="principled">
        <rgb name="base_color" value="0.8, 0.3, 0.2"/>
        <texture type="checkerboard" name="roughness"><float name="color0" value="0.1"/><float name="color1" value="0.7"/></texture>
        <float name="anisotropic" value="0.3"/><float name="metallic" value="0.2"/>
        <float name="spec_trans" value="0.4"/><float name="specular" value="0.6"/>
        <float name="spec_tint" value="0.5"/><float name="sheen" value="0.6"/>
        <float name="sheen_tint" value="0.4"/><float name="flatness" value="0.2"/>
        <float name="clearcoat" value="0.7"/><float name="clearcoat_gloss" value="0.6"/>
        <float name="main_specular_sampling_rate" value="2"/>
        <float name="clearcoat_sampling_rate" value="0.5"/>
        <float name="diffuse_reflectance_sampling_rate" value="3"/>
        </bsdf>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let Bsdf::Principled(p) = b else {
        panic!("expected principled, got {b:?}")
    };
    let uv = Vec2::new(0.3, 0.6);
    assert!(matches!(p.roughness, Texture::Checkerboard(_)));
    assert_eq!(p.anisotropic.eval_1(uv), 0.3);
    assert_eq!(p.sheen_tint.eval_1(uv), 0.4);
    assert_eq!(p.clearcoat_gloss.eval_1(uv), 0.6);
    let eta = 2.0 / (1.0 - (0.08f32 * 0.6).sqrt()) - 1.0;
    assert_eq!(p.eta, eta);
    assert!(p.has_spec_trans);
    assert_eq!(
        (p.specular_rate, p.clearcoat_rate, p.diffuse_rate),
        (2.0, 0.5, 3.0)
    );
    // Defaults, and an explicit zero spec_trans is no transmission lobe (Mitsuba's get_flag).
    let b = load_bsdf(
        dir.path(),
        r#"<bsdf type="principled"><float name="spec_trans" value="0"/><float name="eta" value="1"/></bsdf>"#,
    )
    .unwrap();
    let Bsdf::Principled(p) = b else { panic!() };
    assert!(!p.has_spec_trans);
    assert_eq!(p.eta, 1.0);
    assert_eq!(p.base_color.eval_1(uv), 0.5);
    assert_eq!(p.roughness.eval_1(uv), 0.5);
    // A matched index with transmission is nudged as Mitsuba does.
    let b = load_bsdf(
        dir.path(),
        r#"<bsdf type="principled"><float name="spec_trans" value="0.5"/><float name="eta" value="1"/></bsdf>"#,
    )
    .unwrap();
    let Bsdf::Principled(p) = b else { panic!() };
    assert_eq!(p.eta, 1.001);
}

#[test]
fn principledthin_reads_every_parameter() {
    let dir = tempfile::tempdir().unwrap();
    let b = load_bsdf(
        dir.path(),
        r#"<bsdf type="principledthin">
        <rgb name="base_color" value="0.7, 0.4, 0.2"/><float name="roughness" value="0.35"/>
        <float name="anisotropic" value="0.4"/><float name="spec_trans" value="0.6"/>
        <texture type="checkerboard" name="eta"><float name="color0" value="1.2"/><float name="color1" value="1.6"/></texture>
        <float name="spec_tint" value="0.5"/><float name="sheen" value="0.5"/>
        <float name="sheen_tint" value="0.6"/><float name="flatness" value="0.3"/>
        <float name="diff_trans" value="1.6"/>
        <float name="specular_reflectance_sampling_rate" value="1.5"/>
        <float name="specular_transmittance_sampling_rate" value="0.7"/>
        <float name="diffuse_reflectance_sampling_rate" value="2"/>
        <float name="diffuse_transmittance_sampling_rate" value="0.5"/>
        </bsdf>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let Bsdf::PrincipledThin(p) = b else {
        panic!("expected principledthin, got {b:?}")
    };
    let uv = Vec2::new(0.3, 0.6);
    assert!(matches!(p.eta, Texture::Checkerboard(_)));
    assert_eq!(p.diff_trans.eval_1(uv), 1.6);
    assert_eq!(p.flatness.eval_1(uv), 0.3);
    assert!(p.has_spec_trans && p.has_diff_trans);
    assert_eq!(p.rates, [1.5, 0.7, 2.0, 0.5]);
}

#[test]
fn principled_bad_parameters_name_file_line_and_problem() {
    let dir = tempfile::tempdir().unwrap();
    for (bsdf, needle) in [
        (
            r#"<bsdf type="principled"><float name="roughness" value="1.5"/></bsdf>"#,
            "\"roughness\" must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="principled"><float name="metallic" value="-0.1"/></bsdf>"#,
            "\"metallic\" must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="principled"><rgb name="base_color" value="1.2, 0.5, 0.5"/></bsdf>"#,
            "base_color",
        ),
        (
            r#"<bsdf type="principled"><float name="eta" value="-1.5"/></bsdf>"#,
            "\"eta\" must be positive",
        ),
        (
            r#"<bsdf type="principled"><float name="eta" value="1.5"/><float name="specular" value="0.5"/></bsdf>"#,
            "either \"eta\" or \"specular\"",
        ),
        (
            r#"<bsdf type="principled"><float name="specular" value="2"/></bsdf>"#,
            "\"specular\" must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="principled"><float name="clearcoat_sampling_rate" value="-1"/></bsdf>"#,
            "clearcoat_sampling_rate",
        ),
        (
            r#"<bsdf type="principled"><float name="roughnes" value="0.2"/></bsdf>"#,
            "roughnes",
        ),
        (
            r#"<bsdf type="principledthin"><float name="diff_trans" value="2.5"/></bsdf>"#,
            "\"diff_trans\" must lie in [0, 2]",
        ),
        (
            r#"<bsdf type="principledthin"><float name="eta" value="0"/></bsdf>"#,
            "\"eta\" must be positive",
        ),
        (
            r#"<bsdf type="principledthin"><float name="sheen" value="1.1"/></bsdf>"#,
            "\"sheen\" must lie in [0, 1]",
        ),
    ] {
        let e = load_bsdf(dir.path(), bsdf).expect_err(bsdf);
        assert!(e.contains("scene.xml"), "no file in: {e}");
        assert!(e.contains(":4:"), "no line 4 in: {e}");
        assert!(e.contains(needle), "expected {needle:?} in: {e}");
    }
}
