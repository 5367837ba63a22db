//! Stanford PLY meshes, hand-written reader: `ascii 1.0` and `binary_little_endian 1.0`
//! (big endian is rejected with a clear error). Vertex `x y z`, optional `nx ny nz` and uv
//! (`u v`, `s t`, `texture_u texture_v`, `texture_s texture_t`); faces from the `vertex_indices`
//! (or `vertex_index`) list, polygons fan-triangulated; other elements and properties skipped.

use super::shapes::{LocalMesh, Shape};
use crate::geometry::MeshAttribute;
use crate::geometry::mesh_attribute::group_fields;
use crate::math::{Vec2, Vec3};
use crate::plugin::Properties;
use crate::{Error, Result};
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }
    /// The little-endian value at the start of `b` (at least `size()` bytes).
    #[inline]
    fn decode(self, b: &[u8]) -> f64 {
        match self {
            Ty::I8 => b[0] as i8 as f64,
            Ty::U8 => b[0] as f64,
            Ty::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Ty::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Ty::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::F64 => f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
        }
    }
    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    ty: Ty,
    /// For list properties: the type of the count.
    list_count: Option<Ty>,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

/// Reads values either from ASCII tokens (with line numbers) or little-endian bytes.
enum Source<'a> {
    Ascii {
        tokens: Vec<(usize, &'a str)>,
        pos: usize,
    },
    Binary {
        data: &'a [u8],
        pos: usize,
    },
}

impl Source<'_> {
    fn read(&mut self, ty: Ty, path: &Path, what: &dyn Fn() -> String) -> Result<f64> {
        match self {
            Source::Ascii { tokens, pos } => {
                let Some(&(line, tok)) = tokens.get(*pos) else {
                    return Err(Error::format(
                        path,
                        format!("unexpected end of file in {}", what()),
                    ));
                };
                *pos += 1;
                let v: f64 = tok.parse().map_err(|_| {
                    Error::format(
                        path,
                        format!("line {line}: cannot parse \"{tok}\" in {}", what()),
                    )
                })?;
                if !v.is_finite() {
                    return Err(Error::format(
                        path,
                        format!("line {line}: non-finite value \"{tok}\" in {}", what()),
                    ));
                }
                if !matches!(ty, Ty::F32 | Ty::F64) && v.fract() != 0.0 {
                    return Err(Error::format(
                        path,
                        format!("line {line}: \"{tok}\" is not an integer in {}", what()),
                    ));
                }
                Ok(v)
            }
            Source::Binary { data, pos } => {
                let n = ty.size();
                let Some(b) = data.get(*pos..*pos + n) else {
                    return Err(Error::format(
                        path,
                        format!("unexpected end of file in {}", what()),
                    ));
                };
                *pos += n;
                let v = ty.decode(b);
                if !v.is_finite() {
                    return Err(Error::format(
                        path,
                        format!("non-finite value in {}", what()),
                    ));
                }
                Ok(v)
            }
        }
    }
}

/// Mitsuba's `ply` shape: `filename`, `face_normals`, `flip_tex_coords` (false).
pub fn from_props(p: &dyn Properties) -> Result<Shape> {
    Shape::mesh_file_from_props(p, false, load)
}

