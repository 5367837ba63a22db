//! Mitsuba's `serialized` mesh files: one or more shapes, each a little-endian header (u16
//! magic 0x041C, u16 version 3 or 4) followed by a zlib stream holding u32 flags, (v4) the
//! NUL-terminated shape name, u64 vertex and triangle counts, positions, optional normals, uvs
//! and colours (f32 or f64 by flag) and the triangle indices (u32, or u64 beyond 2³² vertices).
//! The file ends with the byte offset of each shape (u64 in v4, u32 in v3) and the u32 shape
//! count, which `shape_index` selects by.

use super::shapes::{LocalMesh, Shape, available_memory, check_mesh_fits};
use crate::io::bytes::Reader;
use crate::math::{Vec2, Vec3};
use crate::plugin::Properties;
use crate::{Error, Result};
use rayon::prelude::*;
use std::io::Read;
use std::path::Path;

const MAGIC: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const SINGLE: u32 = 0x1000;
const DOUBLE: u32 = 0x2000;

/// One shape of a serialized file.
#[derive(Debug)]
pub struct SerializedShape {
    pub mesh: LocalMesh,
    /// The file asks for face normals (flag 0x0010); Mitsuba 3 ignores this flag in version 3/4
    /// files, and so does the scene loader.
    pub face_normals: bool,
    /// Shape name (version 4 files; empty otherwise).
    pub name: String,
}

/// Mitsuba's `serialized` shape: `filename`, `shape_index` (0), `face_normals` (false: Mitsuba 3
/// ignores the face-normals flag of version 3/4 files, only its v5 loader applies it).
pub fn from_props(p: &dyn Properties) -> Result<Shape> {
    let mut s = Shape::base(p, None)?;
    let file = p.string_req("filename")?;
    let path = p.resolve(&file);
    let index = p.int("shape_index", 0)?;
    let index = u32::try_from(index).map_err(|_| p.err(&format!("invalid shape_index {index}")))?;
    let sh = load(&path, index).map_err(|e| p.err(&e.to_string()))?;
    s.local = Some(sh.mesh);
    s.options.face_normals = p.bool("face_normals", false)?;
    s.options.recompute_normals = true;
    s.label = Some(if sh.name.is_empty() {
        format!("{file}[{index}]")
    } else {
        format!("{file}[{index}] {}", sh.name)
    });
    s.file = Some(path);
    Ok(s)
}

/// Reads shape `shape_index` of a serialized file.
pub fn load(path: &Path, shape_index: u32) -> Result<SerializedShape> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse(&bytes, path, shape_index, available_memory())
}

const KIND: &str = "corrupt Mitsuba serialized mesh";

/// The most bytes zlib's deflate can expand one compressed byte into (its maximum ratio).
const MAX_INFLATE_RATIO: u64 = 1032;

/// Refuses, before anything is allocated for them, a shape whose declared counts need more
/// bytes than its `compressed` bytes can inflate to (a count that lies), 2³¹ or more indices, or
/// more memory than is available.
fn check_counts(
    path: &Path,
    nv: u64,
    nt: u64,
    compressed: usize,
    avail: Option<u64>,
) -> Result<()> {
    check_mesh_fits(nv, nt, avail).map_err(|m| Error::format(path, format!("{KIND}: {m}")))?;
    // 3 f32 per vertex and 3 u32 per triangle at least.
    let least = nv as u128 * 12 + nt as u128 * 12;
    let most = compressed as u128 * MAX_INFLATE_RATIO as u128 + 64;
    if least > most {
        return Err(Error::format(
            path,
            format!(
                "{KIND}: the shape declares {nv} vertices and {nt} triangles, at least {least} bytes, but its {compressed} compressed bytes inflate to at most {most}: the file is truncated or its counts are wrong"
            ),
        ));
    }
    Ok(())
}

/// The `k`-th little-endian float of `size` (4 or 8) bytes in `c`, as f32.
fn decode(c: &[u8], size: usize, k: usize) -> f32 {
    let b = &c[k * size..];
    if size == 8 {
        f64::from_le_bytes(b[..8].try_into().expect("8 bytes")) as f32
    } else {
        f32::from_le_bytes(b[..4].try_into().expect("4 bytes"))
    }
}

