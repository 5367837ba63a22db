//! What a shape plugin describes ([`Shape`]: object-space geometry and its placement) with the
//! constructors that read the built-in shapes' properties (Mitsuba `rectangle`, `cube`,
//! `sphere`, `disk`, `cylinder`; the mesh files' own are in `obj.rs`, `ply.rs`,
//! `serialized.rs`), the built-ins as triangle meshes with Mitsuba's exact uv
//! parameterisations, and the common step that turns any object-space mesh into a world-space
//! [`Mesh`] (transform, normals, degenerate triangles, flips).

use crate::geometry::sphere::Sphere;
use crate::geometry::{Mesh, MeshAttribute};
use crate::math::transform::{normal_matrix, xf_point};
use crate::math::{Frame, Mat3, Mat4, Vec2, Vec3};
use crate::plugin::Properties;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Sphere tessellation: rings in θ (pole to pole) and segments in φ.
pub const SPHERE_RINGS: usize = 128;
/// Sphere tessellation: segments in φ.
pub const SPHERE_SEGMENTS: usize = 256;
/// Disk tessellation: segments in φ and rings in r.
pub const DISK_SEGMENTS: usize = 256;
/// Disk tessellation: rings in r.
pub const DISK_RINGS: usize = 16;
/// Cylinder tessellation: segments in φ (the silhouette is within 7.6·10⁻⁵ radii of the
/// analytic one; the straight sides are exact).
pub const CYLINDER_SEGMENTS: usize = 256;

/// An object-space triangle mesh before it is placed in the world.
#[derive(Clone, Debug, Default)]
pub struct LocalMesh {
    /// Object-space vertex positions.
    pub positions: Vec<Vec3>,
    /// Empty, or one (not necessarily unit) normal per vertex.
    pub normals: Vec<Vec3>,
    /// Empty, or one uv per vertex.
    pub uvs: Vec<Vec2>,
    /// Triangles (counter-clockwise = front, geometric normal (p1 − p0) × (p2 − p0)).
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex and per-triangle attributes (PLY files), kept with their triangles.
    pub attributes: Vec<MeshAttribute>,
}

/// How [`to_world`] treats normals.
#[derive(Clone, Copy, Debug, Default)]
pub struct MeshOptions {
    /// Mitsuba `face_normals`: drop vertex normals, shade with the geometric normal.
    pub face_normals: bool,
    /// Mitsuba `flip_normals`: reverse the winding and negate vertex normals.
    pub flip_normals: bool,
    /// Compute angle-weighted vertex normals when the file has none (Mitsuba's OBJ/PLY behaviour).
    pub recompute_normals: bool,
    /// Analytic shapes: keep the winding consistent with the transformed normals when `to_world`
    /// mirrors (Mitsuba's analytic shapes take their normal from the inverse transpose).
    pub keep_orientation: bool,
}

/// A shape as its plugin's constructor reads it: what it is in object space and how it is
/// placed in the world (Mitsuba 3's `Shape` base properties and the plugin's own).
#[derive(Clone, Debug)]
pub struct Shape {
    /// The triangles in object space; None for the analytic sphere (centre and radius in
    /// `to_world`).
    pub local: Option<LocalMesh>,
    /// Object → world, including the plugin's own placement (a sphere's centre and radius, ...).
    pub to_world: Mat4,
    /// How [`to_world`] treats the mesh's normals.
    pub options: MeshOptions,
    /// The mesh file the shape was read from (for messages).
    pub file: Option<PathBuf>,
    /// The name of the shape when its element has no id (a mesh file's name, ...).
    pub label: Option<String>,
}

impl Shape {
    /// The properties every shape reads first, as Mitsuba's `Shape` and `Mesh` base
    /// constructors: `to_world` (identity) and `flip_normals` (false); the geometry comes next.
    pub fn base(p: &dyn Properties, local: Option<LocalMesh>) -> crate::Result<Shape> {
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let flip_normals = p.bool("flip_normals", false)?;
        Ok(Shape {
            local,
            to_world,
            options: MeshOptions {
                flip_normals,
                ..Default::default()
            },
            file: None,
            label: None,
        })
    }

