//! Wavefront OBJ meshes, with Mitsuba's conventions: polygons fan-triangulated, vertices unique
//! per (position, uv, normal) triple within each object (`o`/`g`) in order of first use, all
//! objects merged into one mesh, materials, points and lines ignored, and uv's v flipped
//! (v ← 1 − v) when `flip_tex_coords` is set (Mitsuba's default).
//!
//! The file is parsed in parallel: it is cut into line-aligned chunks, a first pass counts each
//! chunk's lines, `v`/`vt`/`vn` records and face triangles (so the counts are checked before
//! anything is allocated for them), then every chunk parses straight into its own part of the
//! vertex arrays, resolving relative (negative) indices against the counts before it.

use super::shapes::{LocalMesh, Shape, available_memory, check_mesh_fits};
use crate::math::{Vec2, Vec3};
use crate::plugin::Properties;
use crate::{Error, Result};
use rayon::prelude::*;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::ops::Range;
use std::path::Path;

/// A face corner without a uv or normal index.
const NONE: u32 = u32::MAX;

/// Mitsuba's `obj` shape: `filename`, `face_normals`, `flip_tex_coords` (true).
pub fn from_props(p: &dyn Properties) -> Result<Shape> {
    Shape::mesh_file_from_props(p, true, load)
}

/// Loads an OBJ file into object space. Errors name the file and, for bad records, the line.
pub fn load(path: &Path, flip_tex_coords: bool) -> Result<LocalMesh> {
    let avail = available_memory();
    let len = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    if let Some(a) = avail
        && len > a
    {
        return Err(Error::format(
            path,
            format!("the file has {len} bytes, more than the {a} bytes of memory available"),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let chunk = (bytes.len() / (8 * rayon::current_num_threads())).max(1 << 20);
    parse(path, &bytes, flip_tex_coords, avail, chunk)
}

/// What a stretch of the file holds, counted before it is parsed.
#[derive(Clone, Copy, Debug, Default)]
struct Counts {
    lines: u64,
    v: u64,
    vt: u64,
    vn: u64,
    triangles: u64,
}

impl Counts {
    fn add(self, o: Counts) -> Counts {
        Counts {
            lines: self.lines + o.lines,
            v: self.v + o.v,
            vt: self.vt + o.vt,
            vn: self.vn + o.vn,
            triangles: self.triangles + o.triangles,
        }
    }
}

/// One chunk's faces: three (v, vt, vn) corners per triangle, and the triangle counts at which
/// an `o` or `g` record starts a new object.
struct Faces {
    corners: Vec<[u32; 3]>,
    objects: Vec<usize>,
}

/// The whitespace-separated words of a line.
fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace() || *b == 0x0b)
        .filter(|w| !w.is_empty())
}

/// Cuts `bytes` into ranges of about `target` bytes that end after a newline (or at the end).
fn chunks(bytes: &[u8], target: usize) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < bytes.len() {
        let mut end = (start + target.max(1)).min(bytes.len());
        end = bytes[end..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| end + i + 1);
        out.push(start..end);
        start = end;
    }
    out
}

/// First pass over a chunk: its lines, vertex records and face triangles.
fn count(text: &[u8]) -> Counts {
    let mut c = Counts {
        lines: text.iter().filter(|&&b| b == b'\n').count() as u64,
        ..Counts::default()
    };
    for line in text.split(|&b| b == b'\n') {
        let mut w = words(line);
        match w.next() {
            Some(b"v") => c.v += 1,
            Some(b"vt") => c.vt += 1,
            Some(b"vn") => c.vn += 1,
            Some(b"f") => c.triangles += (w.count() as u64).saturating_sub(2),
            _ => {}
        }
    }
    c
}

