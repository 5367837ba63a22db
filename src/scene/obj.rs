//! Wavefront OBJ meshes (via `tobj`), with Mitsuba's conventions: polygons fan-triangulated,
//! vertices unique per (position, uv, normal) triple, all objects merged into one mesh, materials
//! ignored, and uv's v flipped (v ← 1 − v) when `flip_tex_coords` is set (Mitsuba's default).

use super::shapes::LocalMesh;
use crate::math::{Vec2, Vec3};
use crate::{Error, Result};
use std::path::Path;

/// Loads an OBJ file into object space. Errors name the file and, for bad numbers, the line.
pub fn load(path: &Path, flip_tex_coords: bool) -> Result<LocalMesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    check_numbers(path, &bytes)?;
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::BufReader::new(bytes.as_slice());
    let (models, _materials) =
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| Error::format(path, format!("cannot parse OBJ: {e}")))?;
    let any_uv = models.iter().any(|m| !m.mesh.texcoords.is_empty());
    let any_n = models.iter().any(|m| !m.mesh.normals.is_empty());
    let all_n = models
        .iter()
        .all(|m| !m.mesh.normals.is_empty() || m.mesh.indices.is_empty());
    if any_n && !all_n {
        return Err(Error::format(
            path,
            "some objects have vertex normals and others do not (unsupported mix)",
        ));
    }
    let mut out = LocalMesh::default();
    for m in &models {
        let mesh = &m.mesh;
        let base = out.positions.len() as u32;
        let n = mesh.positions.len() / 3;
        for i in 0..n {
            out.positions.push(Vec3::new(
                mesh.positions[3 * i],
                mesh.positions[3 * i + 1],
                mesh.positions[3 * i + 2],
            ));
            if any_n {
                out.normals.push(Vec3::new(
                    mesh.normals[3 * i],
                    mesh.normals[3 * i + 1],
                    mesh.normals[3 * i + 2],
                ));
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
            for &i in t {
                if i as usize >= n {
                    return Err(Error::format(
                        path,
                        format!("face references missing vertex {}", i + 1),
                    ));
                }
            }
            out.indices.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if out.indices.is_empty() {
        return Err(Error::format(path, "the OBJ file contains no faces"));
    }
    Ok(out)
}

/// Rejects unparsable or non-finite numbers in `v`, `vn` and `vt` lines, naming the line.
fn check_numbers(path: &Path, bytes: &[u8]) -> Result<()> {
    let text = String::from_utf8_lossy(bytes);
    for (ln, line) in text.lines().enumerate() {
        let mut it = line.split_whitespace();
        let (need, what) = match it.next() {
            Some("v") => (3, "vertex position"),
            Some("vn") => (3, "vertex normal"),
            Some("vt") => (1, "texture coordinate"),
            _ => continue,
        };
        let mut count = 0;
        for tok in it {
            let v: f64 = tok.parse().map_err(|_| {
                Error::format(
                    path,
                    format!("line {}: cannot parse {what} value \"{tok}\"", ln + 1),
                )
            })?;
            if !v.is_finite() {
                return Err(Error::format(
                    path,
                    format!("line {}: non-finite {what} value \"{tok}\"", ln + 1),
                ));
            }
            count += 1;
        }
        if count < need {
            return Err(Error::format(
                path,
                format!("line {}: {what} needs {need} values, got {count}", ln + 1),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert_eq!(m.indices.len(), 2);
        assert!(m.normals.is_empty());
        let i = m
            .positions
            .iter()
            .position(|q| *q == Vec3::new(1.0, 1.0, 0.0))
            .unwrap();
        assert_eq!(m.uvs[i], Vec2::new(1.0, 0.75));
        let m2 = load(&p, false).unwrap();
        let i = m2
            .positions
            .iter()
            .position(|q| *q == Vec3::new(1.0, 1.0, 0.0))
            .unwrap();
        assert_eq!(m2.uvs[i], Vec2::new(1.0, 0.25));
    }

    #[test]
    fn nan_vertex_names_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.obj");
        std::fs::write(&p, "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let e = load(&p, true).unwrap_err().to_string();
        assert!(e.contains("bad.obj") && e.contains("line 2"), "{e}");
        let e = load(&dir.path().join("none.obj"), true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("none.obj"), "{e}");
    }
}
