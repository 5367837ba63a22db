//! `<shape>`: meshes from files (obj, ply, serialized) and Mitsuba's built-in shapes (the
//! cylinder as a 256-segment mesh with Mitsuba's uv and analytic vertex normals), with their bsdf and
//! area emitter.

use super::properties::Props;
use super::{Builder, N};
use crate::Error;
use crate::Result;
use crate::geometry::Mesh;
use crate::geometry::sphere::Sphere;
use crate::math::Mat3;
use crate::math::Mat4;
use crate::math::Vec3;
use crate::math::transform::is_finite;
use crate::plugin::Properties;
use crate::scene::shapes;
use crate::scene::shapes::MeshOptions;

impl<'a, 'x> Builder<'a, 'x> {
    pub(super) fn shape(&mut self, node: N<'a>) -> Result<()> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        let mut xf = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let flip_normals = p.bool("flip_normals", false)?;
        let mut opts = MeshOptions {
            flip_normals,
            ..Default::default()
        };
        let mut name = x.attr(node, "id").map(str::to_string);
        let wrap = |e: Error| x.err(node, format!("shape \"{}\": {e}", p.ty));
        let mut mesh_file = None;
        let mut analytic = false;
        let local = match p.ty.as_str() {
            "obj" | "ply" => {
                let file = p.string_req("filename")?;
                let path = x.resolve(&file);
                mesh_file = Some(path.clone());
                opts.face_normals = p.bool("face_normals", false)?;
                opts.recompute_normals = true;
                let flip_uv = p.bool("flip_tex_coords", p.ty == "obj")?;
                name.get_or_insert(file);
                if p.ty == "obj" {
                    crate::scene::obj::load(&path, flip_uv).map_err(wrap)?
                } else {
                    crate::scene::ply::load(&path, flip_uv).map_err(wrap)?
                }
            }
            "serialized" => {
                let file = p.string_req("filename")?;
                let path = x.resolve(&file);
                mesh_file = Some(path.clone());
                let index = p.int("shape_index", 0)?;
                let index = u32::try_from(index)
                    .map_err(|_| p.err(format!("invalid shape_index {index}")))?;
                let sh = crate::scene::serialized::load(&path, index).map_err(wrap)?;
                // Mitsuba 3 ignores the face-normals flag of version 3/4 files (only its v5
                // loader applies it): the property alone decides, as in its load_legacy.
                opts.face_normals = p.bool("face_normals", false)?;
                opts.recompute_normals = true;
                let label = if sh.name.is_empty() {
                    format!("{file}[{index}]")
                } else {
                    format!("{file}[{index}] {}", sh.name)
                };
                name.get_or_insert(label);
                sh.mesh
            }
            "cylinder" => {
                let radius = p.float("radius", 1.0)?;
                let p0 = p.vec3_opt("p0")?.unwrap_or(Vec3::ZERO);
                let p1 = p.vec3_opt("p1")?.unwrap_or(Vec3::Z);
                let d = p1 - p0;
                let length = d.length();
                if radius <= 0.0 || length <= 0.0 {
                    return Err(p.err("the cylinder needs a positive radius and p0 != p1"));
                }
                // Mitsuba: to_world · translate(p0) · to_frame(Frame(d / |d|)) · scale(r, r, |d|).
                let f = crate::math::Frame::from_normal(d / length);
                let frame = Mat4::from_cols(
                    f.s.extend(0.0),
                    f.t.extend(0.0),
                    f.n.extend(0.0),
                    glam::Vec4::W,
                );
                xf = xf
                    * Mat4::from_translation(p0)
                    * frame
                    * Mat4::from_scale(Vec3::new(radius, radius, length));
                let l = Mat3::from_mat4(xf);
                if (l.x_axis.length() - l.y_axis.length()).abs() > 1e-4 * l.x_axis.length()
                    || l.x_axis.dot(l.y_axis).abs() > 1e-4 * l.x_axis.length_squared()
                {
                    return Err(p.err("to_world must not contain shear or non-uniform scaling along x and y for a cylinder (Mitsuba's is analytic)"));
                }
                opts.keep_orientation = true;
                shapes::cylinder(shapes::CYLINDER_SEGMENTS)
            }
            "rectangle" => {
                let l = Mat3::from_mat4(xf);
                if l.x_axis.normalize().dot(l.y_axis.normalize()).abs() > 1e-4 {
                    return Err(p.err("the to_world transformation contains shear, which Mitsuba's rectangle does not support"));
                }
                opts.keep_orientation = true;
                shapes::rectangle()
            }
            "disk" => {
                opts.keep_orientation = true;
                shapes::disk(shapes::DISK_RINGS, shapes::DISK_SEGMENTS)
            }
            "cube" => shapes::cube(),
            "sphere" => {
                let center = p.vec3_opt("center")?.unwrap_or(Vec3::ZERO);
                let radius = p.float("radius", 1.0)?;
                if radius <= 0.0 {
                    return Err(p.err("the sphere radius must be positive"));
                }
                xf = xf * Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius));
                // Mitsuba's sphere is analytic: it keeps only the centre and the radius of to_world
                // (warning about the rest), so an ellipsoid here would not match its render.
                let l = Mat3::from_mat4(xf);
                let g = l.transpose() * l;
                let s2 = g.x_axis.x;
                if (g - Mat3::from_diagonal(Vec3::splat(s2)))
                    .to_cols_array()
                    .iter()
                    .any(|v| v.abs() > 1e-4 * s2)
                {
                    return Err(p.err("to_world must not contain non-uniform scale or shear for a sphere (Mitsuba ignores it)"));
                }
                // Analytic, as Mitsuba's: centre, radius and orientation of to_world.
                analytic = true;
                shapes::LocalMesh::default()
            }
            _ => {
                return Err(p.err(
                    "unsupported shape type (btfpt implements obj, ply, serialized, rectangle, cube, sphere, disk, cylinder)",
                ));
            }
        };
        if !is_finite(&xf) {
            return Err(p.err("to_world contains NaN or infinite values"));
        }
        let bsdf_node = p.single_child("bsdf")?;
        let emitter = match p.single_child("emitter")? {
            None => None,
            Some(c) => {
                let e = Props::parse(x, c.node)?;
                if e.ty != "area" {
                    return Err(e.err("only \"area\" emitters can be attached to a shape"));
                }
                let radiance = e.emission("radiance", Vec3::ONE)?;
                e.finish()?;
                self.area_emitters_used.insert(x.key(c.node));
                Some(radiance)
            }
        };
        // Mitsuba's default BSDF: diffuse 0.5, but black on an emitter (an area light without a
        // <bsdf> reflects nothing).
        let bsdf = match bsdf_node {
            Some(c) => self.bsdf_index(c.node)?,
            None => self.default_bsdf(emitter.is_some()),
        };
        p.finish()?;
        let mut mesh = if analytic {
            let sphere = Sphere::from_to_world(&xf, flip_normals)
                .ok_or_else(|| p.err("to_world is singular for a sphere"))?;
            Mesh {
                sphere: Some(sphere),
                ..Default::default()
            }
        } else {
            shapes::to_world(local, &xf, opts).map_err(|m| p.err(m))?
        };
        if mesh.indices.is_empty() && mesh.sphere.is_none() {
            return Err(p.err(match mesh_file {
                Some(f) => format!(
                    "{}: the mesh has no triangles of non-zero area",
                    f.display()
                ),
                None => "the shape has no triangles of non-zero area".into(),
            }));
        }
        mesh.name = name.unwrap_or_else(|| p.ty.clone());
        mesh.bsdf = bsdf;
        mesh.emitter = emitter;
        self.meshes.push(mesh);
        Ok(())
    }
}