/// Loads a PLY file into object space; `flip_tex_coords` (Mitsuba default false for PLY) flips v.
pub fn load(path: &Path, flip_tex_coords: bool) -> Result<LocalMesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    // Header: ASCII lines up to and including "end_header\n".
    let marker = b"end_header";
    let hend = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .ok_or_else(|| Error::format(path, "not a PLY file (no end_header)"))?;
    let mut body = hend + marker.len();
    while body < bytes.len() && bytes[body] != b'\n' {
        body += 1;
    }
    body += 1;
    let header = String::from_utf8_lossy(&bytes[..hend]);
    let mut lines = header.lines().enumerate();
    match lines.next() {
        Some((_, l)) if l.trim() == "ply" => {}
        _ => return Err(Error::format(path, "not a PLY file (missing 'ply' magic)")),
    }
    let mut ascii = None;
    let mut elements: Vec<Element> = Vec::new();
    for (ln, line) in lines {
        let t: Vec<&str> = line.split_whitespace().collect();
        let bad = |m: &str| Error::format(path, format!("line {}: {m}", ln + 1));
        match t.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                ascii = Some(match t.get(1).copied() {
                    Some("ascii") => true,
                    Some("binary_little_endian") => false,
                    Some("binary_big_endian") => {
                        return Err(bad(
                            "binary_big_endian PLY files are not supported (convert to binary_little_endian or ascii)",
                        ));
                    }
                    _ => return Err(bad("unknown PLY format")),
                });
                if t.get(2).copied() != Some("1.0") {
                    return Err(bad("unsupported PLY version (expected 1.0)"));
                }
            }
            Some("element") => {
                let (Some(name), Some(count)) = (t.get(1), t.get(2)) else {
                    return Err(bad("malformed element line"));
                };
                let count = count.parse().map_err(|_| bad("malformed element count"))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?;
                let p = if t.get(1) == Some(&"list") {
                    let (Some(c), Some(i), Some(n)) = (t.get(2), t.get(3), t.get(4)) else {
                        return Err(bad("malformed list property"));
                    };
                    Property {
                        name: n.to_string(),
                        ty: Ty::parse(i).ok_or_else(|| bad("unknown property type"))?,
                        list_count: Some(Ty::parse(c).ok_or_else(|| bad("unknown property type"))?),
                    }
                } else {
                    let (Some(ty), Some(n)) = (t.get(1), t.get(2)) else {
                        return Err(bad("malformed property"));
                    };
                    Property {
                        name: n.to_string(),
                        ty: Ty::parse(ty)
                            .ok_or_else(|| bad(&format!("unknown property type '{ty}'")))?,
                        list_count: None,
                    }
                };
                el.props.push(p);
            }
            Some(other) => return Err(bad(&format!("unknown header keyword '{other}'"))),
        }
    }
    let ascii = ascii.ok_or_else(|| Error::format(path, "PLY header has no format line"))?;
    check_counts(path, &elements, ascii, bytes.len().saturating_sub(body))?;
    let header_lines = String::from_utf8_lossy(&bytes[..body.min(bytes.len())])
        .lines()
        .count();
    let data = &bytes[body.min(bytes.len())..];
    let text;
    let mut src = if ascii {
        text = String::from_utf8_lossy(data);
        let tokens = text
            .lines()
            .enumerate()
            .flat_map(|(i, l)| l.split_whitespace().map(move |t| (header_lines + i + 1, t)))
            .collect();
        Source::Ascii { tokens, pos: 0 }
    } else {
        Source::Binary { data, pos: 0 }
    };

    let mut out = LocalMesh::default();
    let mut saw_vertex = false;
    for el in &elements {
        let find = |n: &[&str]| {
            el.props
                .iter()
                .position(|p| n.contains(&p.name.as_str()) && p.list_count.is_none())
        };
        let (ix, iy, iz) = (find(&["x"]), find(&["y"]), find(&["z"]));
        let (inx, iny, inz) = (find(&["nx"]), find(&["ny"]), find(&["nz"]));
        let iu = find(&["u", "s", "texture_u", "texture_s"]);
        let iv = find(&["v", "t", "texture_v", "texture_t"]);
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        // Extra fields of the vertex and face records become mesh attributes, named and
        // grouped as Mitsuba names them.
        let groups = if is_vertex || is_face {
            let names: Vec<&str> = el
                .props
                .iter()
                .map(|p| {
                    if p.list_count.is_some() {
                        ""
                    } else {
                        p.name.as_str()
                    }
                })
                .collect();
            let mut reserved = vec!["x", "y", "z", "nx", "ny", "nz", ""];
            reserved.extend([iu, iv].iter().flatten().map(|&i| names[i]));
            let kind = if is_vertex { "vertex_" } else { "face_" };
            group_fields(kind, &names, &reserved)
        } else {
            Vec::new()
        };
        let first_attribute = out.attributes.len();
        for (name, fields) in &groups {
            out.attributes.push(MeshAttribute {
                name: name.clone(),
                dim: fields.len(),
                data: Vec::new(),
            });
        }
        if is_vertex {
            if ix.is_none() || iy.is_none() || iz.is_none() {
                return Err(Error::format(path, "vertex element lacks x, y, z"));
            }
            saw_vertex = true;
        }
        let has_n = inx.is_some() && iny.is_some() && inz.is_some();
        let has_uv = iu.is_some() && iv.is_some();
        let face_list = el.props.iter().position(|p| {
            p.list_count.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
        });
        if is_face && face_list.is_none() {
            return Err(Error::format(
                path,
                "face element lacks a vertex_indices list",
            ));
        }
        if let (Source::Binary { data, pos }, true) = (&mut src, groups.is_empty()) {
            let rest = &data[(*pos).min(data.len())..];
            let used = if is_vertex && !out.positions.is_empty() {
                None
            } else if is_vertex {
                let roles = VertexRoles {
                    xyz: [ix, iy, iz],
                    n: has_n.then_some([inx, iny, inz]),
                    uv: has_uv.then_some([iu, iv]),
                };
                binary_vertices(el, rest, &roles, flip_tex_coords, &mut out)
            } else if is_face && out.indices.is_empty() {
                face_list.and_then(|fl| binary_faces(el, rest, fl, &mut out))
            } else {
                None
            };
            if let Some(used) = used {
                *pos += used;
                saw_vertex |= is_vertex;
                continue;
            }
        }
        let mut vals = vec![0.0f64; el.props.len()];
        let mut poly: Vec<u32> = Vec::new();
        for k in 0..el.count {
            for (pi, p) in el.props.iter().enumerate() {
                let what = || format!("element '{}' #{k}, property '{}'", el.name, p.name);
                if let Some(ct) = p.list_count {
                    let n = src.read(ct, path, &what)?;
                    if n < 0.0 {
                        return Err(Error::format(
                            path,
                            format!("negative list length in {}", what()),
                        ));
                    }
                    let is_idx = Some(pi) == face_list && is_face;
                    if is_idx {
                        poly.clear();
                    }
                    for _ in 0..n as usize {
                        let v = src.read(p.ty, path, &what)?;
                        if is_idx {
                            if v < 0.0 || v > u32::MAX as f64 {
                                return Err(Error::format(
                                    path,
                                    format!("bad vertex index {v} in {}", what()),
                                ));
                            }
                            poly.push(v as u32);
                        }
                    }
                } else {
                    vals[pi] = src.read(p.ty, path, &what)?;
                }
            }
            if is_vertex {
                let g = |i: Option<usize>| i.map(|i| vals[i] as f32).unwrap_or(0.0);
                let p = Vec3::new(g(ix), g(iy), g(iz));
                if !p.is_finite() {
                    return Err(Error::format(
                        path,
                        format!("vertex #{k} does not fit in f32"),
                    ));
                }
                out.positions.push(p);
                push_attributes(&mut out.attributes[first_attribute..], &groups, &vals, 1);
                if has_n {
                    out.normals.push(Vec3::new(g(inx), g(iny), g(inz)));
                }
                if has_uv {
                    let uv = Vec2::new(g(iu), g(iv));
                    out.uvs.push(if flip_tex_coords {
                        Vec2::new(uv.x, 1.0 - uv.y)
                    } else {
                        uv
                    });
                }
            } else if is_face {
                if poly.len() < 3 {
                    return Err(Error::format(
                        path,
                        format!("face #{k} has fewer than 3 vertices"),
                    ));
                }
                for i in 1..poly.len() - 1 {
                    out.indices.push([poly[0], poly[i], poly[i + 1]]);
                }
                // A face's attributes hold for each triangle of its fan.
                let fan = poly.len() - 2;
                push_attributes(&mut out.attributes[first_attribute..], &groups, &vals, fan);
            }
        }
    }
    if !saw_vertex {
        return Err(Error::format(path, "PLY file has no vertex element"));
    }
    let n = out.positions.len();
    if let Some((f, _)) = out
        .indices
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&i| i as usize >= n))
    {
        return Err(Error::format(
            path,
            format!("face #{f} references a vertex beyond the {n} vertices"),
        ));
    }
    if out.indices.is_empty() {
        return Err(Error::format(path, "PLY file contains no faces"));
    }
    if let Some(a) = out
        .attributes
        .iter()
        .find(|a| a.data.iter().any(|v| !v.is_finite()))
    {
        return Err(Error::format(
            path,
            format!("attribute \"{}\" holds a non-finite value", a.name),
        ));
    }
    Ok(out)
}