/// Parses shape `index` of the file `b` (read from `path`, which errors name), refusing a shape
/// that does not fit in `avail` bytes of memory before allocating for it.
fn parse(b: &[u8], path: &Path, index: u32, avail: Option<u64>) -> Result<SerializedShape> {
    let mut r = Reader::new(b, path, KIND);
    let header = |r: &mut Reader, at: usize| -> Result<u16> {
        r.seek(at)?;
        r.set_part("shape header");
        let magic = r.u16("magic")?;
        if magic != MAGIC {
            return Err(Error::format(
                path,
                format!(
                    "not a Mitsuba serialized mesh (magic {magic:#06x} at byte {at}, expected 0x041c)"
                ),
            ));
        }
        let version = r.u16("version")?;
        if version != 3 && version != 4 {
            return Err(r.err(format!(
                "serialized format version {version} is not supported (3 or 4)"
            )));
        }
        Ok(version)
    };
    let version = header(&mut r, 0)?;
    let offset = if index == 0 {
        0
    } else {
        r.set_part("shape table");
        let n = b.len();
        let at = n
            .checked_sub(4)
            .ok_or_else(|| r.err("file too short for the shape table"))?;
        r.seek(at)?;
        let count = r.u32("shape count")?;
        if index >= count {
            return Err(Error::format(
                path,
                format!("shape_index {index} is out of range: the file holds {count} shapes"),
            ));
        }
        let k = (count - index) as usize;
        let entry = if version == 4 { 8 } else { 4 };
        let at = k
            .checked_mul(entry)
            .and_then(|t| n.checked_sub(4 + t))
            .ok_or_else(|| r.err("the shape table runs past the start of the file"))?;
        r.seek(at)?;
        let o = if version == 4 {
            r.u64("shape offset")?
        } else {
            r.u32("shape offset")? as u64
        };
        usize::try_from(o).map_err(|_| r.err(format!("shape offset {o} is past the end")))?
    };
    let version = header(&mut r, offset)?;
    let stream = &b[r.pos()..];
    let mut z = flate2::read::ZlibDecoder::new(stream);
    // The header fields stream out of the decoder; their counts then bound the payload read.
    let mut head = Vec::new();
    let read_exact =
        |z: &mut flate2::read::ZlibDecoder<&[u8]>, n: u64, out: &mut Vec<u8>| -> Result<()> {
            let got = z.take(n).read_to_end(out).map_err(|e| {
                Error::format(
                    path,
                    format!("{KIND}: compressed shape data is truncated or corrupt: {e}"),
                )
            })?;
            if (got as u64) < n {
                return Err(Error::format(
                    path,
                    format!("{KIND}: compressed shape data ends early (truncated file?)"),
                ));
            }
            Ok(())
        };
    read_exact(&mut z, 4, &mut head)?;
    let flags = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
    let name = if version == 4 {
        let mut s = Vec::new();
        loop {
            let mut c = Vec::with_capacity(1);
            read_exact(&mut z, 1, &mut c)?;
            if c[0] == 0 {
                break;
            }
            if s.len() > 1 << 16 {
                return Err(Error::format(
                    path,
                    format!("{KIND}: shape name is not terminated"),
                ));
            }
            s.push(c[0]);
        }
        String::from_utf8_lossy(&s).into_owned()
    } else {
        String::new()
    };
    let mut counts = Vec::with_capacity(16);
    read_exact(&mut z, 16, &mut counts)?;
    let mut c = Reader::new(&counts, path, KIND);
    c.set_part("shape counts");
    let nv = c.u64("vertex count")?;
    let nt = c.u64("triangle count")?;
    let double = match flags & (SINGLE | DOUBLE) {
        SINGLE => false,
        DOUBLE => true,
        _ => {
            return Err(Error::format(
                path,
                format!("{KIND}: flags {flags:#x} give no single/double precision"),
            ));
        }
    };
    let scalar: u64 = if double { 8 } else { 4 };
    let per_vertex = 3
        + if flags & HAS_NORMALS != 0 { 3 } else { 0 }
        + if flags & HAS_TEXCOORDS != 0 { 2 } else { 0 }
        + if flags & HAS_COLORS != 0 { 3 } else { 0 };
    let index_size: u64 = if nv > u32::MAX as u64 { 8 } else { 4 };
    check_counts(path, nv, nt, stream.len(), avail)?;
    let need = nv * per_vertex * scalar + nt * 3 * index_size;
    let mut payload = Vec::with_capacity(need as usize);
    read_exact(&mut z, need, &mut payload)?;
    // The payload's arrays, decoded in parallel straight into the mesh's.
    let (mut rest, size) = (payload.as_slice(), scalar as usize);
    let mut take = |n: u64| {
        let (a, b) = rest.split_at(n as usize);
        rest = b;
        a
    };
    let vec3s = |b: &[u8]| -> Vec<Vec3> {
        b.par_chunks_exact(3 * size)
            .map(|c| Vec3::new(decode(c, size, 0), decode(c, size, 1), decode(c, size, 2)))
            .collect()
    };
    let positions = vec3s(take(nv * 3 * scalar));
    let normals = if flags & HAS_NORMALS != 0 {
        vec3s(take(nv * 3 * scalar))
    } else {
        Vec::new()
    };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        take(nv * 2 * scalar)
            .par_chunks_exact(2 * size)
            .map(|c| Vec2::new(decode(c, size, 0), decode(c, size, 1)))
            .collect()
    } else {
        Vec::new()
    };
    if flags & HAS_COLORS != 0 {
        take(nv * 3 * scalar); // vertex colours are not used
    }
    let isize = index_size as usize;
    let tris = take(nt * 3 * index_size);
    let index = |c: &[u8], k: usize| -> u64 {
        let b = &c[k * isize..];
        if isize == 8 {
            u64::from_le_bytes(b[..8].try_into().expect("8 bytes"))
        } else {
            u32::from_le_bytes(b[..4].try_into().expect("4 bytes")) as u64
        }
    };
    if let Some((t, i)) = tris
        .par_chunks_exact(3 * isize)
        .enumerate()
        .find_map_first(|(t, c)| {
            (0..3)
                .map(|k| index(c, k))
                .find(|&i| i >= nv)
                .map(|i| (t, i))
        })
    {
        return Err(Error::format(
            path,
            format!("{KIND}: triangle {t} uses vertex {i}, but there are {nv} vertices"),
        ));
    }
    let indices = tris
        .par_chunks_exact(3 * isize)
        .map(|c| [index(c, 0) as u32, index(c, 1) as u32, index(c, 2) as u32])
        .collect();
    drop(payload);
    if let Some(p) = positions.par_iter().position_first(|p| !p.is_finite()) {
        return Err(Error::format(
            path,
            format!("{KIND}: vertex {p} has a non-finite position"),
        ));
    }
    Ok(SerializedShape {
        mesh: LocalMesh {
            positions,
            normals,
            uvs,
            indices,
            attributes: Vec::new(),
        },
        face_normals: flags & FACE_NORMALS != 0,
        name,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// The file name errors are reported against.
    fn pth() -> &'static Path {
        Path::new("mesh.serialized")
    }

    /// name, extra flags, positions, uvs, triangles.
    type TestShape<'a> = (&'a str, u32, Vec<[f32; 3]>, Vec<[f32; 2]>, Vec<[u32; 3]>);

    /// Writes shapes in Mitsuba's format (v4, single precision, u64 shape table).
    fn write(shapes: &[TestShape]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for (name, extra, pos, uv, tri) in shapes {
            offsets.push(out.len() as u64);
            out.extend_from_slice(&MAGIC.to_le_bytes());
            out.extend_from_slice(&4u16.to_le_bytes());
            let mut raw = Vec::new();
            let flags = SINGLE | extra | if uv.is_empty() { 0 } else { HAS_TEXCOORDS };
            raw.extend_from_slice(&flags.to_le_bytes());
            raw.extend_from_slice(name.as_bytes());
            raw.push(0);
            raw.extend_from_slice(&(pos.len() as u64).to_le_bytes());
            raw.extend_from_slice(&(tri.len() as u64).to_le_bytes());
            for v in pos.iter().flatten().chain(uv.iter().flatten()) {
                raw.extend_from_slice(&v.to_le_bytes());
            }
            for i in tri.iter().flatten() {
                raw.extend_from_slice(&i.to_le_bytes());
            }
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            z.write_all(&raw).unwrap();
            out.extend_from_slice(&z.finish().unwrap());
        }
        for o in &offsets {
            out.extend_from_slice(&o.to_le_bytes());
        }
        out.extend_from_slice(&(offsets.len() as u32).to_le_bytes());
        out
    }

    fn two_shapes() -> Vec<u8> {
        write(&[
            (
                "tri",
                0,
                vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                vec![],
                vec![[0, 1, 2]],
            ),
            (
                "quad",
                FACE_NORMALS,
                vec![
                    [0.0, 0.0, 1.0],
                    [2.0, 0.0, 1.0],
                    [2.0, 2.0, 1.0],
                    [0.0, 2.0, 1.0],
                ],
                vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
                vec![[0, 1, 2], [0, 2, 3]],
            ),
        ])
    }

    #[test]
    fn reads_shapes_by_index() {
        let b = two_shapes();
        let a = parse(&b, pth(), 0, None).unwrap();
        assert_eq!((a.name.as_str(), a.face_normals), ("tri", false));
        assert_eq!(a.mesh.positions[1], Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(a.mesh.indices, vec![[0, 1, 2]]);
        let q = parse(&b, pth(), 1, None).unwrap();
        assert_eq!((q.name.as_str(), q.face_normals), ("quad", true));
        assert_eq!(q.mesh.uvs[2], Vec2::new(1.0, 1.0));
        assert_eq!(q.mesh.indices.len(), 2);
        let e = parse(&b, pth(), 2, None).unwrap_err().to_string();
        assert!(e.contains("holds 2 shapes"), "{e}");
    }

    /// tests/data/two-shapes.serialized is written by reference-images/make_serialized_fixture.py,
    /// which checks that Mitsuba 3.9 reads these same values from it (f32 then f64 shapes).
    #[test]
    fn reads_the_file_mitsuba_reads() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/two-shapes.serialized");
        let a = load(&p, 0).unwrap();
        assert_eq!(a.mesh.positions.len(), 3);
        assert_eq!(a.mesh.normals[1], Vec3::new(0.0, 0.6, 0.8));
        assert!(a.mesh.uvs.is_empty());
        let q = load(&p, 1).unwrap();
        assert_eq!(q.name, "quad");
        assert_eq!(q.mesh.positions[2], Vec3::new(2.0, 2.0, 1.0));
        assert_eq!(q.mesh.uvs[1], Vec2::new(1.0, 0.0));
        assert_eq!(q.mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(q.mesh.normals.is_empty());
        let e = load(&p.with_extension("missing"), 0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("two-shapes.missing"), "{e}");
    }

    #[test]
    fn bad_files_are_clear_errors() {
        let b = two_shapes();
        let err = |b: &[u8], i: u32| parse(b, pth(), i, None).unwrap_err().to_string();
        assert!(err(&b[..30], 0).contains("truncated"));
        assert!(err(b"ply\n", 0).contains("magic"));
        assert!(err(&[], 0).contains("truncated"));
        assert!(err(&[], 0).contains("mesh.serialized"));
        let mut bad = b.clone();
        let n = bad.len();
        bad[n - 4..].copy_from_slice(&1000u32.to_le_bytes());
        assert!(err(&bad, 5).contains("past the start"));
        // A triangle index beyond the vertices.
        let b = write(&[("x", 0, vec![[0.0; 3]; 3], vec![], vec![[0, 1, 7]])]);
        assert!(err(&b, 0).contains("vertex 7"));
    }

    /// A one-shape v4 file with the given flags and declared counts over `payload`.
    fn shape_file(flags: u32, nv: u64, nt: u64, payload: &[u8]) -> Vec<u8> {
        let mut raw = Vec::new();
        raw.extend_from_slice(&flags.to_le_bytes());
        raw.extend_from_slice(b"s\0");
        raw.extend_from_slice(&nv.to_le_bytes());
        raw.extend_from_slice(&nt.to_le_bytes());
        raw.extend_from_slice(payload);
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        z.write_all(&raw).unwrap();
        let mut out = MAGIC.to_le_bytes().to_vec();
        out.extend_from_slice(&4u16.to_le_bytes());
        out.extend_from_slice(&z.finish().unwrap());
        out.extend_from_slice(&0u64.to_le_bytes());
        out.extend_from_slice(&1u32.to_le_bytes());
        out
    }

    #[test]
    fn every_attribute_and_precision_round_trips() {
        let mut rng = crate::math::Pcg32::new(3, 1);
        let (nv, nt) = (2000usize, 3900usize);
        let vals: Vec<f64> = (0..nv * 11)
            .map(|_| rng.next_f32() as f64 * 8.0 - 4.0 + 1e-9)
            .collect();
        let tris: Vec<u32> = (0..nt * 3).map(|_| rng.next_below(nv as u32)).collect();
        for double in [false, true] {
            for extra in [
                0,
                HAS_NORMALS,
                HAS_TEXCOORDS | HAS_COLORS,
                HAS_NORMALS | HAS_TEXCOORDS | HAS_COLORS,
            ] {
                let flags = extra | if double { DOUBLE } else { SINGLE };
                let (n, uv, col) = (
                    extra & HAS_NORMALS != 0,
                    extra & HAS_TEXCOORDS != 0,
                    extra & HAS_COLORS != 0,
                );
                let per =
                    3 + if n { 3 } else { 0 } + if uv { 2 } else { 0 } + if col { 3 } else { 0 };
                let mut payload = Vec::new();
                for &v in &vals[..nv * per] {
                    if double {
                        payload.extend_from_slice(&v.to_le_bytes());
                    } else {
                        payload.extend_from_slice(&(v as f32).to_le_bytes());
                    }
                }
                for i in &tris {
                    payload.extend_from_slice(&i.to_le_bytes());
                }
                let b = shape_file(flags, nv as u64, nt as u64, &payload);
                let m = parse(&b, pth(), 0, None).unwrap().mesh;
                let f = |k: usize| vals[k] as f32;
                let v3 = |o: usize, i: usize| {
                    Vec3::new(f(o + 3 * i), f(o + 3 * i + 1), f(o + 3 * i + 2))
                };
                assert_eq!(m.positions, (0..nv).map(|i| v3(0, i)).collect::<Vec<_>>());
                let mut o = 3 * nv;
                if n {
                    assert_eq!(m.normals, (0..nv).map(|i| v3(o, i)).collect::<Vec<_>>());
                    o += 3 * nv;
                } else {
                    assert!(m.normals.is_empty());
                }
                if uv {
                    let want: Vec<Vec2> = (0..nv)
                        .map(|i| Vec2::new(f(o + 2 * i), f(o + 2 * i + 1)))
                        .collect();
                    assert_eq!(m.uvs, want);
                } else {
                    assert!(m.uvs.is_empty());
                }
                let want: Vec<[u32; 3]> =
                    tris.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
                assert_eq!(m.indices, want);
            }
        }
    }

    #[test]
    fn lying_or_huge_counts_fail_before_allocating() {
        let err = |b: &[u8], avail| parse(b, pth(), 0, avail).unwrap_err().to_string();
        // 2^30 vertices declared over a few bytes: a count that lies.
        let e = err(&shape_file(SINGLE, 1 << 30, 1, &[0; 64]), None);
        assert!(
            e.contains("mesh.serialized") && e.contains("counts are wrong"),
            "{e}"
        );
        let e = err(&shape_file(SINGLE, 3, (1 << 31) / 3 + 1, &[]), None);
        assert!(e.contains("2^31"), "{e}");
        let e = err(&shape_file(SINGLE, 1 << 33, 1, &[]), None);
        assert!(e.contains("u32"), "{e}");
        let e = err(&two_shapes(), Some(100));
        assert!(e.contains("memory is available"), "{e}");
        // A non-finite position is reported with its vertex.
        let mut payload = Vec::new();
        for v in [0.0f32, 0.0, 0.0, 1.0, f32::NAN, 0.0, 0.0, 1.0, 0.0] {
            payload.extend_from_slice(&v.to_le_bytes());
        }
        for i in [0u32, 1, 2] {
            payload.extend_from_slice(&i.to_le_bytes());
        }
        let e = err(&shape_file(SINGLE, 3, 1, &payload), None);
        assert!(e.contains("vertex 1 has a non-finite"), "{e}");
    }
}