    /// A mesh file (`obj`, `ply`): `filename`, `face_normals` (false), `flip_tex_coords`
    /// (`flip_default`); `load` reads the file (v ← 1 − v when flipping); vertex normals are
    /// recomputed when the file has none.
    pub fn mesh_file_from_props(
        p: &dyn Properties,
        flip_default: bool,
        load: fn(&Path, bool) -> crate::Result<LocalMesh>,
    ) -> crate::Result<Shape> {
        let mut s = Shape::base(p, None)?;
        let file = p.string_req("filename")?;
        let path = p.resolve(&file);
        s.options.face_normals = p.bool("face_normals", false)?;
        s.options.recompute_normals = true;
        let flip_uv = p.bool("flip_tex_coords", flip_default)?;
        s.local = Some(load(&path, flip_uv).map_err(|e| p.err(&e.to_string()))?);
        s.file = Some(path);
        s.label = Some(file);
        Ok(s)
    }

    /// Mitsuba's `rectangle`: [-1, 1]² in the z = 0 plane; `to_world` without shear.
    pub fn rectangle_from_props(p: &dyn Properties) -> crate::Result<Shape> {
        let mut s = Shape::base(p, Some(rectangle()))?;
        let l = Mat3::from_mat4(s.to_world);
        if l.x_axis.normalize().dot(l.y_axis.normalize()).abs() > 1e-4 {
            return Err(p.err("the to_world transformation contains shear, which Mitsuba's rectangle does not support"));
        }
        s.options.keep_orientation = true;
        Ok(s)
    }

    /// Mitsuba's `disk`: the unit disk in the z = 0 plane.
    pub fn disk_from_props(p: &dyn Properties) -> crate::Result<Shape> {
        let mut s = Shape::base(p, Some(disk(DISK_RINGS, DISK_SEGMENTS)))?;
        s.options.keep_orientation = true;
        Ok(s)
    }

    /// Mitsuba's `cube`: [-1, 1]³.
    pub fn cube_from_props(p: &dyn Properties) -> crate::Result<Shape> {
        Shape::base(p, Some(cube()))
    }

    /// Mitsuba's `cylinder`: `radius` (1) around the axis from `p0` (origin) to `p1` (+z),
    /// tessellated; `to_world` must scale x and y alike (Mitsuba's is analytic).
    pub fn cylinder_from_props(p: &dyn Properties) -> crate::Result<Shape> {
        let mut s = Shape::base(p, None)?;
        let radius = p.float("radius", 1.0)?;
        let p0 = p.vec3_opt("p0")?.unwrap_or(Vec3::ZERO);
        let p1 = p.vec3_opt("p1")?.unwrap_or(Vec3::Z);
        let d = p1 - p0;
        let length = d.length();
        if radius <= 0.0 || length <= 0.0 {
            return Err(p.err("the cylinder needs a positive radius and p0 != p1"));
        }
        // Mitsuba: to_world · translate(p0) · to_frame(Frame(d / |d|)) · scale(r, r, |d|).
        let f = Frame::from_normal(d / length);
        let frame = Mat4::from_cols(
            f.s.extend(0.0),
            f.t.extend(0.0),
            f.n.extend(0.0),
            glam::Vec4::W,
        );
        s.to_world = s.to_world
            * Mat4::from_translation(p0)
            * frame
            * Mat4::from_scale(Vec3::new(radius, radius, length));
        let l = Mat3::from_mat4(s.to_world);
        if (l.x_axis.length() - l.y_axis.length()).abs() > 1e-4 * l.x_axis.length()
            || l.x_axis.dot(l.y_axis).abs() > 1e-4 * l.x_axis.length_squared()
        {
            return Err(p.err("to_world must not contain shear or non-uniform scaling along x and y for a cylinder (Mitsuba's is analytic)"));
        }
        s.options.keep_orientation = true;
        s.local = Some(cylinder(CYLINDER_SEGMENTS));
        Ok(s)
    }

    /// True if `m`'s linear part is a rotation times a uniform scale (no shear, no
    /// non-uniform scale): what keeps an analytic sphere a sphere.
    pub fn scales_uniformly(m: &Mat4) -> bool {
        let l = Mat3::from_mat4(*m);
        let g = l.transpose() * l;
        let s2 = g.x_axis.x;
        !(g - Mat3::from_diagonal(Vec3::splat(s2)))
            .to_cols_array()
            .iter()
            .any(|v| v.abs() > 1e-4 * s2)
    }

