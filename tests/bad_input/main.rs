//! Bad inputs fed to the real binary: every case must exit non-zero, print a message naming the
//! file (or argument) and the problem, never panic, and leave no output file (final or temporary).
//!
//! The same table is the documentation: `BTFPT_WRITE_BAD_INPUTS_DOC=1 cargo test --release --test
//! bad_input` regenerates `docs/bad-inputs.md` from what the binary actually printed.

use btfpt::btf::ubo2014::{ColorModel, FactorisedBtf, PayloadKind};
use btfpt::btf::{self, DirectionSet, RawBtf, StoredEncoding};
use btfpt::io::RgbImage;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One bad input: how it is made, the command, and what stderr must mention.
struct Case {
    /// Short unique id (also the row key of the doc table).
    id: &'static str,
    /// Category column of the doc table.
    what: &'static str,
    /// The command line after `btfpt`.
    args: Vec<OsString>,
    /// Substrings stderr must contain (case-insensitive): the file and the problem.
    expect: Vec<&'static str>,
    /// Folder that must hold no file afterwards (outputs go here).
    out: PathBuf,
}

fn os(v: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<OsString> {
    v.iter().map(|s| s.as_ref().to_os_string()).collect()
}

/// A small valid scene around `body` (shapes, bsdfs, emitters), film `w`×`h`.
fn scene(body: &str, w: &str, h: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="{w}"/>
            <integer name="height" value="{h}"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    {body}
</scene>
"#
    )
}

const LIGHT: &str = r#"<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>"#;

fn rect(inner: &str) -> String {
    format!(
        r#"<shape type="rectangle">{inner}<bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></shape>"#
    )
}

fn mesh_shape(kind: &str, file: &str, emitter: bool) -> String {
    let e = if emitter {
        r#"<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>"#
    } else {
        ""
    };
    format!(
        r#"<shape type="{kind}"><string name="filename" value="{file}"/><bsdf type="diffuse"/>{e}</shape>"#
    )
}

fn btf_shape(file: &str) -> String {
    format!(
        r#"<shape type="rectangle"><bsdf type="btf"><string name="filename" value="{file}"/></bsdf></shape>{LIGHT}"#
    )
}

/// A binary little-endian PLY: a unit quad (two triangles).
fn ply_quad() -> Vec<u8> {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        for c in p {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in [[0i32, 1, 2], [0, 2, 3]] {
        b.push(3);
        for i in f {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    b
}

fn ascii_ply(verts: &str, faces: &str, nv: usize, nf: usize) -> String {
    format!(
        "ply\nformat ascii 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\nelement face {nf}\nproperty list uchar int vertex_indices\nend_header\n{verts}{faces}"
    )
}

/// A tiny BTF on the 81 UBO2003 directions, 2×2 texels, value 0.25 + a little texture.
fn tiny_btf(nan: bool) -> RawBtf {
    let d = DirectionSet::ubo2003();
    let n = 81 * 81 * 4;
    let mut data: Vec<f32> = (0..n)
        .flat_map(|i| {
            let v = 0.25 + 0.1 * ((i % 7) as f32 / 7.0);
            [v, v * 0.8, v * 0.6]
        })
        .collect();
    if nan {
        data[5 * 81 * 12 + 7] = f32::NAN;
    }
    RawBtf::from_f32(d.clone(), d, 2, 2, StoredEncoding::Linear, &data).unwrap()
}

fn tiny_ubo2014() -> Vec<u8> {
    let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 90.0)]);
    let lights = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (60.0, 0.0)]);
    FactorisedBtf {
        kind: PayloadKind::Fmf { extended: true },
        color: ColorModel::Rgb,
        drr: false,
        version: 4,
        cosine_flag: 0,
        rgb_scale: [1.0; 3],
        rotations: true,
        scalar_size: 2,
        views,
        lights,
        width: 3,
        height: 2,
        u: vec![vec![1.0; 3 * 4]],
        sxv: vec![vec![0.5; 6]],
        components: vec![1],
    }
    .to_bytes()
}

fn write(p: &Path, bytes: impl AsRef<[u8]>) -> PathBuf {
    if let Some(d) = p.parent() {
        std::fs::create_dir_all(d).unwrap();
    }
    std::fs::write(p, bytes).unwrap();
    p.to_path_buf()
}