/// Appends one record's attribute values (`times` copies: one per triangle of a face's fan)
/// to the attributes of `groups`: integer fields as their values, as Mitsuba 3.9.1 keeps them
/// (it warns that colours are expected in [0, 1]); non-finite values are refused later.
fn push_attributes(
    attrs: &mut [MeshAttribute],
    groups: &[(String, Vec<usize>)],
    vals: &[f64],
    times: usize,
) {
    for (a, (_, fields)) in attrs.iter_mut().zip(groups) {
        for _ in 0..times {
            a.data.extend(fields.iter().map(|&f| vals[f] as f32));
        }
    }
}

/// Rejects, before anything is allocated for them, element counts that the file cannot hold
/// (a truncated file or a header that lies: every value takes at least its binary size, or two
/// characters in ASCII, and a face at least three indices), meshes of 2³¹ indices or more, and
/// meshes that would not fit in the memory available.
fn check_counts(path: &Path, elements: &[Element], ascii: bool, data_len: usize) -> Result<()> {
    let value = |t: Ty| if ascii { 2 } else { t.size() as u128 };
    let mut need: u128 = 0;
    let (mut vertices, mut faces) = (0u128, 0u128);
    for el in elements {
        let per: u128 = el
            .props
            .iter()
            .map(|p| match p.list_count {
                None => value(p.ty),
                Some(c)
                    if el.name == "face"
                        && matches!(p.name.as_str(), "vertex_indices" | "vertex_index") =>
                {
                    value(c) + 3 * value(p.ty)
                }
                Some(c) => value(c),
            })
            .sum();
        need += el.count as u128 * per;
        match el.name.as_str() {
            "vertex" => vertices += el.count as u128,
            "face" => faces += el.count as u128,
            _ => {}
        }
    }
    let indices = 3 * faces;
    if indices >= 1 << 31 {
        return Err(Error::format(
            path,
            format!(
                "the header declares {faces} faces: {indices} or more vertex indices, at least 2^31, more than a mesh can hold"
            ),
        ));
    }
    // ASCII: the last value needs no separator after it.
    let slack = if ascii { 1 } else { 0 };
    if need > data_len as u128 + slack {
        return Err(Error::format(
            path,
            format!(
                "the header declares {} but only {data_len} bytes follow it, fewer than the {need} those need at least: the file is truncated or its header is wrong",
                elements
                    .iter()
                    .map(|e| format!("{} '{}'", e.count, e.name))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    super::shapes::check_mesh_fits(
        vertices as u64,
        faces as u64,
        super::shapes::available_memory(),
    )
    .map_err(|m| Error::format(path, m))
}

/// Which vertex properties hold positions, normals and uvs.
struct VertexRoles {
    xyz: [Option<usize>; 3],
    n: Option<[Option<usize>; 3]>,
    uv: Option<[Option<usize>; 2]>,
}

/// Byte offset of every property in a record without lists (None if the element has lists).
fn fixed_layout(el: &Element) -> Option<(Vec<usize>, usize)> {
    let mut offs = Vec::with_capacity(el.props.len());
    let mut o = 0;
    for p in &el.props {
        if p.list_count.is_some() {
            return None;
        }
        offs.push(o);
        o += p.ty.size();
    }
    Some((offs, o))
}

/// Binary vertex element of fixed-size records, decoded in parallel. None (nothing read) if
/// it has lists, is cut short or holds a non-finite value or position: the sequential reader
/// then reports the exact place.
fn binary_vertices(
    el: &Element,
    data: &[u8],
    roles: &VertexRoles,
    flip_tex_coords: bool,
    out: &mut LocalMesh,
) -> Option<usize> {
    use rayon::prelude::*;
    let (offs, rec) = fixed_layout(el)?;
    let len = el.count.checked_mul(rec)?;
    if rec == 0 || data.len() < len {
        return None;
    }
    let recs = &data[..len];
    let get = |r: &[u8], i: Option<usize>| {
        i.map(|i| el.props[i].ty.decode(&r[offs[i]..]) as f32)
            .unwrap_or(0.0)
    };
    let finite = recs.par_chunks_exact(rec).all(|r| {
        el.props
            .iter()
            .zip(&offs)
            .all(|(p, &o)| p.ty.decode(&r[o..]).is_finite())
            && Vec3::new(
                get(r, roles.xyz[0]),
                get(r, roles.xyz[1]),
                get(r, roles.xyz[2]),
            )
            .is_finite()
    });
    if !finite {
        return None;
    }
    let [ix, iy, iz] = roles.xyz;
    out.positions = recs
        .par_chunks_exact(rec)
        .map(|r| Vec3::new(get(r, ix), get(r, iy), get(r, iz)))
        .collect();
    if let Some([nx, ny, nz]) = roles.n {
        out.normals = recs
            .par_chunks_exact(rec)
            .map(|r| Vec3::new(get(r, nx), get(r, ny), get(r, nz)))
            .collect();
    }
    if let Some([u, v]) = roles.uv {
        out.uvs = recs
            .par_chunks_exact(rec)
            .map(|r| {
                let (u, v) = (get(r, u), get(r, v));
                Vec2::new(u, if flip_tex_coords { 1.0 - v } else { v })
            })
            .collect();
    }
    Some(len)
}

/// Binary face element whose faces all have the first face's vertex count (a triangle or quad
/// mesh), decoded in parallel and fan-triangulated. None (nothing read) otherwise, or on a bad
/// value, for the sequential reader to handle and report.
fn binary_faces(el: &Element, data: &[u8], list: usize, out: &mut LocalMesh) -> Option<usize> {
    use rayon::prelude::*;
    if el.count == 0 {
        return Some(0);
    }
    let mut before = 0;
    let mut after = 0;
    for (i, p) in el.props.iter().enumerate() {
        if i == list {
            continue;
        }
        if p.list_count.is_some() {
            return None;
        }
        if i < list {
            before += p.ty.size();
        } else {
            after += p.ty.size();
        }
    }
    let lp = &el.props[list];
    let (ct, it) = (lp.list_count?, lp.ty);
    let n0 = ct.decode(data.get(before..before + ct.size())?);
    if !(3.0..=1024.0).contains(&n0) {
        return None;
    }
    let n0 = n0 as usize;
    let rec = before + ct.size() + n0 * it.size() + after;
    let len = el.count.checked_mul(rec)?;
    if data.len() < len {
        return None;
    }
    let recs = &data[..len];
    // Every face the same size, every other value finite, every index a u32.
    let ok = recs.par_chunks_exact(rec).all(|r| {
        ct.decode(&r[before..]) == n0 as f64
            && (0..n0).all(|k| {
                let v = it.decode(&r[before + ct.size() + k * it.size()..]);
                (0.0..=u32::MAX as f64).contains(&v)
            })
            && {
                let mut o = 0;
                el.props.iter().enumerate().all(|(i, p)| {
                    let fin = i == list || p.ty.decode(&r[o..]).is_finite();
                    o += if i == list {
                        ct.size() + n0 * it.size()
                    } else {
                        p.ty.size()
                    };
                    fin
                })
            }
    });
    if !ok {
        return None;
    }
    let per = n0 - 2;
    let mut tris = vec![[0u32; 3]; el.count.checked_mul(per)?];
    tris.par_chunks_mut(per)
        .zip(recs.par_chunks_exact(rec))
        .for_each(|(t, r)| {
            let idx = |k: usize| it.decode(&r[before + ct.size() + k * it.size()..]) as u32;
            let first = idx(0);
            for (i, tri) in t.iter_mut().enumerate() {
                *tri = [first, idx(i + 1), idx(i + 2)];
            }
        });
    out.indices = tris;
    Some(len)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Writes a binary little-endian PLY quad (float xyz, nx ny nz, u v; uchar/int face list).
    pub(crate) fn write_binary_quad(path: &Path) {
        let mut b = b"ply\nformat binary_little_endian 1.0\ncomment test\nelement vertex 4\n\
property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n\
property float nz\nproperty float u\nproperty float v\nelement face 1\n\
property list uchar int vertex_indices\nend_header\n"
            .to_vec();
        for (x, y) in [(0.0f32, 0.0f32), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            for v in [x, y, 0.0, 0.0, 0.0, 1.0, x, y] {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        b.push(4);
        for i in [0i32, 1, 2, 3] {
            b.extend_from_slice(&i.to_le_bytes());
        }
        std::fs::write(path, b).unwrap();
    }

    #[test]
    fn binary_quad_with_normals_and_uvs() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("q.ply");
        write_binary_quad(&p);
        let m = load(&p, false).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.normals[2], Vec3::Z);
        assert_eq!(m.uvs[2], Vec2::new(1.0, 1.0));
        let f = load(&p, true).unwrap();
        assert_eq!(f.uvs[1], Vec2::new(1.0, 1.0));
    }

    #[test]
    fn ascii_triangle_skips_unknown_elements() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.ply");
        std::fs::write(
            &p,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             property uchar red\nelement face 1\nproperty list uchar uint vertex_index\n\
             element edge 1\nproperty int a\nproperty int b\nend_header\n\
             0 0 0 255\n1 0 0 0\n0 1 0 7\n3 0 1 2\n0 1\n",
        )
        .unwrap();
        let m = load(&p, false).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]]);
        assert!(m.normals.is_empty() && m.uvs.is_empty());
    }

    #[test]
    fn errors_name_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.ply");
        std::fs::write(
            &p,
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
        )
        .unwrap();
        let e = load(&p, false).unwrap_err().to_string();
        assert!(e.contains("bad.ply") && e.contains("line 11"), "{e}");
        let be = dir.path().join("be.ply");
        std::fs::write(&be, "ply\nformat binary_big_endian 1.0\nend_header\n").unwrap();
        let e = load(&be, false).unwrap_err().to_string();
        assert!(e.contains("be.ply") && e.contains("big_endian"), "{e}");
        let tr = dir.path().join("trunc.ply");
        let mut b = std::fs::read({
            let q = dir.path().join("q.ply");
            write_binary_quad(&q);
            q
        })
        .unwrap();
        b.truncate(b.len() - 3);
        std::fs::write(&tr, b).unwrap();
        let e = load(&tr, false).unwrap_err().to_string();
        assert!(e.contains("trunc.ply") && e.contains("end of file"), "{e}");
    }
}

