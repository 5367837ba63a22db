//! A glTF triangle primitive's geometry as an object-space [`LocalMesh`]: the declared counts
//! are checked against the buffers and the memory available before anything is allocated, and
//! plain arrays (f32 positions, normals and uvs, u8/u16/u32 indices, interleaved or not) are
//! decoded in parallel straight from the buffer into the mesh's arrays; other encodings
//! (sparse or normalized-integer accessors) go through the `gltf` crate's reader.

use crate::math::{Vec2, Vec3};
use crate::scene::shapes::{LocalMesh, check_mesh_fits};
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::buffer::Data;
use ::gltf::mesh::Semantic;
use ::gltf::{Accessor, Primitive};
use rayon::prelude::*;

/// Reads `prim` (triangles) from `buffers`; `mirror` reverses the winding (a transform with a
/// negative determinant). `avail` bounds the memory it may need. Errors are messages for the
/// caller to prefix with the file and primitive.
pub(super) fn read(
    prim: &Primitive,
    buffers: &[Data],
    mirror: bool,
    avail: Option<u64>,
) -> Result<LocalMesh, String> {
    read_with(prim, buffers, mirror, avail, true)
}

/// [`read`], with the parallel decoding of plain arrays switched off when `direct` is false
/// (the crate's reader for everything: the oracle of the tests).
fn read_with(
    prim: &Primitive,
    buffers: &[Data],
    mirror: bool,
    avail: Option<u64>,
    direct: bool,
) -> Result<LocalMesh, String> {
    let pos = prim
        .get(&Semantic::Positions)
        .ok_or("has no POSITION attribute")?;
    let nv = pos.count();
    let ni = prim.indices().map_or(nv, |a| a.count());
    if ni >= 1 << 31 {
        return Err(format!(
            "{ni} vertex indices, at least 2^31, more than a mesh can hold"
        ));
    }
    if !ni.is_multiple_of(3) {
        return Err(format!("index count {ni} is not a multiple of 3"));
    }
    check_mesh_fits(nv as u64, (ni / 3) as u64, avail)?;
    let normals = prim.get(&Semantic::Normals);
    let uvs = prim.get(&Semantic::TexCoords(0));
    for (a, role) in [
        (Some(&pos), "POSITION"),
        (normals.as_ref(), "NORMAL"),
        (uvs.as_ref(), "TEXCOORD_0"),
        (prim.indices().as_ref(), "indices"),
    ] {
        if let Some(a) = a {
            check_bounds(a, buffers, role)?;
        }
        if let Some(a) = a
            && role != "indices"
            && a.count() != nv
        {
            return Err(format!(
                "accessor {} ({role}) has {} elements but POSITION has {nv}",
                a.index(),
                a.count()
            ));
        }
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));
    let missing = |role: &str| format!("cannot read the {role} accessor");
    let positions = match plain(&pos, buffers, direct, DataType::F32, Dimensions::Vec3) {
        Some((b, stride)) => vec3s(b, stride, nv),
        None => reader
            .read_positions()
            .ok_or_else(|| missing("POSITION"))?
            .map(Vec3::from)
            .collect(),
    };
    let normals = match &normals {
        Some(a) => match plain(a, buffers, direct, DataType::F32, Dimensions::Vec3) {
            Some((b, stride)) => vec3s(b, stride, nv),
            None => reader
                .read_normals()
                .ok_or_else(|| missing("NORMAL"))?
                .map(Vec3::from)
                .collect(),
        },
        None => Vec::new(),
    };
    let uvs = match &uvs {
        Some(a) => match plain(a, buffers, direct, DataType::F32, Dimensions::Vec2) {
            Some((b, stride)) => (0..nv)
                .into_par_iter()
                .map(|i| Vec2::new(f32_at(b, i * stride), f32_at(b, i * stride + 4)))
                .collect(),
            None => reader
                .read_tex_coords(0)
                .ok_or_else(|| missing("TEXCOORD_0"))?
                .into_f32()
                .map(Vec2::from)
                .collect(),
        },
        None => Vec::new(),
    };
    let order = |t: [u32; 3]| if mirror { [t[0], t[2], t[1]] } else { t };
    let indices = match prim.indices() {
        None => (0..ni / 3)
            .into_par_iter()
            .map(|t| order([3 * t as u32, 3 * t as u32 + 1, 3 * t as u32 + 2]))
            .collect(),
        Some(a) => {
            let ty = a.data_type();
            match plain(&a, buffers, direct, ty, Dimensions::Scalar) {
                Some((b, stride)) if matches!(ty, DataType::U8 | DataType::U16 | DataType::U32) => {
                    let at = |i: usize| -> u32 {
                        let o = i * stride;
                        match ty {
                            DataType::U8 => b[o] as u32,
                            DataType::U16 => u16::from_le_bytes([b[o], b[o + 1]]) as u32,
                            _ => u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]),
                        }
                    };
                    (0..ni / 3)
                        .into_par_iter()
                        .map(|t| order([at(3 * t), at(3 * t + 1), at(3 * t + 2)]))
                        .collect()
                }
                _ => {
                    let mut it = reader
                        .read_indices()
                        .ok_or_else(|| missing("indices"))?
                        .into_u32();
                    let mut out = Vec::with_capacity(ni / 3);
                    while let (Some(x), Some(y), Some(z)) = (it.next(), it.next(), it.next()) {
                        out.push(order([x, y, z]));
                    }
                    out
                }
            }
        }
    };
    Ok(LocalMesh {
        positions,
        normals,
        uvs,
        indices,
        attributes: Vec::new(),
    })
}

