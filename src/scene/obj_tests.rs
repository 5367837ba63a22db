use super::*;
use crate::math::Pcg32;
use std::fmt::Write;

fn p() -> &'static Path {
    Path::new("mesh.obj")
}

/// The reader this module replaced (tobj, `single_index`), with its conversion to a
/// `LocalMesh`: the oracle the parallel reader must agree with on well-formed files.
fn tobj_reference(bytes: &[u8], flip_tex_coords: bool) -> LocalMesh {
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::BufReader::new(bytes);
    let (models, _) =
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed)).unwrap();
    let any_uv = models.iter().any(|m| !m.mesh.texcoords.is_empty());
    let any_n = models.iter().any(|m| !m.mesh.normals.is_empty());
    let mut out = LocalMesh::default();
    for m in &models {
        let mesh = &m.mesh;
        let base = out.positions.len() as u32;
        for i in 0..mesh.positions.len() / 3 {
            let v = |a: &[f32], k: usize| Vec3::new(a[k * i], a[k * i + 1], a[k * i + 2]);
            out.positions.push(v(&mesh.positions, 3));
            if any_n {
                out.normals.push(v(&mesh.normals, 3));
            }
            if any_uv {
                let uv = if mesh.texcoords.len() >= 2 * (i + 1) {
                    Vec2::new(mesh.texcoords[2 * i], mesh.texcoords[2 * i + 1])
                } else {
                    Vec2::ZERO
                };
                out.uvs.push(if flip_tex_coords {
                    Vec2::new(uv.x, 1.0 - uv.y)
                } else {
                    uv
                });
            }
        }
        for t in mesh.indices.chunks_exact(3) {
            out.indices.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    out
}

/// A well-formed OBJ exercising what real files hold: objects and groups, triangles, quads and
/// polygons, absolute and relative indices, optional uvs and normals, w coordinates, comments,
/// CRLF line ends, and faces that reuse corners across objects.
fn varied_obj(seed: u64, uvs: bool, normals: bool) -> String {
    let mut rng = Pcg32::new(seed, 7);
    let mut s = String::from("# made by the test\nmtllib none.mtl\n");
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    for obj in 0..5 {
        writeln!(s, "{} part{obj}", if obj % 2 == 0 { "o" } else { "g" }).unwrap();
        for _ in 0..40 {
            let x = rng.next_f32() * 4.0 - 2.0;
            if rng.next_f32() < 0.1 {
                writeln!(s, "v {x} {} {} 2\r", rng.next_f32(), rng.next_f32()).unwrap();
            } else {
                writeln!(s, "v  {x}\t{} {}", rng.next_f32(), rng.next_f32()).unwrap();
            }
            nv += 1;
            if uvs {
                writeln!(s, "vt {} {}", rng.next_f32(), rng.next_f32()).unwrap();
                nt += 1;
            }
            if normals {
                writeln!(s, "vn {} {} 1", rng.next_f32(), rng.next_f32()).unwrap();
                nn += 1;
            }
        }
        s.push_str("usemtl red\ns off\n\n");
        for _ in 0..60 {
            let n = 3 + (rng.next_u32() % 4) as usize;
            s.push('f');
            for _ in 0..n {
                let pick = |rng: &mut Pcg32, count: i64| -> i64 {
                    let i = (rng.next_u32() as i64) % count.min(60);
                    if rng.next_f32() < 0.3 {
                        -(i + 1)
                    } else {
                        count - i
                    }
                };
                let v = pick(&mut rng, nv);
                match (uvs, normals) {
                    (false, false) => write!(s, " {v}").unwrap(),
                    (true, false) => write!(s, " {v}/{}", pick(&mut rng, nt)).unwrap(),
                    (false, true) => write!(s, " {v}//{}", pick(&mut rng, nn)).unwrap(),
                    (true, true) => {
                        write!(s, " {v}/{}/{}", pick(&mut rng, nt), pick(&mut rng, nn)).unwrap()
                    }
                }
            }
            s.push('\n');
        }
        s.push_str("# end of part\n");
    }
    s
}

fn assert_same(a: &LocalMesh, b: &LocalMesh) {
    assert_eq!(a.indices, b.indices);
    assert_eq!(a.positions, b.positions);
    assert_eq!(a.uvs, b.uvs);
    assert_eq!(a.normals, b.normals);
}

#[test]
fn parallel_reader_gives_the_meshes_tobj_gave() {
    for (seed, uvs, normals) in [
        (1, false, false),
        (2, true, false),
        (3, false, true),
        (4, true, true),
    ] {
        let text = varied_obj(seed, uvs, normals);
        for flip in [false, true] {
            let want = tobj_reference(text.as_bytes(), flip);
            assert!(want.indices.len() > 500);
            // One chunk, and chunks of a few lines, so relative indices and objects cross chunks.
            for chunk in [1 << 20, 200, 1] {
                let got = parse(p(), text.as_bytes(), flip, None, chunk).unwrap();
                assert_same(&got, &want);
            }
        }
    }
}

#[test]
fn quad_with_uvs_is_fan_triangulated_and_v_flipped() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("q.obj");
    std::fs::write(
        &p,
        "mtllib missing.mtl\no a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 0.25\nvt 0 1\n\
         usemtl foo\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let m = load(&p, true).unwrap();
    assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(m.normals.is_empty());
    assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
    assert_eq!(m.uvs[2], Vec2::new(1.0, 0.75));
    let m2 = load(&p, false).unwrap();
    assert_eq!(m2.uvs[2], Vec2::new(1.0, 0.25));
}

#[test]
fn nan_vertex_names_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.obj");
    std::fs::write(&p, "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let e = load(&p, true).unwrap_err().to_string();
    assert!(
        e.contains("bad.obj") && e.contains("line 2") && e.contains("finite"),
        "{e}"
    );
    let e = load(&dir.path().join("none.obj"), true)
        .unwrap_err()
        .to_string();
    assert!(e.contains("none.obj"), "{e}");
}

#[test]
fn bad_records_name_file_and_line() {
    let err = |s: &str| {
        parse(p(), s.as_bytes(), true, None, 4)
            .unwrap_err()
            .to_string()
    };
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    for (body, line, what) in [
        ("f 1 2 9\n", 4, "missing vertex 9"),
        ("f 1 2 0\n", 4, "index 0"),
        ("f -4 2 3\n", 4, "missing vertex -4"),
        ("f 1 2 x\n", 4, "\"x\""),
        ("f 1/1/1/1 2 3\n", 4, "more than three"),
        ("vt 0\nf 1 2 3\n", 4, "has 1 values"),
        ("v 1 2\nf 1 2 3\n", 4, "has 2 values"),
        ("v 1 2 3 0\nf 1 2 3\n", 4, "w = 0"),
        ("v 1 2 3 4 5\nf 1 2 3\n", 4, "5 values"),
        ("vn 0 0 1\nf 1//1 2//1 3\n", 5, ""),
    ] {
        let e = err(&format!("{tri}{body}"));
        assert!(e.contains("mesh.obj"), "{e}");
        if what.is_empty() {
            assert!(e.contains("some faces have vertex normals"), "{e}");
        } else {
            assert!(
                e.contains(&format!("line {line}")) && e.contains(what),
                "{body}: {e}"
            );
        }
    }
    assert!(err(tri).contains("no faces"));
    // A uv index into a file without uvs is ignored, as before.
    let m = parse(
        p(),
        format!("{tri}f 1/5 2/5 3/5\n").as_bytes(),
        true,
        None,
        4,
    )
    .unwrap();
    assert!(m.uvs.is_empty() && m.indices.len() == 1);
}

#[test]
fn meshes_beyond_memory_or_index_range_are_refused_before_allocation() {
    let text = varied_obj(5, true, false);
    let e = parse(p(), text.as_bytes(), true, Some(1000), 1 << 20)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("mesh.obj") && e.contains("memory is available"),
        "{e}"
    );
    // The counts a file of 2^31 corner indices would give (too big to write in a test).
    let big = Counts {
        v: 3,
        triangles: (1 << 31) / 3 + 1,
        ..Counts::default()
    };
    assert!(check_counts(big, None).unwrap_err().contains("2^31"));
    let ok = Counts {
        triangles: (1 << 31) / 3,
        ..big
    };
    assert!(check_counts(ok, None).is_ok());
    let uvs = Counts {
        vt: u32::MAX as u64,
        ..ok
    };
    assert!(check_counts(uvs, None).unwrap_err().contains("u32"));
}

#[test]
fn chunks_end_after_newlines_and_cover_the_file() {
    let text = b"v 0 0 0\nv 1 0 0\n\nf 1 2 3";
    for target in [1, 3, 8, 100] {
        let c = chunks(text, target);
        assert_eq!(c.first().unwrap().start, 0);
        assert_eq!(c.last().unwrap().end, text.len());
        for w in c.windows(2) {
            assert_eq!(w[0].end, w[1].start);
            assert_eq!(text[w[0].end - 1], b'\n');
        }
    }
}