/// Builds every case's files under `dir` (each case in its own sub-folder).
fn cases(dir: &Path) -> Vec<Case> {
    let mut v = Vec::new();
    let mut add = |id: &'static str,
                   what: &'static str,
                   make: &dyn Fn(&Path, &Path) -> Vec<OsString>,
                   expect: Vec<&'static str>| {
        let d = dir.join(id);
        let out = d.join("out");
        std::fs::create_dir_all(&out).unwrap();
        let args = make(&d, &out);
        v.push(Case {
            id,
            what,
            args,
            expect,
            out,
        });
    };
    let render = |scene: &Path, out: &Path, extra: &[&str]| {
        let mut a = os(&[
            &"render",
            &scene,
            &"-o",
            &out.join("img.exr"),
            &"--threads",
            &"1",
        ]);
        a.extend(extra.iter().map(OsString::from));
        a
    };
    let ok_body = format!("{}{LIGHT}", rect(""));
    let good_scene = scene(&ok_body, "8", "8");

    // ---- scene files ----
    add(
        "scene-missing",
        "scene file does not exist",
        &|d, o| render(&d.join("nope.xml"), o, &[]),
        vec!["nope.xml", "not found"],
    );
    {
        let g = good_scene.clone();
        add(
            "xml-truncated",
            "scene XML cut in the middle",
            &move |d, o| {
                let s = write(&d.join("cut.xml"), &g[..g.len() / 2]);
                render(&s, o, &[])
            },
            vec!["cut.xml"],
        );
    }
    add(
        "xml-binary",
        "scene file is binary garbage",
        &|d, o| {
            let s = write(&d.join("garbage.xml"), [0u8, 159, 146, 150, 255, 0, 1, 2]);
            render(&s, o, &[])
        },
        vec!["garbage.xml"],
    );
    add(
        "scene-empty",
        "empty scene `<scene version=\"3.0.0\"/>`",
        &|d, o| {
            let s = write(&d.join("empty.xml"), r#"<scene version="3.0.0"/>"#);
            render(&s, o, &[])
        },
        vec!["empty.xml", "sensor"],
    );
    add(
        "scene-nothing",
        "camera but no shapes and no emitters",
        &|d, o| {
            let s = write(&d.join("nothing.xml"), scene("", "8", "8"));
            render(&s, o, &[])
        },
        vec!["nothing.xml", "empty"],
    );
    add(
        "transform-nan",
        "NaN in a shape transform (`<translate x=\"nan\"/>`)",
        &|d, o| {
            let body = format!(
                "{}{LIGHT}",
                rect(r#"<transform name="to_world"><translate x="nan"/></transform>"#)
            );
            let s = write(&d.join("nan.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["nan.xml", "finite"],
    );
    // ---- instancing (shapegroup + instance): the body starts on line 13 ----
    let group = r#"<shape type="shapegroup" id="g">
<shape type="cube"><bsdf type="diffuse"/></shape>
</shape>"#;
    {
        let body =
            format!("{LIGHT}\n{group}\n<shape type=\"instance\">\n<ref id=\"nope\"/>\n</shape>");
        add(
            "instance-undefined",
            "an instance referencing an undefined id",
            &move |d, o| render(&write(&d.join("inst.xml"), scene(&body, "8", "8")), o, &[]),
            vec!["inst.xml:18", "nope"],
        );
    }
    {
        let body = format!(
            "{LIGHT}\n<shape type=\"cube\" id=\"c\"/>\n<shape type=\"instance\">\n<ref id=\"c\"/>\n</shape>"
        );
        add(
            "instance-not-group",
            "an instance referencing a shape that is not a shapegroup",
            &move |d, o| render(&write(&d.join("inst.xml"), scene(&body, "8", "8")), o, &[]),
            vec!["inst.xml:16", "only a shapegroup", "cube"],
        );
    }
    {
        let body = format!("{LIGHT}\n<shape type=\"instance\"/>");
        add(
            "instance-empty",
            "an instance without a shapegroup",
            &move |d, o| render(&write(&d.join("inst.xml"), scene(&body, "8", "8")), o, &[]),
            vec!["inst.xml:14", "instance", "shapegroup must be specified"],
        );
    }
    {
        let body = format!(
            r#"{LIGHT}
<shape type="shapegroup" id="g">
<shape type="rectangle">
<emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
</shape>
</shape>"#
        );
        add(
            "shapegroup-emitter",
            "a shapegroup whose shape carries an area emitter (Mitsuba refuses it)",
            &move |d, o| render(&write(&d.join("inst.xml"), scene(&body, "8", "8")), o, &[]),
            vec!["inst.xml:15", "emitters is not supported"],
        );
    }
    add(
        "ptracer-specular",
        "`ptracer` on a scene with a mirror (btfpt's path tracer would not give the particle tracer's image)",
        &|d, o| {
            let body = r#"<shape type="sphere" id="ball"><bsdf type="conductor"/></shape>
<emitter type="point"><point name="position" x="0" y="2" z="2"/></emitter>"#;
            let xml = scene(body, "8", "8").replace(r#"type="path""#, r#"type="ptracer""#);
            render(&write(&d.join("pt.xml"), xml), o, &[])
        },
        vec!["pt.xml:2", "ptracer", "\"ball\" has a specular"],
    );
    {
        let body = format!(
            r#"{LIGHT}
{group}
<shape type="shapegroup" id="h">
<shape type="instance"><ref id="g"/></shape>
</shape>
<shape type="instance"><ref id="h"/></shape>"#
        );
        add(
            "instance-of-instance",
            "a shapegroup holding an instance (nested instancing, Mitsuba refuses it)",
            &move |d, o| render(&write(&d.join("inst.xml"), scene(&body, "8", "8")), o, &[]),
            vec!["inst.xml:18", "nested instancing"],
        );
    }
    {
        let body = format!(
            r#"{LIGHT}
<shape type="shapegroup" id="h">
<shape type="instance"><ref id="h"/></shape>
</shape>"#
        );
        add(
            "instance-cycle",
            "a shapegroup holding an instance of itself (a cycle)",
            &move |d, o| render(&write(&d.join("inst.xml"), scene(&body, "8", "8")), o, &[]),
            vec!["inst.xml:15", "nested instancing"],
        );
    }
    {
        let body = format!(
            r#"{LIGHT}
<shape type="shapegroup" id="s"><shape type="sphere"/></shape>
<shape type="instance"><ref id="s"/>
<transform name="to_world"><scale x="1" y="2" z="1"/></transform>
</shape>"#
        );
        add(
            "instance-sphere-nonuniform",
            "an analytic sphere of a shapegroup placed with a non-uniform scale",
            &move |d, o| render(&write(&d.join("inst.xml"), scene(&body, "8", "8")), o, &[]),
            vec!["inst.xml:15", "non-uniformly"],
        );
    }
    add(
        "blend-weight-range",
        "`blendbsdf` weight outside [0, 1]",
        &|d, o| {
            let body = format!(
                r#"<shape type="rectangle"><bsdf type="blendbsdf"><float name="weight" value="1.5"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>{LIGHT}"#
            );
            let s = write(&d.join("blend.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["blend.xml", "weight", "[0, 1]"],
    );
    for (id, what, integrator, file, expect) in [
        (
            "aov-unknown-type",
            "`aov` integrator with an AOV type Mitsuba does not have",
            r#"<integrator type="aov"><string name="aovs" value="dd:depth, nn:normals"/><integrator type="path" name="img"/></integrator>"#,
            "aov-type.xml",
            vec!["aov-type.xml:2", "aovs", "invalid AOV type \"normals\""],
        ),
        (
            "aov-malformed",
            "`aov` integrator whose `aovs` item is not `<name>:<type>`",
            r#"<integrator type="aov"><string name="aovs" value="dd:depth, depth"/></integrator>"#,
            "aov-malformed.xml",
            vec!["aov-malformed.xml:2", "aovs", "\"depth\"", "<name>:<type>"],
        ),
        (
            "moment-two-nested",
            "`moment` integrator around two nested integrators",
            r#"<integrator type="moment"><integrator type="path" name="a"/><integrator type="direct" name="b"/></integrator>"#,
            "moment-two.xml",
            vec!["moment-two.xml:2", "moment", "one nested integrator"],
        ),
    ] {
        add(
            id,
            what,
            &move |d, o| {
                let body = format!("{}{LIGHT}", rect(""));
                let text = scene(&body, "8", "8").replace(
                    r#"<integrator type="path"><integer name="max_depth" value="3"/></integrator>"#,
                    integrator,
                );
                let s = write(&d.join(file), text);
                render(&s, o, &[])
            },
            expect,
        );
    }
    add(
        "mixture-three",
        "Mitsuba 0.6 `mixturebsdf` with three components",
        &|d, o| {
            let body = format!(
                r#"<shape type="rectangle"><bsdf type="mixturebsdf"><string name="weights" value="0.2, 0.3, 0.5"/><bsdf type="diffuse"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>{LIGHT}"#
            );
            let s = write(&d.join("mix.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["mix.xml", "more than two"],
    );
    add(
        "mask-no-bsdf",
        "`mask` without a nested bsdf",
        &|d, o| {
            let body = format!(
                r#"<shape type="rectangle"><bsdf type="mask"><float name="opacity" value="0.5"/></bsdf></shape>{LIGHT}"#
            );
            let s = write(&d.join("mask.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["mask.xml", "nested bsdf"],
    );
    add(
        "roughplastic-alpha",
        "`roughplastic` with a negative roughness",
        &|d, o| {
            let body = format!(
                r#"<shape type="rectangle"><bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="-0.2"/></bsdf></shape>{LIGHT}"#
            );
            let s = write(&d.join("rp.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["rp.xml", "alpha", "roughness"],
    );
    add(
        "transform-inf",
        "Inf in a shape transform (`<scale value=\"inf\"/>`)",
        &|d, o| {
            let body = format!(
                "{}{LIGHT}",
                rect(r#"<transform name="to_world"><scale value="inf"/></transform>"#)
            );
            let s = write(&d.join("inf.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["inf.xml", "finite"],
    );
    add(
        "camera-nan",
        "NaN in the camera `lookat` origin",
        &|d, o| {
            let s = write(
                &d.join("cam.xml"),
                good_scene_with(&good_scene, "origin=\"0, 0, 4\"", "origin=\"0, nan, 4\""),
            );
            render(&s, o, &[])
        },
        vec!["cam.xml", "finite"],
    );
    add(
        "rgb-nan",
        "NaN in an `rgb` reflectance",
        &|d, o| {
            let s = write(
                &d.join("rgb.xml"),
                good_scene_with(&good_scene, "0.5, 0.5, 0.5", "0.5, nan, 0.5"),
            );
            render(&s, o, &[])
        },
        vec!["rgb.xml", "finite"],
    );
    add(
        "radiance-inf",
        "Inf emitter radiance",
        &|d, o| {
            let s = write(
                &d.join("rad.xml"),
                good_scene_with(&good_scene, "value=\"1, 1, 1\"", "value=\"inf, 1, 1\""),
            );
            render(&s, o, &[])
        },
        vec!["rad.xml", "finite"],
    );
    // ---- meshes ----
    add(
        "ply-truncated",
        "binary PLY shorter than its header says",
        &|d, o| {
            let q = ply_quad();
            write(&d.join("cut.ply"), &q[..q.len() - 7]);
            let s = write(
                &d.join("s.xml"),
                scene(&mesh_shape("ply", "cut.ply", false), "8", "8"),
            );
            render(&s, o, &[])
        },
        vec!["cut.ply"],
    );
    add(
        "ply-nan-vertex",
        "PLY vertex with a NaN coordinate",
        &|d, o| {
            let p = ascii_ply("0 0 0\n1 0 0\nnan 1 0\n", "3 0 1 2\n", 3, 1);
            write(&d.join("nan.ply"), p);
            let s = write(
                &d.join("s.xml"),
                scene(&mesh_shape("ply", "nan.ply", false), "8", "8"),
            );
            render(&s, o, &[])
        },
        vec!["nan.ply", "finite"],
    );
    add(
        "ply-bad-index",
        "PLY face index beyond the vertex count",
        &|d, o| {
            let p = ascii_ply("0 0 0\n1 0 0\n0 1 0\n", "3 0 1 7\n", 3, 1);
            write(&d.join("idx.ply"), p);
            let s = write(
                &d.join("s.xml"),
                scene(&mesh_shape("ply", "idx.ply", false), "8", "8"),
            );
            render(&s, o, &[])
        },
        vec!["idx.ply", "beyond"],
    );
    add(
        "ply-degenerate-emitter",
        "area emitter whose PLY has only zero-area triangles",
        &|d, o| {
            let p = ascii_ply("0 0 0\n1 0 0\n2 0 0\n", "3 0 1 2\n3 0 0 1\n", 3, 2);
            write(&d.join("flat.ply"), p);
            let s = write(
                &d.join("s.xml"),
                scene(&mesh_shape("ply", "flat.ply", true), "8", "8"),
            );
            render(&s, o, &[])
        },
        vec!["flat.ply", "non-zero area"],
    );
    add(
        "ply-zero-normal",
        "PLY with zero-length vertex normals",
        &|d, o| {
            let p = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0 0 0\n1 0 0 0 0 0\n0 1 0 0 0 0\n3 0 1 2\n";
            write(&d.join("zn.ply"), p);
            let s = write(
                &d.join("s.xml"),
                scene(&mesh_shape("ply", "zn.ply", false), "8", "8"),
            );
            render(&s, o, &[])
        },
        vec!["s.xml", "zero or non-finite normal"],
    );
    add(
        "obj-bad-index",
        "OBJ face referring to a missing vertex",
        &|d, o| {
            write(&d.join("idx.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
            let s = write(
                &d.join("s.xml"),
                scene(&mesh_shape("obj", "idx.obj", false), "8", "8"),
            );
            render(&s, o, &[])
        },
        vec!["idx.obj"],
    );
    add(
        "obj-inf-vertex",
        "OBJ vertex with an Inf coordinate",
        &|d, o| {
            write(&d.join("inf.obj"), "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n");
            let s = write(
                &d.join("s.xml"),
                scene(&mesh_shape("obj", "inf.obj", false), "8", "8"),
            );
            render(&s, o, &[])
        },
        vec!["inf.obj", "finite"],
    );
    add(
        "mesh-missing",
        "shape file that does not exist",
        &|d, o| {
            let s = write(
                &d.join("s.xml"),
                scene(&mesh_shape("obj", "gone.obj", false), "8", "8"),
            );
            render(&s, o, &[])
        },
        vec!["gone.obj"],
    );
    // ---- textures / environment maps ----
    add(
        "texture-missing",
        "bitmap texture that does not exist",
        &|d, o| {
            let body = format!(
                r#"<shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="nope.png"/></texture></bsdf></shape>{LIGHT}"#
            );
            let s = write(&d.join("s.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["nope.png", "not found"],
    );
    add(
        "png-truncated",
        "bitmap texture PNG cut in the middle",
        &|d, o| {
            let png = d.join("full.png");
            std::fs::create_dir_all(d).unwrap();
            let mut img = RgbImage::new(16, 16);
            img.set(3, 3, [0.5, 0.2, 0.1]);
            btfpt::io::write_png_srgb(&png, &img).unwrap();
            let b = std::fs::read(&png).unwrap();
            write(&d.join("cut.png"), &b[..b.len() / 2]);
            let body = format!(
                r#"<shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="cut.png"/></texture></bsdf></shape>{LIGHT}"#
            );
            let s = write(&d.join("s.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["cut.png"],
    );
    add(
        "exr-truncated",
        "environment map EXR cut in the middle",
        &|d, o| {
            let exr = d.join("full.exr");
            std::fs::create_dir_all(d).unwrap();
            btfpt::io::write_exr(&exr, &RgbImage::new(16, 8)).unwrap();
            let b = std::fs::read(&exr).unwrap();
            write(&d.join("cut.exr"), &b[..b.len() / 2]);
            let body = format!(
                r#"{}<emitter type="envmap"><string name="filename" value="cut.exr"/></emitter>"#,
                rect("")
            );
            let s = write(&d.join("s.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["cut.exr"],
    );
    add(
        "exr-nan",
        "environment map EXR containing NaN and Inf pixels",
        &|d, o| {
            let exr = d.join("nan.exr");
            std::fs::create_dir_all(d).unwrap();
            let mut img = RgbImage::new(16, 8);
            img.set(2, 2, [f32::NAN, 0.0, 0.0]);
            img.set(5, 5, [f32::INFINITY, 0.0, 0.0]);
            btfpt::io::write_exr(&exr, &img).unwrap();
            let body = format!(
                r#"{}<emitter type="envmap"><string name="filename" value="nan.exr"/></emitter>"#,
                rect("")
            );
            let s = write(&d.join("s.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["nan.exr", "finite"],
    );
    add(
        "projector-texture-missing",
        "projector whose irradiance bitmap does not exist",
        &|d, o| {
            let body = format!(
                r#"{}<emitter type="projector"><float name="fov" value="30"/>
                <texture type="bitmap" name="irradiance"><string name="filename" value="gone.png"/></texture></emitter>"#,
                rect("")
            );
            let s = write(&d.join("s.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["gone.png", "s.xml", "not found"],
    );
    add(
        "projector-fov",
        "projector field of view out of range",
        &|d, o| {
            let body = format!(
                r#"{}<emitter type="projector"><float name="fov" value="190"/></emitter>"#,
                rect("")
            );
            let s = write(&d.join("s.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["s.xml", "projector", "field of view"],
    );
    add(
        "spot-constant-texture",
        "spot emitter whose texture is a constant",
        &|d, o| {
            let body = format!(
                r#"{}<emitter type="spot"><rgb name="texture" value="0.5"/></emitter>"#,
                rect("")
            );
            let s = write(&d.join("s.xml"), scene(&body, "8", "8"));
            render(&s, o, &[])
        },
        vec!["s.xml", "spot", "spatially varying"],
    );
    add(
        "pplastic-eta",
        "pplastic with a negative eta",
        &|d, o| {
            let body = r#"<shape type="rectangle"><bsdf type="pplastic"><float name="eta" value="-1.5"/></bsdf></shape>"#;
            let s = write(&d.join("s.xml"), scene(&format!("{body}{LIGHT}"), "8", "8"));
            render(&s, o, &[])
        },
        vec!["s.xml", "pplastic", "eta"],
    );
    // ---- film, samples, output ----
    add(
        "resolution-absurd",
        "film 10000000 × 8",
        &|d, o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "10000000", "8"));
            render(&s, o, &[])
        },
        vec!["s.xml", "invalid film size"],
    );
    add(
        "film-memory",
        "film 100000 × 100000 (≈ 670 GiB of film)",
        &|d, o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "100000", "100000"));
            render(&s, o, &[])
        },
        vec!["GiB of film memory"],
    );
    add(
        "resolution-negative",
        "film width -8",
        &|d, o| {
            let s = write(&d.join("neg.xml"), scene(&ok_body_s(), "-8", "8"));
            render(&s, o, &[])
        },
        vec!["neg.xml", "invalid film size"],
    );
    add(
        "spp-absurd",
        "`--spp 4000000000`",
        &|d, o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "8", "8"));
            render(&s, o, &["--spp", "4000000000"])
        },
        vec!["sample range"],
    );
    add(
        "spp-zero",
        "`--spp 0`",
        &|d, o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "8", "8"));
            render(&s, o, &["--spp", "0"])
        },
        vec!["at least 1"],
    );
    add(
        "output-dir-missing",
        "output in a folder that does not exist",
        &|d, _o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "8", "8"));
            os(&[&"render", &s, &"-o", &d.join("no/such/dir/img.exr")])
        },
        vec!["img.exr", "does not exist"],
    );
    add(
        "output-unwritable",
        "output in a read-only file system (`/proc`)",
        &|d, _o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "8", "8"));
            os(&[&"render", &s, &"-o", &"/proc/btfpt-test.exr"])
        },
        vec!["btfpt-test.exr", "not writable"],
    );
    add(
        "output-not-exr",
        "output named `.png`",
        &|d, o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "8", "8"));
            os(&[&"render", &s, &"-o", &o.join("img.png")])
        },
        vec!["img.png", ".exr"],
    );
    add(
        "resume-no-checkpoint",
        "`--resume` without a checkpoint",
        &|d, o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "8", "8"));
            render(&s, o, &["--resume"])
        },
        vec!["img.exr.ckpt"],
    );
    add(
        "resume-corrupt-checkpoint",
        "`--resume` with a corrupt checkpoint",
        &|d, o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "8", "8"));
            write(&o.join("img.exr.ckpt"), b"BTFCKPT garbage garbage garbage");
            let mut a = render(&s, o, &["--resume"]);
            // The corrupt checkpoint itself is input, not output: move it out of `out/` after use.
            a.push("--seed".into());
            a.push("0".into());
            a
        },
        vec!["img.exr.ckpt"],
    );
    // ---- BTF data ----
    add(
        "ubo2003-missing-images",
        "UBO2003 folder with 3 of 6561 images deleted (render)",
        &|d, o| {
            let f = d.join("mat");
            btf::ubo2003::write_folder(&tiny_btf(false), &f, btf::ubo2003::ImageKind::Png8)
                .unwrap();
            let mut names: Vec<PathBuf> = std::fs::read_dir(&f)
                .unwrap()
                .map(|e| e.unwrap().path())
                .collect();
            names.sort();
            for i in [17, 400, 6000] {
                std::fs::remove_file(&names[i]).unwrap();
            }
            let s = write(&d.join("s.xml"), scene(&btf_shape("mat"), "8", "8"));
            render(&s, o, &[])
        },
        vec!["mat", "missing"],
    );
    add(
        "ubo2003-missing-images-fit",
        "UBO2003 folder with images deleted (fit)",
        &|d, o| {
            let f = d.join("mat");
            btf::ubo2003::write_folder(&tiny_btf(false), &f, btf::ubo2003::ImageKind::Png8)
                .unwrap();
            let first = std::fs::read_dir(&f)
                .unwrap()
                .next()
                .unwrap()
                .unwrap()
                .path();
            std::fs::remove_file(first).unwrap();
            os(&[&"fit", &f, &"-o", &o.join("m.plmc"), &"--model", &"lm"])
        },
        vec!["mat", "missing"],
    );
    add(
        "ubo2014-truncated",
        "UBO2014 `.btf` cut in the middle (render)",
        &|d, o| {
            let b = tiny_ubo2014();
            write(&d.join("cut.btf"), &b[..b.len() * 2 / 3]);
            let s = write(&d.join("s.xml"), scene(&btf_shape("cut.btf"), "8", "8"));
            render(&s, o, &[])
        },
        vec!["cut.btf"],
    );
    add(
        "ubo2014-header-only",
        "UBO2014 `.btf` that ends inside the header (info)",
        &|d, _o| {
            let b = tiny_ubo2014();
            let p = write(&d.join("head.btf"), &b[..40]);
            os(&[&"info", &p])
        },
        vec!["head.btf"],
    );
    add(
        "btfc-corrupt",
        "`.btfc` cache with one payload byte flipped",
        &|d, o| {
            let p = d.join("m.btfc");
            std::fs::create_dir_all(d).unwrap();
            btf::cache::write_raw(&tiny_btf(false), &p).unwrap();
            let mut b = std::fs::read(&p).unwrap();
            let n = b.len();
            b[n - 100] ^= 0x40;
            std::fs::write(&p, b).unwrap();
            let s = write(&d.join("s.xml"), scene(&btf_shape("m.btfc"), "8", "8"));
            render(&s, o, &[])
        },
        vec!["m.btfc", "checksum"],
    );
    add(
        "btfc-truncated",
        "`.btfc` cache cut short (fit)",
        &|d, o| {
            let p = d.join("m.btfc");
            std::fs::create_dir_all(d).unwrap();
            btf::cache::write_raw(&tiny_btf(false), &p).unwrap();
            let b = std::fs::read(&p).unwrap();
            std::fs::write(&p, &b[..b.len() - 10]).unwrap();
            os(&[&"fit", &p, &"-o", &o.join("m.plmc")])
        },
        vec!["m.btfc"],
    );
    add(
        "btf-nan-data",
        "BTF whose data contain NaN (fit)",
        &|d, o| {
            let p = d.join("nan.btfc");
            std::fs::create_dir_all(d).unwrap();
            btf::cache::write_raw(&tiny_btf(true), &p).unwrap();
            os(&[&"fit", &p, &"-o", &o.join("m.plmc"), &"--model", &"lm"])
        },
        vec!["nan.btfc", "finite"],
    );
    add(
        "fit-output-unwritable",
        "fit output in a read-only file system (`/proc`)",
        &|d, _o| {
            let p = d.join("m.btfc");
            std::fs::create_dir_all(d).unwrap();
            btf::cache::write_raw(&tiny_btf(false), &p).unwrap();
            os(&[&"fit", &p, &"-o", &"/proc/m.plmc", &"--model", &"lm"])
        },
        vec!["m.plmc"],
    );
    add(
        "plmc-truncated",
        "`.plmc` model cut in the middle (eval)",
        &|d, _o| {
            let data = d.join("m.btfc");
            std::fs::create_dir_all(d).unwrap();
            btf::cache::write_raw(&tiny_btf(false), &data).unwrap();
            let p = write(&d.join("cut.plmc"), b"PLMC\x01\x00\x00\x00\x02");
            os(&[&"eval", &p, &"--against", &data])
        },
        vec!["cut.plmc"],
    );
    add(
        "merge-not-exr",
        "`merge` of a file that is not an EXR",
        &|d, o| {
            let p = write(&d.join("a.exr"), b"not an exr at all");
            os(&[&"merge", &p, &p, &"-o", &o.join("m.exr")])
        },
        vec!["a.exr"],
    );
    add(
        "synth-into-non-empty-folder",
        "`synth` into a folder that already holds files",
        &|d, o| {
            let target = write(&o.join("btf").join("keep.txt"), b"x");
            let _ = d;
            os(&[
                &"synth",
                &"foil",
                &"--size",
                &"2",
                &"-o",
                &target.parent().unwrap(),
            ])
        },
        vec!["btf", "not empty", "--force"],
    );
    add(
        "convert-into-non-empty-folder",
        "`convert` into a folder that already holds files",
        &|d, o| {
            let p = d.join("m.btfc");
            btf::cache::write_raw(&tiny_btf(false), &p).unwrap();
            let target = write(&o.join("btf").join("keep.txt"), b"x");
            os(&[&"convert", &p, &target.parent().unwrap()])
        },
        vec!["btf", "not empty", "--force"],
    );
    add(
        "merge-output-png",
        "`merge -o` named `.png` (the merged image is linear EXR)",
        &|d, o| {
            let p = write(&d.join("a.exr"), b"not read: the output is checked first");
            os(&[&"merge", &p, &p, &"-o", &o.join("m.png")])
        },
        vec!["m.png", ".exr"],
    );
    add(
        "variance-not-exr",
        "`render --variance` named `.png`",
        &|d, o| {
            let s = write(&d.join("s.xml"), scene(&ok_body_s(), "8", "8"));
            os(&[
                &"render",
                &s,
                &"-o",
                &o.join("img.exr"),
                &"--variance",
                &o.join("var.png"),
            ])
        },
        vec!["var.png", "--variance", ".exr"],
    );
    add(
        "diff-not-png",
        "`compare --diff` named `.exr` (the difference image is an 8-bit PNG)",
        &|d, o| {
            let a = d.join("a.exr");
            btfpt::io::write_exr(&a, &RgbImage::new(2, 2)).unwrap();
            os(&[&"compare", &a, &a, &"--diff", &o.join("d.exr")])
        },
        vec!["d.exr", "--diff", ".png"],
    );
    add(
        "plot-not-png",
        "`eval --plot` named `.jpg`",
        &|d, o| {
            let data = d.join("m.btfc");
            btf::cache::write_raw(&tiny_btf(false), &data).unwrap();
            let m = write(&d.join("m.plmc"), b"PLMC");
            os(&[
                &"eval",
                &m,
                &"--against",
                &data,
                &"--plot",
                &o.join("p.jpg"),
            ])
        },
        vec!["p.jpg", "--plot", ".png"],
    );
    add(
        "tile-preview-jpg",
        "`tile-preview -o` named `.jpg`",
        &|d, o| {
            let m = write(&d.join("m.plmc"), b"PLMC");
            os(&[&"tile-preview", &m, &"-o", &o.join("t.jpg")])
        },
        vec!["t.jpg", ".png", ".exr"],
    );
    add(
        "info-not-a-btf-folder",
        "`info` of a folder that holds no BTF images",
        &|d, _o| {
            let junk = write(&d.join("junk").join("notes.txt"), b"x");
            os(&[&"info", &junk.parent().unwrap()])
        },
        vec!["junk", "not a UBO2003"],
    );
    add(
        "render-a-folder",
        "`render` of a folder instead of a scene file",
        &|d, o| {
            let folder = d.join("scenes");
            std::fs::create_dir_all(&folder).unwrap();
            os(&[&"render", &folder, &"-o", &o.join("img.exr")])
        },
        vec!["scenes", "is a folder", "scene file"],
    );
    add(
        "fit-a-model",
        "`fit` given a fitted `.plmc` model instead of measured data",
        &|d, o| {
            let m = write(&d.join("m.plmc"), b"PLMC");
            os(&[&"fit", &m, &"-o", &o.join("n.plmc")])
        },
        vec!["m.plmc", "measured data", "btfpt info", "btfpt eval"],
    );
    v
}

fn ok_body_s() -> String {
    format!("{}{LIGHT}", rect(""))
}

fn good_scene_with(s: &str, from: &str, to: &str) -> String {
    assert!(s.contains(from), "{from}");
    s.replacen(from, to, 1)
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            v.push(e.path());
        }
    }
    v
}

struct Outcome {
    code: Option<i32>,
    stderr: String,
    problems: Vec<String>,
}

fn run_case(c: &Case) -> Outcome {
    let before: Vec<PathBuf> = files_in(&c.out);
    let out = Command::new(env!("CARGO_BIN_EXE_btfpt"))
        .args(&c.args)
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    let lower = stderr.to_lowercase();
    let mut problems = Vec::new();
    if out.status.success() {
        problems.push("exit code 0".into());
    }
    if out.status.code().is_none() {
        problems.push(format!("killed by a signal: {:?}", out.status));
    }
    if lower.contains("panicked") || lower.contains("rust_backtrace") {
        problems.push("panic text on stderr".into());
    }
    for e in &c.expect {
        if !lower.contains(&e.to_lowercase()) {
            problems.push(format!("stderr does not mention '{e}'"));
        }
    }
    let left: Vec<PathBuf> = files_in(&c.out)
        .into_iter()
        .filter(|p| !before.contains(p))
        // A failed fit keeps the views it finished in OUTPUT.parts/ for the rerun (by design).
        .filter(|p| !(p.is_dir() && p.extension().is_some_and(|e| e == "parts")))
        .collect();
    if !left.is_empty() {
        problems.push(format!("output left behind: {left:?}"));
    }
    for p in c.args.iter().map(PathBuf::from) {
        if let Some(parent) = p.parent() {
            for f in files_in(parent) {
                let name = f
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .to_string();
                if name.contains(".tmp") {
                    problems.push(format!("temporary file left behind: {}", f.display()));
                }
            }
        }
    }
    Outcome {
        code: out.status.code(),
        stderr,
        problems,
    }
}

/// The message a user sees: the `error:` line(s), with the temporary folder shown as `…/`.
fn shown(stderr: &str, dir: &Path) -> String {
    let d = format!("{}/", dir.display());
    stderr
        .lines()
        .filter(|l| l.starts_with("error") || l.starts_with("warning") || l.starts_with("Caused"))
        .map(|l| l.replace(&d, "…/").replace('|', "\\|"))
        .collect::<Vec<_>>()
        .join("<br>")
}

#[test]
fn every_bad_input_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let cases = cases(dir.path());
    let mut ids: Vec<&str> = cases.iter().map(|c| c.id).collect();
    ids.sort();
    ids.dedup();
    assert_eq!(ids.len(), cases.len(), "duplicate case ids");

    let mut failures = Vec::new();
    let mut rows = Vec::new();
    for c in &cases {
        let o = run_case(c);
        if !o.problems.is_empty() {
            failures.push(format!(
                "{}: {}\n    stderr: {}",
                c.id,
                o.problems.join("; "),
                o.stderr.trim().replace('\n', "\n            ")
            ));
        }
        let cmd: Vec<String> = c
            .args
            .iter()
            .map(|a| {
                a.to_string_lossy()
                    .replace(&format!("{}/{}/", dir.path().display(), c.id), "")
            })
            .collect();
        rows.push(format!(
            "| `{}` | {} | `btfpt {}` | {} | {} |",
            c.id,
            c.what,
            cmd.join(" ").replace('|', "\\|"),
            o.code.map_or("signal".into(), |c| c.to_string()),
            shown(&o.stderr, dir.path()).replace(&format!("{}/", c.id), "")
        ));
    }
    let doc_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/bad-inputs.md");
    if std::env::var_os("BTFPT_WRITE_BAD_INPUTS_DOC").is_some() {
        let doc = format!(
            "# Bad inputs and what the user sees\n\n\
             Generated by `BTFPT_WRITE_BAD_INPUTS_DOC=1 cargo test --release --test bad_input` from the\n\
             cases of `tests/bad_input/main.rs`, which checks for each: exit code ≠ 0, the message names the\n\
             file (or argument) and the problem, no panic text, and no output or temporary file left\n\
             behind. Paths are relative to the case's scratch folder.\n\n\
             | case | input | command | exit | message |\n|---|---|---|---|---|\n{}\n",
            rows.join("\n")
        );
        std::fs::create_dir_all(doc_path.parent().unwrap()).unwrap();
        std::fs::write(&doc_path, doc).unwrap();
    } else {
        let doc = std::fs::read_to_string(&doc_path).unwrap_or_default();
        for c in &cases {
            assert!(
                doc.contains(&format!("| `{}` |", c.id)),
                "docs/bad-inputs.md lacks case {} (regenerate it, see the file header)",
                c.id
            );
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} bad inputs misbehave:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// A scene whose light transport overflows (radiance near f32::MAX on a 1e-7-sized emitter and a
/// point light): NaN/Inf path contributions arise, are discarded, counted and reported, and the
/// image stays finite.
#[test]
fn nan_and_inf_samples_never_reach_the_film() {
    let dir = tempfile::tempdir().unwrap();
    let body = format!(
        r#"{}
    <shape type="rectangle"><transform name="to_world"><scale value="1e-7"/><translate z="1"/></transform>
        <emitter type="area"><rgb name="radiance" value="3e38, 3e38, 3e38"/></emitter></shape>
    <emitter type="point"><point name="position" x="0" y="0" z="1"/><rgb name="intensity" value="3e38, 3e38, 3e38"/></emitter>"#,
        rect("")
    );
    let s = write(&dir.path().join("overflow.xml"), scene(&body, "16", "16"));
    let out = dir.path().join("o.exr");
    let o = Command::new(env!("CARGO_BIN_EXE_btfpt"))
        .args(os(&[
            &"render",
            &s,
            &"-o",
            &out,
            &"--spp",
            &"16",
            &"--threads",
            &"1",
        ]))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let n: u64 = err
        .split(" NaN/Inf samples discarded")
        .next()
        .and_then(|h| h.rsplit(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no discarded-sample count reported: {err}"));
    assert!(n > 0, "{err}");
    let img = btfpt::io::read_image(&out).unwrap();
    assert!(
        img.data.iter().all(|v| v.is_finite()),
        "non-finite pixel in the film"
    );
}

/// Every input a fuzzer crashed once (`tests/fuzz-regressions/<target>/`) is now a clean error.
#[test]
fn fuzz_regressions_are_clean_errors() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions");
    let mut n = 0;
    for f in files_in(&root.join("image_exr")) {
        let e = btfpt::io::read_image(&f).expect_err("corrupt EXR must be rejected");
        assert!(
            e.to_string()
                .contains(&*f.file_name().unwrap().to_string_lossy()),
            "{e}"
        );
        n += 1;
    }
    for f in files_in(&root.join("btfc")) {
        let e = btfpt::btf::cache::load_cache(&f)
            .map(|_| ())
            .expect_err("corrupt .btfc must be rejected");
        // The dimensions overflow u64: a wrapping size check (release builds) would misreport
        // them as a size mismatch, a checked one (debug builds) panicked.
        assert!(
            e.to_string()
                .contains(&*f.file_name().unwrap().to_string_lossy())
                && e.to_string().contains("implausible dimensions"),
            "{e}"
        );
        n += 1;
    }
    assert!(n > 1, "no regression inputs found");
}