/// Parses the words `w` of a `what` record, N or more numbers finite as f32; returns the first N.
fn floats<'a, const N: usize>(
    w: impl Iterator<Item = &'a [u8]>,
    what: &str,
) -> std::result::Result<[f32; N], String> {
    let mut out = [0.0f32; N];
    let mut k = 0;
    for tok in w {
        let s = std::str::from_utf8(tok).unwrap_or("");
        let v: f32 = s.parse().map_err(|_| {
            format!(
                "cannot parse {what} value \"{}\"",
                String::from_utf8_lossy(tok)
            )
        })?;
        if !v.is_finite() {
            return Err(format!("non-finite {what} value \"{s}\""));
        }
        if k < N {
            out[k] = v;
        }
        k += 1;
    }
    if k < N {
        return Err(format!("{what} has {k} values, expected {N}"));
    }
    Ok(out)
}

/// Where a chunk starts (the counts before it) and the file's totals.
struct Place {
    at: Counts,
    total: Counts,
}

/// Resolves one index of a face corner: 1-based, or negative (relative to the `seen` records
/// before this line); `total` records exist in the file.
fn resolve(word: &[u8], seen: u64, total: u64, what: &str) -> std::result::Result<u32, String> {
    let x: i64 = std::str::from_utf8(word)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| {
            format!(
                "cannot parse face index \"{}\"",
                String::from_utf8_lossy(word)
            )
        })?;
    let i = match x {
        0 => return Err(format!("face index 0 (OBJ {what} indices start at 1)")),
        x if x > 0 => x - 1,
        x => seen as i64 + x,
    };
    if i < 0 || i as u64 >= total {
        return Err(format!(
            "face references missing {what} {x} (the file has {total})"
        ));
    }
    Ok(i as u32)
}

/// Second pass over a chunk: vertex records into its parts of the arrays, faces into corners.
fn parse_chunk(
    text: &[u8],
    place: &Place,
    count: Counts,
    pos: &mut [Vec3],
    uv: &mut [Vec2],
    nrm: &mut [Vec3],
) -> std::result::Result<Faces, (u64, String)> {
    let mut faces = Faces {
        corners: Vec::with_capacity(3 * count.triangles as usize),
        objects: Vec::new(),
    };
    let (mut v, mut vt, mut vn) = (0usize, 0usize, 0usize);
    let mut poly: Vec<[u32; 3]> = Vec::new();
    for (ln, line) in text.split(|&b| b == b'\n').enumerate() {
        let fail = |m: String| (place.at.lines + ln as u64 + 1, m);
        let mut w = words(line);
        match w.next() {
            Some(b"v") => {
                let what = "vertex position";
                let [x, y, z] = floats::<3>(w.by_ref().take(3), what).map_err(fail)?;
                let fourth = w.next();
                let w = match (fourth, w.count()) {
                    (None, _) => 1.0,
                    (Some(t), 0) => floats::<1>(std::iter::once(t), what).map_err(fail)?[0],
                    (Some(_), 2) => 1.0, // an RGB colour, not used
                    (Some(_), n) => {
                        return Err(fail(format!(
                            "vertex position has {} values, expected 3, 4 (with w) or 6 (with a colour)",
                            n + 4
                        )));
                    }
                };
                if w == 0.0 {
                    return Err(fail("vertex position has w = 0".into()));
                }
                let q = Vec3::new(x, y, z);
                let q = if w == 1.0 { q } else { q / w };
                if !q.is_finite() {
                    return Err(fail(
                        "vertex position is non-finite after dividing by w".into(),
                    ));
                }
                pos[v] = q;
                v += 1;
            }
            Some(b"vt") => {
                let [a, b] = floats::<2>(w, "texture coordinate").map_err(fail)?;
                uv[vt] = Vec2::new(a, b);
                vt += 1;
            }
            Some(b"vn") => {
                let [x, y, z] = floats::<3>(w, "vertex normal").map_err(fail)?;
                nrm[vn] = Vec3::new(x, y, z);
                vn += 1;
            }
            Some(b"f") => {
                poly.clear();
                for word in w {
                    let mut parts = word.split(|&b| b == b'/');
                    let mut c = [NONE; 3];
                    for (k, part) in parts.by_ref().take(3).enumerate() {
                        if part.is_empty() {
                            if k == 0 {
                                return Err(fail(format!(
                                    "face corner \"{}\" has no vertex index",
                                    String::from_utf8_lossy(word)
                                )));
                            }
                            continue;
                        }
                        let (seen, total, what) = match k {
                            0 => (place.at.v + v as u64, place.total.v, "vertex"),
                            1 => (
                                place.at.vt + vt as u64,
                                place.total.vt,
                                "texture coordinate",
                            ),
                            _ => (place.at.vn + vn as u64, place.total.vn, "vertex normal"),
                        };
                        // A uv or normal index in a file without any is ignored (as tobj did).
                        if k > 0 && total == 0 {
                            continue;
                        }
                        c[k] = resolve(part, seen, total, what).map_err(fail)?;
                    }
                    if parts.next().is_some() {
                        return Err(fail(format!(
                            "face corner \"{}\" has more than three indices",
                            String::from_utf8_lossy(word)
                        )));
                    }
                    poly.push(c);
                }
                for k in 2..poly.len() {
                    faces
                        .corners
                        .extend_from_slice(&[poly[0], poly[k - 1], poly[k]]);
                }
            }
            Some(b"o") | Some(b"g") => faces.objects.push(faces.corners.len() / 3),
            _ => {}
        }
    }
    Ok(faces)
}