    /// Mitsuba's `sphere`, analytic: `center` (origin), `radius` (1); `to_world` must scale
    /// uniformly (Mitsuba keeps only its centre, radius and orientation).
    pub fn sphere_from_props(p: &dyn Properties) -> crate::Result<Shape> {
        let mut s = Shape::base(p, None)?;
        let center = p.vec3_opt("center")?.unwrap_or(Vec3::ZERO);
        let radius = p.float("radius", 1.0)?;
        if radius <= 0.0 {
            return Err(p.err("the sphere radius must be positive"));
        }
        s.to_world =
            s.to_world * Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius));
        // An ellipsoid here would not match Mitsuba's render, which warns and ignores the rest.
        if !Shape::scales_uniformly(&s.to_world) {
            return Err(p.err("to_world must not contain non-uniform scale or shear for a sphere (Mitsuba ignores it)"));
        }
        Ok(s)
    }

    /// The shape in world space (an error message for the caller to locate): the mesh placed
    /// by [`to_world`], or the analytic sphere; a mesh must keep a triangle of non-zero area.
    pub fn into_mesh(self) -> Result<Mesh, String> {
        let mesh = match self.local {
            None => Mesh {
                sphere: Some(
                    Sphere::from_to_world(&self.to_world, self.options.flip_normals)
                        .ok_or("to_world is singular for a sphere")?,
                ),
                ..Default::default()
            },
            Some(local) => to_world(local, &self.to_world, self.options)?,
        };
        if mesh.indices.is_empty() && mesh.sphere.is_none() {
            return Err(match self.file {
                Some(f) => format!(
                    "{}: the mesh has no triangles of non-zero area",
                    f.display()
                ),
                None => "the shape has no triangles of non-zero area".into(),
            });
        }
        Ok(mesh)
    }
}

/// Bytes per triangle a loaded mesh costs at the peak of loading and BVH building (indices,
/// the vertex data a height field shares among two triangles, the BVH and its transient build
/// buffers; measured by scripts/scaling.sh, rounded up).
pub const PEAK_BYTES_PER_TRIANGLE: u64 = 160;

/// Bytes per vertex of a loaded mesh: position, normal and uv, and the file's copy of them.
pub const PEAK_BYTES_PER_VERTEX: u64 = 64;

/// Memory the system can still give this process (Linux `MemAvailable`), None if unknown.
pub fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses, from a file's declared counts and before anything is allocated for them, a mesh of
/// 2³¹ indices or more (u32 indices, as Mitsuba's) or one whose estimated footprint exceeds
/// `available` bytes (unchecked when None). The message is for the caller to prefix with the file.
pub fn check_mesh_fits(
    vertices: u64,
    triangles: u64,
    available: Option<u64>,
) -> Result<(), String> {
    let indices = triangles as u128 * 3;
    if indices >= 1 << 31 {
        return Err(format!(
            "{triangles} triangles need {indices} vertex indices, at least 2^31, more than a mesh can hold"
        ));
    }
    if vertices > u32::MAX as u64 {
        return Err(format!(
            "{vertices} vertices: more than u32 indices can address"
        ));
    }
    let need = triangles as u128 * PEAK_BYTES_PER_TRIANGLE as u128
        + vertices as u128 * PEAK_BYTES_PER_VERTEX as u128;
    if let Some(avail) = available
        && need > avail as u128
    {
        let gib = |b: u128| b as f64 / (1u64 << 30) as f64;
        return Err(format!(
            "{vertices} vertices and {triangles} triangles need about {:.1} GiB to load and render, but only {:.1} GiB of memory is available",
            gib(need),
            gib(avail as u128)
        ));
    }
    Ok(())
}