#[cfg(test)]
mod size_tests {
    use super::*;

    /// A binary PLY header with `vertices` and `faces` declared, followed by `body`.
    fn write(path: &Path, vertices: u64, faces: u64, body: &[u8]) {
        let mut b = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {vertices}\nproperty float x\n\
             property float y\nproperty float z\nelement face {faces}\n\
             property list uchar uint vertex_indices\nend_header\n"
        )
        .into_bytes();
        b.extend_from_slice(body);
        std::fs::write(path, b).unwrap();
    }

    #[test]
    fn header_claiming_2_pow_40_faces_fails_fast() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("liar.ply");
        write(&p, 3, 1 << 40, &[0; 64]);
        let e = load(&p, false).unwrap_err().to_string();
        assert!(e.contains("liar.ply") && e.contains("2^31"), "{e}");
    }

    #[test]
    fn header_claiming_more_than_the_file_holds_fails() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("short.ply");
        // 1000 vertices and 2000 triangles declared, 40 bytes present.
        write(&p, 1000, 2000, &[0; 40]);
        let e = load(&p, false).unwrap_err().to_string();
        assert!(
            e.contains("short.ply") && e.contains("header") && e.contains("40 bytes"),
            "{e}"
        );
        let a = dir.path().join("short_ascii.ply");
        std::fs::write(
            &a,
            "ply\nformat ascii 1.0\nelement vertex 100000\nproperty float x\nproperty float y\n\
             property float z\nend_header\n0 0 0\n",
        )
        .unwrap();
        let e = load(&a, false).unwrap_err().to_string();
        assert!(e.contains("short_ascii.ply") && e.contains("header"), "{e}");
    }

    #[test]
    fn meshes_beyond_memory_or_index_range_are_refused() {
        use crate::scene::shapes::check_mesh_fits;
        assert!(check_mesh_fits(1 << 20, 1 << 21, Some(1 << 34)).is_ok());
        let e = check_mesh_fits(1 << 20, 1 << 21, Some(1 << 28)).unwrap_err();
        assert!(e.contains("GiB") && e.contains("available"), "{e}");
        let e = check_mesh_fits(3, (1 << 31) / 3 + 1, None).unwrap_err();
        assert!(e.contains("2^31"), "{e}");
        assert!(check_mesh_fits(3, (1 << 31) / 3, None).is_ok());
    }

    /// A binary triangle strip of `n` quads, with a float `quality` per face.
    fn strip(n: u32, face: impl Fn(u32) -> Vec<u8>) -> Vec<u8> {
        let mut b = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
             property float y\nproperty float z\nproperty float u\nproperty float v\n\
             element face {}\nproperty list uchar int vertex_indices\nproperty float quality\n\
             end_header\n",
            2 * (n + 1),
            n
        )
        .into_bytes();
        for i in 0..=n {
            for y in [0.0f32, 1.0] {
                for v in [i as f32, y, 0.5 * i as f32, i as f32 / n as f32, y] {
                    b.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        for i in 0..n {
            b.extend_from_slice(&face(i));
            b.extend_from_slice(&0.25f32.to_le_bytes());
        }
        b
    }

    fn quad_face(i: u32) -> Vec<u8> {
        let mut f = vec![4u8];
        for k in [2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1] {
            f.extend_from_slice(&(k as i32).to_le_bytes());
        }
        f
    }

    #[test]
    fn parallel_and_sequential_binary_readers_agree() {
        let dir = tempfile::tempdir().unwrap();
        let n = 5000;
        // All quads: the parallel reader; one triangle among them: the sequential one.
        let fast = dir.path().join("fast.ply");
        std::fs::write(&fast, strip(n, quad_face)).unwrap();
        let slow = dir.path().join("slow.ply");
        std::fs::write(
            &slow,
            strip(n, |i| {
                if i == n - 1 {
                    let mut f = vec![3u8];
                    for k in [2 * i, 2 * i + 2, 2 * i + 3] {
                        f.extend_from_slice(&(k as i32).to_le_bytes());
                    }
                    f
                } else {
                    quad_face(i)
                }
            }),
        )
        .unwrap();
        let a = load(&fast, true).unwrap();
        let b = load(&slow, true).unwrap();
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.uvs, b.uvs);
        assert_eq!(a.indices.len(), 2 * n as usize);
        assert_eq!(b.indices.len(), 2 * n as usize - 1);
        assert_eq!(a.indices[..b.indices.len()], b.indices[..]);
        assert_eq!(a.uvs[3], Vec2::new(1.0 / n as f32, 0.0));
        // A bad index in the parallel path is reported as by the sequential one.
        let bad = dir.path().join("bad.ply");
        std::fs::write(
            &bad,
            strip(n, |i| {
                let mut f = quad_face(i);
                if i == 77 {
                    f[1..5].copy_from_slice(&(-1i32).to_le_bytes());
                }
                f
            }),
        )
        .unwrap();
        let e = load(&bad, false).unwrap_err().to_string();
        assert!(e.contains("bad.ply") && e.contains("#77"), "{e}");
    }
}