/// `n` elements of 3 little-endian f32 each, `stride` bytes apart from the start of `b`.
fn vec3s(b: &[u8], stride: usize, n: usize) -> Vec<Vec3> {
    (0..n)
        .into_par_iter()
        .map(|i| {
            let o = i * stride;
            Vec3::new(f32_at(b, o), f32_at(b, o + 4), f32_at(b, o + 8))
        })
        .collect()
}

/// The little-endian f32 at byte `o` of `b`.
fn f32_at(b: &[u8], o: usize) -> f32 {
    f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

/// The bytes of accessor `a` from its first element and its stride, when it is a plain array
/// of `ty` × `dims` (not sparse, not normalized) and `direct` allows reading it directly.
fn plain<'b>(
    a: &Accessor,
    buffers: &'b [Data],
    direct: bool,
    ty: DataType,
    dims: Dimensions,
) -> Option<(&'b [u8], usize)> {
    if !direct
        || a.sparse().is_some()
        || a.normalized()
        || a.data_type() != ty
        || a.dimensions() != dims
    {
        return None;
    }
    let view = a.view()?;
    let buf = buffers.get(view.buffer().index())?;
    let start = view.offset() + a.offset();
    let bytes = buf.0.get(start..view.offset() + view.length())?;
    Some((bytes, view.stride().unwrap_or(a.size())))
}

/// Refuses an accessor whose declared elements run past its buffer view, or a view past its
/// buffer (a count that lies), before anything is read from it.
fn check_bounds(a: &Accessor, buffers: &[Data], role: &str) -> Result<(), String> {
    let Some(view) = a.view() else {
        return if a.sparse().is_some() {
            Ok(())
        } else {
            Err(format!(
                "accessor {} ({role}) has no buffer view",
                a.index()
            ))
        };
    };
    let stride = view.stride().unwrap_or(a.size());
    let need = (a.count() as u128).saturating_sub(1) * stride as u128
        + if a.count() > 0 { a.size() as u128 } else { 0 }
        + a.offset() as u128;
    if need > view.length() as u128 {
        return Err(format!(
            "accessor {} ({role}) declares {} elements of {} bytes (stride {stride}) from byte {}, {need} bytes, but its buffer view {} holds {}: the file is wrong or truncated",
            a.index(),
            a.count(),
            a.size(),
            a.offset(),
            view.index(),
            view.length()
        ));
    }
    let have = buffers.get(view.buffer().index()).map_or(0, |d| d.0.len());
    if view.offset() as u128 + view.length() as u128 > have as u128 {
        return Err(format!(
            "buffer view {} ends at byte {}, past the end of its buffer ({have} bytes)",
            view.index(),
            view.offset() + view.length()
        ));
    }
    Ok(())
}

#[cfg(test)]
#[path = "mesh_tests.rs"]
mod tests;