/// Places `local` in the world with `m`. Errors (as a message for the caller to locate) on
/// non-finite data, out-of-range indices and singular transforms. Zero-area triangles are dropped.
pub fn to_world(local: LocalMesh, m: &Mat4, opts: MeshOptions) -> Result<Mesh, String> {
    let LocalMesh {
        positions: mut pos,
        normals: mut nrm,
        uvs,
        mut indices,
        mut attributes,
    } = local;
    let nm = normal_matrix(m).ok_or("to_world is singular (zero scale?)")?;
    let n = pos.len();
    if !nrm.is_empty() && nrm.len() != n {
        return Err(format!("{} normals for {n} vertices", nrm.len()));
    }
    if !uvs.is_empty() && uvs.len() != n {
        return Err(format!(
            "{} texture coordinates for {n} vertices",
            uvs.len()
        ));
    }
    // In place and in parallel: a big mesh's vertices are transformed without a second copy.
    let bad = pos.par_iter_mut().enumerate().find_map_first(|(i, p)| {
        if !p.is_finite() {
            return Some(format!("vertex {i} has a non-finite position {p:?}"));
        }
        let w = xf_point(m, *p);
        if !w.is_finite() {
            return Some(format!("vertex {i} is not finite after to_world ({w:?})"));
        }
        *p = w;
        None
    });
    if let Some(e) = bad {
        return Err(e);
    }
    if let Some((i, uv)) = uvs.iter().enumerate().find(|(_, uv)| !uv.is_finite()) {
        return Err(format!(
            "vertex {i} has a non-finite texture coordinate {uv:?}"
        ));
    }
    if opts.face_normals {
        nrm = Vec::new();
    } else {
        let bad = nrm.par_iter_mut().enumerate().find_map_first(|(i, v)| {
            let w = (nm * *v).normalize();
            if !w.is_finite() {
                return Some(format!("vertex {i} has a zero or non-finite normal {v:?}"));
            }
            *v = w;
            None
        });
        if let Some(e) = bad {
            return Err(e);
        }
    }
    if let Some(f) = indices
        .par_iter()
        .position_first(|t| t.iter().any(|&i| i as usize >= n))
    {
        return Err(format!(
            "triangle {f} references a vertex beyond the {n} vertices"
        ));
    }
    let keep = |t: &[u32; 3]| {
        let (a, b, c) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
        let area2 = (b - a).cross(c - a).length();
        area2 > 0.0 && area2.is_finite()
    };
    // Most meshes have no zero-area triangle: test in parallel, compact only if needed (with
    // the per-triangle attributes of the dropped triangles).
    if !indices.par_iter().all(keep) {
        let kept: Vec<bool> = indices.iter().map(keep).collect();
        for a in attributes.iter_mut().filter(|a| !a.per_vertex()) {
            let d = a.dim;
            let mut t = 0;
            a.data.retain(|_| {
                let k = kept[t / d];
                t += 1;
                k
            });
        }
        indices.retain(keep);
    }
    if opts.keep_orientation && nrm.len() == n {
        // Make the geometric normal agree with the (inverse-transpose) shading normal.
        for t in indices.iter_mut() {
            let (a, b, c) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
            let g = (b - a).cross(c - a);
            let s = nrm[t[0] as usize] + nrm[t[1] as usize] + nrm[t[2] as usize];
            if g.dot(s) < 0.0 {
                t.swap(1, 2);
            }
        }
    }
    if nrm.is_empty() && !opts.face_normals && opts.recompute_normals {
        nrm = angle_weighted_normals(&pos, &indices);
    }
    if opts.flip_normals {
        for t in indices.iter_mut() {
            t.swap(1, 2);
        }
        for v in nrm.iter_mut() {
            *v = -*v;
        }
    }
    Ok(Mesh {
        name: String::new(),
        positions: pos,
        normals: nrm,
        uvs,
        indices,
        bsdf: 0,
        emitter: None,
        sphere: None,
        attributes,
        group: None,
        instance: None,
    })
}

