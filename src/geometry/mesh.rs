//! Triangle meshes: every shape of a scene (OBJ, PLY, glTF, rectangle, cube, sphere, disk) ends up
//! as one of these, already transformed to world space.

use super::mesh_attribute::MeshAttribute;
use super::sphere::Sphere;
use crate::math::{Mat3, Mat4, Spectrum, Vec2, Vec3};

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
    /// The shapegroup (Mitsuba `shapegroup`) this mesh belongs to: it is then kept in object
    /// space and rendered only where an instance places its group.
    pub group: Option<u32>,
    /// A Mitsuba `instance`: this mesh has no geometry of its own and places the meshes of
    /// its group with this transform.
    pub instance: Option<Box<Placement>>,
}

/// Where an instance puts its shapegroup: object → world and back, and the normal matrix.
#[derive(Clone, Debug)]
pub struct Placement {
    /// The shapegroup placed (the `group` of its meshes).
    pub group: u32,
    /// Object (group) space → world, an affine transform.
    pub to_world: Mat4,
    /// World → object space (the inverse of `to_world`), for rays entering the group.
    pub to_object: Mat4,
    /// Inverse transpose of `to_world`'s linear part: how normals move to world space.
    pub normal_matrix: Mat3,
    /// True if `to_world` mirrors (negative determinant).
    pub mirrors: bool,
}

impl Placement {
    /// The placement of group `group` by the affine `to_world`; None if it is singular.
    pub fn new(group: u32, to_world: Mat4) -> Option<Placement> {
        let det = to_world.determinant();
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let to_object = to_world.inverse();
        Some(Placement {
            group,
            to_world,
            to_object,
            normal_matrix: Mat3::from_mat4(to_object).transpose(),
            mirrors: det < 0.0,
        })
    }

    /// A triangle's gathered corners and optional normals in world space (shared by the scalar
    /// and packet shading, so both see the same bits).
    #[inline]
    pub fn triangle_to_world(
        &self,
        p: [Vec3; 3],
        n: Option<[Vec3; 3]>,
    ) -> ([Vec3; 3], Option<[Vec3; 3]>) {
        (
            p.map(|q| self.to_world.transform_point3(q)),
            n.map(|ns| ns.map(|v| (self.normal_matrix * v).normalize_or_zero())),
        )
    }

    /// The geometric and shading normals of a hit computed from the world-space triangle,
    /// turned as Mitsuba's instance turns them (object-space normals moved by the normal
    /// matrix): a mirroring placement reverses the winding, so the winding normal flips back,
    /// and so does a shading normal that is the winding one (`has_normals` false).
    #[inline]
    pub fn orient(&self, n: Vec3, ns: Vec3, has_normals: bool) -> (Vec3, Vec3) {
        if self.mirrors {
            (-n, if has_normals { ns } else { -ns })
        } else {
            (n, ns)
        }
    }
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
