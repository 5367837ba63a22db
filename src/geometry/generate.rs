//! Procedural meshes for the tests and benchmarks (compiled for `cfg(test)` and the `test-support`
//! feature only): spheres (optionally displaced or facing inward), quads and boxes.

use super::Mesh;
use crate::math::{PI, Vec2, Vec3};

/// A latitude–longitude sphere with `n_lat` × `n_lon` quads (two triangles each, poles as fans)
/// whose radius in direction d is `radius · (1 + displace(d))`. Outward winding unless `inward`;
/// vertex normals are the (unit) directions d if `smooth`, face normals otherwise; uvs are
/// (φ/2π, θ/π).
pub fn sphere_displaced(
    center: Vec3,
    radius: f32,
    n_lat: u32,
    n_lon: u32,
    inward: bool,
    smooth: bool,
    displace: impl Fn(Vec3) -> f32,
) -> Mesh {
    let n_lat = n_lat.max(2);
    let n_lon = n_lon.max(3);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for i in 0..=n_lat {
        let theta = PI * i as f32 / n_lat as f32;
        for j in 0..=n_lon {
            let phi = 2.0 * PI * j as f32 / n_lon as f32;
            let d = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            positions.push(center + d * radius * (1.0 + displace(d)));
            normals.push(if inward { -d } else { d });
            uvs.push(Vec2::new(j as f32 / n_lon as f32, i as f32 / n_lat as f32));
        }
    }
    let row = n_lon + 1;
    let mut indices = Vec::new();
    for i in 0..n_lat {
        for j in 0..n_lon {
            let a = i * row + j;
            let b = a + 1;
            let c = a + row;
            let d = c + 1;
            // Outward winding: (a, c, d) and (a, d, b) for θ growing downward from +z.
            let mut tris = Vec::with_capacity(2);
            if i != 0 {
                tris.push([a, c, b]);
            }
            if i != n_lat - 1 {
                tris.push([b, c, d]);
            }
            for t in tris {
                indices.push(if inward { [t[0], t[2], t[1]] } else { t });
            }
        }
    }
    Mesh {
        name: "sphere".into(),
        positions,
        normals: if smooth { normals } else { Vec::new() },
        uvs,
        indices,
        bsdf: 0,
        emitter: None,
        sphere: None,
        attributes: Vec::new(),
        group: None,
        instance: None,
    }
}

/// A plain sphere (see [`sphere_displaced`]).
pub fn sphere(
    center: Vec3,
    radius: f32,
    n_lat: u32,
    n_lon: u32,
    inward: bool,
    smooth: bool,
) -> Mesh {
    sphere_displaced(center, radius, n_lat, n_lon, inward, smooth, |_| 0.0)
}

/// A parallelogram `corner + s·e1 + t·e2`, s, t ∈ [0, 1], facing along e1 × e2, uv = (s, t).
pub fn quad(corner: Vec3, e1: Vec3, e2: Vec3) -> Mesh {
    Mesh {
        name: "quad".into(),
        positions: vec![corner, corner + e1, corner + e1 + e2, corner + e2],
        normals: Vec::new(),
        uvs: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        bsdf: 0,
        emitter: None,
        sphere: None,
        attributes: Vec::new(),
        group: None,
        instance: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_winding_area_and_orientation() {
        let s = sphere(Vec3::ZERO, 2.0, 64, 128, false, true);
        let area = s.area();
        assert!((area - 4.0 * PI * 4.0).abs() / area < 5e-3, "{area}");
        for (t, idx) in s.indices.iter().enumerate() {
            let [a, b, c] = idx.map(|i| s.positions[i as usize]);
            let n = (b - a).cross(c - a);
            if n.length() > 0.0 {
                assert!(n.dot(a + b + c) > 0.0, "triangle {t} faces inward");
            }
        }
        let inner = sphere(Vec3::ZERO, 1.0, 8, 16, true, false);
        let [a, b, c] = inner.indices[5].map(|i| inner.positions[i as usize]);
        assert!((b - a).cross(c - a).dot(a + b + c) < 0.0);
        let q = quad(Vec3::ZERO, Vec3::X, Vec3::Y);
        assert!((q.area() - 1.0).abs() < 1e-6);
    }
}