/// Mitsuba's `recompute_vertex_normals`: face normals weighted by the corner angle.
///
/// In parallel over bands of vertices: each band's worker walks all triangles in order and adds
/// only the corners of its own vertices, so every vertex sums its corners in triangle order and
/// the result is the same bits for any number of threads.
pub fn angle_weighted_normals(pos: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; pos.len()];
    let band = pos
        .len()
        .div_ceil(2 * rayon::current_num_threads())
        .max(1 << 16);
    acc.par_chunks_mut(band).enumerate().for_each(|(k, acc)| {
        let (lo, hi) = ((k * band) as u32, (k * band + acc.len()) as u32);
        for t in indices {
            if !t.iter().any(|&i| (lo..hi).contains(&i)) {
                continue;
            }
            let v = [pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]];
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            let len = n.length();
            if len == 0.0 || !len.is_finite() {
                continue;
            }
            let n = n / len;
            for i in 0..3 {
                if !(lo..hi).contains(&t[i]) {
                    continue;
                }
                let d0 = (v[(i + 1) % 3] - v[i]).normalize();
                let d1 = (v[(i + 2) % 3] - v[i]).normalize();
                let angle = d0.dot(d1).clamp(-1.0, 1.0).acos();
                if angle.is_finite() {
                    acc[(t[i] - lo) as usize] += n * angle;
                }
            }
        }
        for n in acc.iter_mut() {
            let l = n.length();
            *n = if l > 0.0 && l.is_finite() {
                *n / l
            } else {
                Vec3::X
            };
        }
    });
    acc
}

/// Mitsuba `rectangle`: [-1, 1]² in the z = 0 plane, normal +z, uv = ((x+1)/2, (y+1)/2).
pub fn rectangle() -> LocalMesh {
    let p = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    LocalMesh {
        positions: p.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect(),
        normals: vec![Vec3::Z; 4],
        uvs: p
            .iter()
            .map(|&(x, y)| Vec2::new((x + 1.0) * 0.5, (y + 1.0) * 0.5))
            .collect(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        attributes: Vec::new(),
    }
}

/// Mitsuba `cube`: [-1, 1]³, 24 vertices, every face mapped to [0, 1]² (Mitsuba's exact tables).
pub fn cube() -> LocalMesh {
    const P: [[f32; 3]; 24] = [
        [1., -1., -1.],
        [1., -1., 1.],
        [-1., -1., 1.],
        [-1., -1., -1.],
        [1., 1., -1.],
        [-1., 1., -1.],
        [-1., 1., 1.],
        [1., 1., 1.],
        [1., -1., -1.],
        [1., 1., -1.],
        [1., 1., 1.],
        [1., -1., 1.],
        [1., -1., 1.],
        [1., 1., 1.],
        [-1., 1., 1.],
        [-1., -1., 1.],
        [-1., -1., 1.],
        [-1., 1., 1.],
        [-1., 1., -1.],
        [-1., -1., -1.],
        [1., 1., -1.],
        [1., -1., -1.],
        [-1., -1., -1.],
        [-1., 1., -1.],
    ];
    const N: [[f32; 3]; 6] = [
        [0., -1., 0.],
        [0., 1., 0.],
        [1., 0., 0.],
        [0., 0., 1.],
        [-1., 0., 0.],
        [0., 0., -1.],
    ];
    const UV: [[f32; 2]; 4] = [[0., 1.], [1., 1.], [1., 0.], [0., 0.]];
    let mut m = LocalMesh::default();
    for (i, p) in P.iter().enumerate() {
        m.positions.push(Vec3::from(*p));
        m.normals.push(Vec3::from(N[i / 4]));
        m.uvs.push(Vec2::from(UV[i % 4]));
    }
    for f in 0..6u32 {
        let b = 4 * f;
        m.indices.push([b, b + 1, b + 2]);
        m.indices.push([b + 3, b, b + 2]);
    }
    m
}

/// Mitsuba `sphere` (unit, at the origin): uv = (φ/2π, θ/π) with θ from +z and φ = atan2(y, x)
/// in [0, 2π); smooth normals; a seam of duplicated vertices at φ = 0 and per-segment pole vertices.
pub fn sphere(rings: usize, segments: usize) -> LocalMesh {
    let mut m = LocalMesh::default();
    let row = segments + 1;
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        let v = i as f32 / rings as f32;
        for j in 0..=segments {
            let pole = i == 0 || i == rings;
            let u = if pole {
                (j as f32 + 0.5).min(segments as f32) / segments as f32
            } else {
                j as f32 / segments as f32
            };
            let phi = 2.0 * std::f32::consts::PI * j as f32 / segments as f32;
            let (st, ct) = theta.sin_cos();
            let (sp, cp) = phi.sin_cos();
            let p = if pole {
                Vec3::new(0.0, 0.0, ct.signum())
            } else {
                Vec3::new(st * cp, st * sp, ct)
            };
            m.positions.push(p);
            m.normals.push(p);
            m.uvs.push(Vec2::new(u, v));
        }
    }
    for i in 0..rings {
        for j in 0..segments {
            let v00 = (i * row + j) as u32;
            let v01 = (i * row + j + 1) as u32;
            let v10 = ((i + 1) * row + j) as u32;
            let v11 = ((i + 1) * row + j + 1) as u32;
            if i + 1 == rings {
                // South pole: the pole vertex of this segment carries u = (j + ½)/segments.
                m.indices.push([v00, v10, v01]);
                continue;
            }
            m.indices.push([v00, v10, v11]);
            if i != 0 {
                m.indices.push([v00, v11, v01]);
            }
        }
    }
    m
}

