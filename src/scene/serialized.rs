//! Mitsuba's `serialized` mesh files: one or more shapes, each a little-endian header (u16
//! magic 0x041C, u16 version 3 or 4) followed by a zlib stream holding u32 flags, (v4) the
//! NUL-terminated shape name, u64 vertex and triangle counts, positions, optional normals, uvs
//! and colours (f32 or f64 by flag) and the triangle indices (u32, or u64 beyond 2³² vertices).
//! The file ends with the byte offset of each shape (u64 in v4, u32 in v3) and the u32 shape
//! count, which `shape_index` selects by.

use super::shapes::LocalMesh;
use crate::math::{Vec2, Vec3};
use crate::{Error, Result};
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
    /// The file asks for face normals (flag 0x0010).
    pub face_normals: bool,
    /// Shape name (version 4 files; empty otherwise).
    pub name: String,
}

/// Reads shape `shape_index` of a serialized file.
pub fn load(path: &Path, shape_index: u32) -> Result<SerializedShape> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse(&bytes, shape_index).map_err(|m| Error::format(path, m))
}

fn le_u16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?))
}

fn le_u32(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

fn le_u64(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

/// Parses shape `index` of the file `b`; errors are messages (the caller names the file).
fn parse(b: &[u8], index: u32) -> std::result::Result<SerializedShape, String> {
    let header = |at: usize| -> std::result::Result<u16, String> {
        let magic = le_u16(b, at).ok_or("file too short for a shape header")?;
        if magic != MAGIC {
            return Err(format!(
                "not a Mitsuba serialized mesh (magic {magic:#06x} at byte {at}, expected 0x041c)"
            ));
        }
        let version = le_u16(b, at + 2).ok_or("file too short for a shape header")?;
        if version != 3 && version != 4 {
            return Err(format!(
                "serialized format version {version} is not supported (3 or 4)"
            ));
        }
        Ok(version)
    };
    let version = header(0)?;
    let offset = if index == 0 {
        0
    } else {
        let n = b.len();
        let count = n
            .checked_sub(4)
            .and_then(|at| le_u32(b, at))
            .ok_or("file too short for the shape table")?;
        if index >= count {
            return Err(format!(
                "shape_index {index} is out of range: the file holds {count} shapes"
            ));
        }
        let k = (count - index) as usize;
        let o = if version == 4 {
            n.checked_sub(4 + 8 * k).and_then(|at| le_u64(b, at))
        } else {
            n.checked_sub(4 * (k + 1))
                .and_then(|at| le_u32(b, at))
                .map(u64::from)
        };
        o.ok_or("shape table runs past the start of the file")? as usize
    };
    let version = header(offset)?;
    let stream = b.get(offset + 4..).ok_or("shape offset beyond the file")?;
    let mut r = Stream {
        z: std::io::BufReader::new(flate2::read::ZlibDecoder::new(stream)),
    };
    let flags = r.u32()?;
    let name = if version == 4 {
        let mut s = Vec::new();
        loop {
            let c = r.bytes::<1>()?[0];
            if c == 0 {
                break;
            }
            if s.len() > 1 << 16 {
                return Err("shape name is not terminated".into());
            }
            s.push(c);
        }
        String::from_utf8_lossy(&s).into_owned()
    } else {
        String::new()
    };
    let nv = r.u64()?;
    let nt = r.u64()?;
    let double = match flags & (SINGLE | DOUBLE) {
        SINGLE => false,
        DOUBLE => true,
        _ => return Err(format!("flags {flags:#x} give no single/double precision")),
    };
    // Guard against absurd counts before allocating (the stream must hold the data anyway).
    let scalar = if double { 8 } else { 4 };
    let index_size: u64 = if nv > u32::MAX as u64 { 8 } else { 4 };
    let need = nv
        .checked_mul(3 * scalar)
        .and_then(|v| v.checked_add(nt.checked_mul(3 * index_size)?));
    match need {
        Some(n) if n <= 1 << 36 && nv <= u32::MAX as u64 => {}
        _ => {
            return Err(format!(
                "implausible sizes: {nv} vertices, {nt} triangles (at most 2^32 vertices)"
            ));
        }
    }
    let (nv, nt) = (nv as usize, nt as usize);
    let vec3s = |r: &mut Stream| -> std::result::Result<Vec<Vec3>, String> {
        let mut v = Vec::with_capacity(nv.min(1 << 24));
        for _ in 0..nv {
            let (x, y, z) = (r.real(double)?, r.real(double)?, r.real(double)?);
            v.push(Vec3::new(x, y, z));
        }
        Ok(v)
    };
    let positions = vec3s(&mut r)?;
    let normals = if flags & HAS_NORMALS != 0 {
        vec3s(&mut r)?
    } else {
        Vec::new()
    };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        let mut v = Vec::with_capacity(nv.min(1 << 24));
        for _ in 0..nv {
            v.push(Vec2::new(r.real(double)?, r.real(double)?));
        }
        v
    } else {
        Vec::new()
    };
    if flags & HAS_COLORS != 0 {
        vec3s(&mut r)?; // vertex colours are not used
    }
    let mut indices = Vec::with_capacity(nt.min(1 << 24));
    for t in 0..nt {
        let mut tri = [0u32; 3];
        for v in &mut tri {
            let i = r.u32()?;
            if i as usize >= nv {
                return Err(format!(
                    "triangle {t} uses vertex {i}, but there are {nv} vertices"
                ));
            }
            *v = i;
        }
        indices.push(tri);
    }
    if let Some(p) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!("vertex {p} has a non-finite position"));
    }
    Ok(SerializedShape {
        mesh: LocalMesh {
            positions,
            normals,
            uvs,
            indices,
        },
        face_normals: flags & FACE_NORMALS != 0,
        name,
    })
}

