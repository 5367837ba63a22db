//! Triangle meshes: every shape of a scene (OBJ, PLY, glTF, rectangle, cube, sphere, disk) ends up
//! as one of these, already transformed to world space.

use super::mesh_attribute::MeshAttribute;
use super::sphere::Sphere;
use crate::math::{Spectrum, Vec2, Vec3};

/// A world-space triangle mesh with optional per-vertex normals and uvs.
///
/// Conventions (Mitsuba 3): without `uvs`, the hit's uv is the barycentric (b1, b2) and ∂p/∂u = p1 − p0;
/// without `normals` (or with `face_normals`), the shading normal is the geometric normal
/// normalize((p1 − p0) × (p2 − p0)). OBJ uvs are stored with v already flipped (v ← 1 − v).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name for messages (file name or XML id).
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Unit vertex normals, empty for face normals.
    pub normals: Vec<Vec3>,
    /// Texture coordinates, empty if the mesh has none.
    pub uvs: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
    /// Index into `Scene::bsdfs`.
    pub bsdf: u32,
    /// Radiance of an attached `area` emitter (emits on the side of the shading normal).
    pub emitter: Option<Spectrum>,
    /// An analytic sphere (Mitsuba `sphere`): then the mesh has no triangles and this is its
    /// whole surface.
    pub sphere: Option<Sphere>,
    /// Per-vertex and per-triangle attributes from the mesh file (vertex colours, ...), for
    /// `mesh_attribute` textures.
    pub attributes: Vec<MeshAttribute>,
}

impl Mesh {
    /// Area of triangle `i` in world units².
    pub fn triangle_area(&self, i: usize) -> f32 {
        let [a, b, c] = self.indices[i];
        let (p0, p1, p2) = (
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        );
        0.5 * (p1 - p0).cross(p2 - p0).length()
    }

    /// Bytes of vertex and index data held by the mesh.
    pub fn resident_bytes(&self) -> usize {
        std::mem::size_of_val(self.positions.as_slice())
            + std::mem::size_of_val(self.normals.as_slice())
            + std::mem::size_of_val(self.uvs.as_slice())
            + std::mem::size_of_val(self.indices.as_slice())
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        if let Some(s) = &self.sphere {
            return s.area();
        }
        (0..self.indices.len()).map(|i| self.triangle_area(i)).sum()
    }
}