/// Mitsuba `disk` (unit radius, z = 0, normal +z): uv = (r, φ/2π) with φ in [0, 2π).
pub fn disk(rings: usize, segments: usize) -> LocalMesh {
    let mut m = LocalMesh::default();
    // Per-segment centre vertices (the angle is undefined at r = 0).
    for j in 0..segments {
        m.positions.push(Vec3::ZERO);
        m.uvs
            .push(Vec2::new(0.0, (j as f32 + 0.5) / segments as f32));
    }
    let row = segments + 1;
    for i in 1..=rings {
        let r = i as f32 / rings as f32;
        for j in 0..=segments {
            let v = j as f32 / segments as f32;
            let (sp, cp) = (2.0 * std::f32::consts::PI * v).sin_cos();
            m.positions.push(Vec3::new(r * cp, r * sp, 0.0));
            m.uvs.push(Vec2::new(r, v));
        }
    }
    let ring = |i: usize, j: usize| (segments + (i - 1) * row + j) as u32;
    for j in 0..segments {
        m.indices.push([j as u32, ring(1, j), ring(1, j + 1)]);
    }
    for i in 1..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i + 1, j),
                ring(i + 1, j + 1),
                ring(i, j + 1),
            );
            m.indices.push([a, b, c]);
            m.indices.push([a, c, d]);
        }
    }
    m.normals = vec![Vec3::Z; m.positions.len()];
    m
}