/// Little-endian reads from the decompressed shape stream.
struct Stream<'a> {
    z: std::io::BufReader<flate2::read::ZlibDecoder<&'a [u8]>>,
}

impl Stream<'_> {
    fn bytes<const N: usize>(&mut self) -> std::result::Result<[u8; N], String> {
        let mut a = [0u8; N];
        self.z.read_exact(&mut a).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                "compressed shape data ends early (truncated file?)".to_string()
            } else {
                format!("cannot decompress the shape data: {e}")
            }
        })?;
        Ok(a)
    }
    fn u32(&mut self) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(self.bytes()?))
    }
    fn u64(&mut self) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(self.bytes()?))
    }
    fn real(&mut self, double: bool) -> std::result::Result<f32, String> {
        Ok(if double {
            f64::from_le_bytes(self.bytes()?) as f32
        } else {
            f32::from_le_bytes(self.bytes()?)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

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
        let a = parse(&b, 0).unwrap();
        assert_eq!((a.name.as_str(), a.face_normals), ("tri", false));
        assert_eq!(a.mesh.positions[1], Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(a.mesh.indices, vec![[0, 1, 2]]);
        let q = parse(&b, 1).unwrap();
        assert_eq!((q.name.as_str(), q.face_normals), ("quad", true));
        assert_eq!(q.mesh.uvs[2], Vec2::new(1.0, 1.0));
        assert_eq!(q.mesh.indices.len(), 2);
        let e = parse(&b, 2).unwrap_err();
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
        assert!(parse(&b[..30], 0).unwrap_err().contains("ends early"));
        assert!(parse(b"ply\n", 0).unwrap_err().contains("magic"));
        assert!(parse(&[], 0).unwrap_err().contains("too short"));
        let mut bad = b.clone();
        let n = bad.len();
        bad[n - 4..].copy_from_slice(&1000u32.to_le_bytes());
        assert!(parse(&bad, 5).unwrap_err().contains("past the start"));
        // A triangle index beyond the vertices.
        let b = write(&[("x", 0, vec![[0.0; 3]; 3], vec![], vec![[0, 1, 7]])]);
        assert!(parse(&b, 0).unwrap_err().contains("vertex 7"));
    }
}