/// A hasher for face-corner keys (three u32 indices): fast, and mixes all bits into the top
/// and bottom ones the hash table uses.
#[derive(Default)]
struct CornerHasher(u64);

impl Hasher for CornerHasher {
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..b.len()].copy_from_slice(b);
            self.write_u64(u64::from_le_bytes(w));
        }
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(26) ^ i).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
    fn finish(&self) -> u64 {
        let mut x = self.0;
        x ^= x >> 33;
        x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
        x ^ (x >> 33)
    }
}

/// Parses an OBJ file held in `bytes` (errors name `path`), in chunks of about `chunk` bytes,
/// refusing counts that do not fit in `avail` bytes of memory before allocating for them.
fn parse(
    path: &Path,
    bytes: &[u8],
    flip_tex_coords: bool,
    avail: Option<u64>,
    chunk: usize,
) -> Result<LocalMesh> {
    let ranges = chunks(bytes, chunk);
    let counts: Vec<Counts> = ranges
        .par_iter()
        .map(|r| count(&bytes[r.clone()]))
        .collect();
    let total = counts.iter().fold(Counts::default(), |a, &c| a.add(c));
    check_counts(total, avail).map_err(|m| Error::format(path, m))?;
    let mut pos = vec![Vec3::ZERO; total.v as usize];
    let mut uv = vec![Vec2::ZERO; total.vt as usize];
    let mut nrm = vec![Vec3::ZERO; total.vn as usize];
    // Each chunk's place in the file and its own parts of the vertex arrays.
    let mut jobs = Vec::with_capacity(ranges.len());
    {
        let (mut p, mut t, mut n) = (pos.as_mut_slice(), uv.as_mut_slice(), nrm.as_mut_slice());
        let mut at = Counts::default();
        for (r, &c) in ranges.iter().zip(&counts) {
            let (a, rest) = std::mem::take(&mut p).split_at_mut(c.v as usize);
            p = rest;
            let (b, rest) = std::mem::take(&mut t).split_at_mut(c.vt as usize);
            t = rest;
            let (d, rest) = std::mem::take(&mut n).split_at_mut(c.vn as usize);
            n = rest;
            jobs.push((r.clone(), Place { at, total }, c, a, b, d));
            at = at.add(c);
        }
    }
    let parsed: Vec<_> = jobs
        .into_par_iter()
        .map(|(r, place, c, a, b, d)| parse_chunk(&bytes[r], &place, c, a, b, d))
        .collect();
    let mut faces = Vec::with_capacity(parsed.len());
    for f in parsed {
        faces.push(f.map_err(|(line, m)| Error::format(path, format!("line {line}: {m}")))?);
    }
    let any_uv = faces
        .par_iter()
        .any(|f| f.corners.iter().any(|c| c[1] != NONE));
    let any_n = faces
        .par_iter()
        .any(|f| f.corners.iter().any(|c| c[2] != NONE));
    if any_n
        && faces
            .par_iter()
            .any(|f| f.corners.iter().any(|c| c[2] == NONE))
    {
        return Err(Error::format(
            path,
            "some faces have vertex normals and others do not (unsupported mix)",
        ));
    }
    let (keys, indices) = unique_vertices(&faces, total, any_uv || any_n);
    drop(faces);
    if indices.is_empty() {
        return Err(Error::format(path, "the OBJ file contains no faces"));
    }
    let identity =
        keys.len() == pos.len() && keys.par_iter().enumerate().all(|(i, k)| k[0] == i as u32);
    let positions = if identity {
        pos
    } else {
        keys.par_iter().map(|k| pos[k[0] as usize]).collect()
    };
    let uvs = if any_uv {
        keys.par_iter()
            .map(|k| {
                let t = if k[1] == NONE {
                    Vec2::ZERO
                } else {
                    uv[k[1] as usize]
                };
                if flip_tex_coords {
                    Vec2::new(t.x, 1.0 - t.y)
                } else {
                    t
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    let normals = if any_n {
        keys.par_iter().map(|k| nrm[k[2] as usize]).collect()
    } else {
        Vec::new()
    };
    Ok(LocalMesh {
        positions,
        normals,
        uvs,
        indices,
        attributes: Vec::new(),
    })
}

/// Refuses a file whose counted records cannot be indexed by u32 or do not fit in memory.
fn check_counts(total: Counts, avail: Option<u64>) -> std::result::Result<(), String> {
    if total.vt >= NONE as u64 || total.vn >= NONE as u64 {
        return Err(format!(
            "{} texture coordinates and {} normals: more than u32 indices can address",
            total.vt, total.vn
        ));
    }
    check_mesh_fits(total.v.max(total.vt).max(total.vn), total.triangles, avail)
}

/// Makes vertices unique per (v, vt, vn) corner within each object, numbered in order of first
/// use: the corner key of each vertex, and the triangles in those numbers. `keyed` is false when
/// no corner has a uv or normal index (then the position index alone is the key).
fn unique_vertices(faces: &[Faces], total: Counts, keyed: bool) -> (Vec<[u32; 3]>, Vec<[u32; 3]>) {
    let triangles: usize = faces.iter().map(|f| f.corners.len() / 3).sum();
    let mut indices = Vec::with_capacity(triangles);
    let mut keys: Vec<[u32; 3]> = Vec::new();
    let mut by_v = if keyed {
        Vec::new()
    } else {
        vec![NONE; total.v as usize]
    };
    let mut by_key: HashMap<[u32; 3], u32, BuildHasherDefault<CornerHasher>> = HashMap::default();
    let mut object_start = 0;
    let mut new_object =
        |keys: &Vec<[u32; 3]>, by_v: &mut Vec<u32>, by_key: &mut HashMap<_, _, _>| {
            for k in &keys[object_start..] {
                if let Some(e) = by_v.get_mut(k[0] as usize) {
                    *e = NONE;
                }
            }
            by_key.clear();
            object_start = keys.len();
        };
    for f in faces {
        let mut objects = f.objects.iter().peekable();
        for (t, tri) in f.corners.chunks_exact(3).enumerate() {
            while objects.next_if(|&&o| o == t).is_some() {
                new_object(&keys, &mut by_v, &mut by_key);
            }
            let mut out = [0u32; 3];
            for (o, c) in out.iter_mut().zip(tri) {
                let next = keys.len() as u32;
                let id = if keyed {
                    *by_key.entry(*c).or_insert(next)
                } else {
                    let e = &mut by_v[c[0] as usize];
                    if *e == NONE {
                        *e = next;
                    }
                    *e
                };
                if id == next {
                    keys.push(*c);
                }
                *o = id;
            }
            indices.push(out);
        }
        for _ in objects {
            new_object(&keys, &mut by_v, &mut by_key);
        }
    }
    (keys, indices)
}

#[cfg(test)]
#[path = "obj_tests.rs"]
mod tests;