/// Mitsuba's `cylinder` in object space: the open tube x² + y² = 1, 0 ≤ z ≤ 1, with its uv
/// (φ / 2π with φ ∈ [0, 2π) from +x towards +y, z) and the analytic outward normals at the
/// vertices; `segments` quads around (the seam at u = 1 has its own vertices).
pub fn cylinder(segments: usize) -> LocalMesh {
    let mut m = LocalMesh::default();
    for j in 0..=segments {
        let u = j as f32 / segments as f32;
        let (sp, cp) = (2.0 * std::f32::consts::PI * u).sin_cos();
        for z in [0.0f32, 1.0] {
            m.positions.push(Vec3::new(cp, sp, z));
            m.uvs.push(Vec2::new(u, z));
            m.normals.push(Vec3::new(cp, sp, 0.0));
        }
    }
    for j in 0..segments as u32 {
        let (a, b, c, d) = (2 * j, 2 * j + 2, 2 * j + 3, 2 * j + 1);
        m.indices.push([a, b, c]);
        m.indices.push([a, c, d]);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::PI;

    fn geo_normal(m: &Mesh, t: usize) -> Vec3 {
        let [a, b, c] = m.indices[t];
        let (p0, p1, p2) = (
            m.positions[a as usize],
            m.positions[b as usize],
            m.positions[c as usize],
        );
        (p1 - p0).cross(p2 - p0).normalize()
    }

    /// ∂p/∂u of a triangle from its uvs.
    fn dpdu(m: &Mesh, t: usize) -> Vec3 {
        let [a, b, c] = m.indices[t].map(|i| i as usize);
        let (dp1, dp2) = (
            m.positions[b] - m.positions[a],
            m.positions[c] - m.positions[a],
        );
        let (du1, du2) = (m.uvs[b] - m.uvs[a], m.uvs[c] - m.uvs[a]);
        let det = du1.x * du2.y - du1.y * du2.x;
        (dp1 * du2.y - dp2 * du1.y) / det
    }

    #[test]
    fn rectangle_uv_and_tangent_follow_mitsuba() {
        let xf = Mat4::from_translation(Vec3::new(0.0, 0.0, 1.0))
            * Mat4::from_rotation_x(0.3)
            * Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0));
        let m = to_world(rectangle(), &xf, MeshOptions::default()).unwrap();
        for t in 0..2 {
            let expect = xf.transform_vector3(Vec3::new(2.0, 0.0, 0.0));
            assert!((dpdu(&m, t) - expect).length() < 1e-5);
            let n = xf.transform_vector3(Vec3::Z).normalize();
            assert!((geo_normal(&m, t) - n).length() < 1e-5);
        }
        // corner (x, y) = (1, -1) has uv (1, 0)
        let i = m
            .positions
            .iter()
            .position(|p| (*p - xf_point(&xf, Vec3::new(1.0, -1.0, 0.0))).length() < 1e-5)
            .unwrap();
        assert_eq!(m.uvs[i], Vec2::new(1.0, 0.0));
        assert!((m.area() - 4.0 * 6.0).abs() < 1e-4);
    }

    #[test]
    fn mirrored_rectangle_keeps_inverse_transpose_normal() {
        let xf = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        let opts = MeshOptions {
            keep_orientation: true,
            ..Default::default()
        };
        let m = to_world(rectangle(), &xf, opts).unwrap();
        for t in 0..2 {
            assert!((geo_normal(&m, t) - Vec3::Z).length() < 1e-6);
        }
        let f = to_world(
            rectangle(),
            &Mat4::IDENTITY,
            MeshOptions {
                flip_normals: true,
                ..opts
            },
        )
        .unwrap();
        assert!((geo_normal(&f, 0) + Vec3::Z).length() < 1e-6);
        assert!((f.normals[0] + Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn cube_faces_point_outward_with_unit_uvs() {
        let m = to_world(cube(), &Mat4::IDENTITY, MeshOptions::default()).unwrap();
        assert_eq!(m.indices.len(), 12);
        for t in 0..12 {
            let [a, b, c] = m.indices[t].map(|i| i as usize);
            let centre = (m.positions[a] + m.positions[b] + m.positions[c]) / 3.0;
            assert!(
                geo_normal(&m, t).dot(centre) > 0.0,
                "triangle {t} points inward"
            );
            assert!((m.normals[a] - geo_normal(&m, t)).length() < 1e-6);
        }
        assert!(m.uvs.iter().all(|uv| uv.x == 0.0 || uv.x == 1.0));
        assert!((m.area() - 24.0).abs() < 1e-4);
    }

    #[test]
    fn sphere_uv_normals_and_area() {
        let xf =
            Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Mat4::from_scale(Vec3::splat(2.0));
        let m = to_world(
            sphere(SPHERE_RINGS, SPHERE_SEGMENTS),
            &xf,
            MeshOptions {
                keep_orientation: true,
                ..Default::default()
            },
        )
        .unwrap();
        let c = Vec3::new(1.0, 2.0, 3.0);
        // Area converges to 4πr² from below (inscribed polyhedron).
        let rel = m.area() / (4.0 * PI * 4.0);
        assert!(rel < 1.0 && rel > 0.9995, "{rel}");
        for (i, p) in m.positions.iter().enumerate() {
            let d = (*p - c) / 2.0;
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!((m.normals[i] - d).length() < 1e-4);
            let theta = d.z.clamp(-1.0, 1.0).acos();
            assert!((m.uvs[i].y - theta / PI).abs() < 1e-4);
            if d.z.abs() < 0.999 {
                let mut phi = d.y.atan2(d.x);
                if phi < 0.0 {
                    phi += 2.0 * PI;
                }
                let u = m.uvs[i].x;
                // the seam duplicates φ = 0 as u = 1
                assert!(
                    (u - phi / (2.0 * PI)).abs() < 1e-4 || (u - 1.0).abs() < 1e-6 && phi < 1e-3
                );
            }
        }
        for t in (0..m.indices.len()).step_by(97) {
            let [a, b, cc] = m.indices[t].map(|i| i as usize);
            let centre = (m.positions[a] + m.positions[b] + m.positions[cc]) / 3.0;
            assert!(geo_normal(&m, t).dot(centre - c) > 0.0);
            // ∂p/∂u points along +φ: (−sin φ, cos φ, 0) in the sphere's frame
            let d = dpdu(&m, t);
            let e = Vec3::Z.cross(centre - c);
            assert!(d.dot(e) > 0.0);
        }
    }

    #[test]
    fn disk_uv_is_radius_and_angle() {
        let m = to_world(
            disk(DISK_RINGS, DISK_SEGMENTS),
            &Mat4::IDENTITY,
            MeshOptions::default(),
        )
        .unwrap();
        let rel = m.area() / PI;
        assert!(rel < 1.0 && rel > 0.999, "{rel}");
        for (p, uv) in m.positions.iter().zip(&m.uvs) {
            assert!((uv.x - p.truncate().length()).abs() < 1e-5);
            if uv.x > 0.0 && uv.y < 1.0 {
                let mut phi = p.y.atan2(p.x);
                if phi < -1e-6 {
                    phi += 2.0 * PI;
                }
                assert!((uv.y - phi / (2.0 * PI)).abs() < 1e-4, "{uv:?} {p:?}");
            }
        }
        for t in 0..m.indices.len() {
            assert!((geo_normal(&m, t) - Vec3::Z).length() < 1e-4);
        }
        // ∂p/∂u is radial on the disk (Mitsuba: dp_du = (cos φ, sin φ, 0))
        let t = m.indices.len() - 1;
        let [a, b, c] = m.indices[t].map(|i| i as usize);
        let centre = (m.positions[a] + m.positions[b] + m.positions[c]) / 3.0;
        assert!(dpdu(&m, t).normalize().dot(centre.normalize()) > 0.99);
    }

    #[test]
    fn degenerate_triangles_dropped_and_nan_rejected() {
        let mut l = rectangle();
        l.indices.push([0, 0, 1]);
        let m = to_world(l.clone(), &Mat4::IDENTITY, MeshOptions::default()).unwrap();
        assert_eq!(m.indices.len(), 2);
        l.positions[1].x = f32::NAN;
        assert!(
            to_world(l, &Mat4::IDENTITY, MeshOptions::default())
                .unwrap_err()
                .contains("vertex 1")
        );
        let singular = Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0));
        assert!(to_world(rectangle(), &singular, MeshOptions::default()).is_err());
    }

    #[test]
    fn recomputed_normals_are_angle_weighted() {
        // A tent of two faces: the ridge vertices average the two face normals.
        let l = LocalMesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(1.0, 0.0, -1.0),
                Vec3::new(-1.0, 0.0, -1.0),
            ],
            indices: vec![[0, 2, 1], [0, 1, 3]],
            ..Default::default()
        };
        let opts = MeshOptions {
            recompute_normals: true,
            ..Default::default()
        };
        let m = to_world(l, &Mat4::IDENTITY, opts).unwrap();
        assert!(
            (m.normals[0] - Vec3::Z).length() < 1e-5,
            "{:?}",
            m.normals[0]
        );
        assert!((m.normals[2] - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-5);
    }

    #[test]
    fn parallel_normals_match_the_sequential_sum() {
        // A noisy 400 × 400 grid: several vertex bands, triangles spanning band borders.
        let n = 400u32;
        let mut pos = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let h = ((i * 7919 + j * 104729) % 97) as f32 / 970.0;
                pos.push(Vec3::new(i as f32, j as f32, h));
            }
        }
        let mut idx = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                idx.push([a, a + 1, a + n + 2]);
                idx.push([a, a + n + 2, a + n + 1]);
            }
        }
        let mut acc = vec![Vec3::ZERO; pos.len()];
        for t in &idx {
            let v = t.map(|i| pos[i as usize]);
            let g = (v[1] - v[0]).cross(v[2] - v[0]);
            let g = g / g.length();
            for i in 0..3 {
                let d0 = (v[(i + 1) % 3] - v[i]).normalize();
                let d1 = (v[(i + 2) % 3] - v[i]).normalize();
                acc[t[i] as usize] += g * d0.dot(d1).clamp(-1.0, 1.0).acos();
            }
        }
        let want: Vec<Vec3> = acc.iter().map(|n| *n / n.length()).collect();
        assert_eq!(angle_weighted_normals(&pos, &idx), want);
    }
}
