//! `<shape>`: the table from plugin name to the constructor that reads the shape's properties
//! (mesh files: `obj.rs`, `ply.rs`, `serialized.rs`; built-ins: [`Shape`]'s in `shapes.rs`),
//! then the shape's bsdf and area emitter.

use super::properties::Props;
use super::{Builder, Constructor, N, plugin_constructor};
use crate::Result;
use crate::bsdf::{BlendBsdf, Bsdf, Diffuse, Texture, TwoSided};
use crate::geometry::Mesh;
use crate::light::emitter::Emitter;
use crate::math::transform::is_finite;
use crate::scene::shapes::Shape;
use crate::scene::{obj, ply, serialized};
use std::sync::Arc;

/// Every `<shape>` plugin btfpt implements, by Mitsuba plugin name.
const SHAPE_PLUGINS: &[(&str, Constructor<Shape>)] = &[
    ("obj", obj::from_props),
    ("ply", ply::from_props),
    ("serialized", serialized::from_props),
    ("rectangle", Shape::rectangle_from_props),
    ("cube", Shape::cube_from_props),
    ("sphere", Shape::sphere_from_props),
    ("disk", Shape::disk_from_props),
    ("cylinder", Shape::cylinder_from_props),
];

impl<'a, 'x> Builder<'a, 'x> {
    pub(super) fn shape(&mut self, node: N<'a>) -> Result<()> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        let shape = plugin_constructor(SHAPE_PLUGINS, &p, "shape type", &[])?(&p)?;
        if !is_finite(&shape.to_world) {
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
                let radiance = Emitter::area_radiance_from_props(&e)?;
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
        let name = x.attr(node, "id").map(str::to_string);
        let name = name.or(shape.label.clone()).unwrap_or_else(|| p.ty.clone());
        let mut mesh = shape.into_mesh().map_err(|m| p.err(m))?;
        mesh.name = name;
        mesh.bsdf = match bound_copy(&self.bsdfs[bsdf as usize], &mesh).map_err(|m| p.err(m))? {
            Some(b) => {
                self.bsdfs.push(b);
                (self.bsdfs.len() - 1) as u32
            }
            None => bsdf,
        };
        mesh.emitter = emitter;
        self.meshes.push(mesh);
        Ok(())
    }
}

/// A copy of `b` whose `mesh_attribute` textures are bound to `mesh`'s attributes (None when
/// it has none): each shape evaluates the attribute of its own mesh, as in Mitsuba.
fn bound_copy(b: &Bsdf, mesh: &Mesh) -> std::result::Result<Option<Bsdf>, String> {
    match b {
        Bsdf::Diffuse(d) => match &d.reflectance {
            Texture::MeshAttribute(m) => Ok(Some(Bsdf::Diffuse(Diffuse {
                reflectance: Texture::MeshAttribute(Arc::new(m.bind(mesh)?)),
            }))),
            _ => Ok(None),
        },
        Bsdf::TwoSided(t) => {
            let (front, back) = (bound_copy(&t.front, mesh)?, bound_copy(&t.back, mesh)?);
            if front.is_none() && back.is_none() {
                return Ok(None);
            }
            Ok(Some(Bsdf::TwoSided(TwoSided {
                front: Box::new(front.unwrap_or_else(|| (*t.front).clone())),
                back: Box::new(back.unwrap_or_else(|| (*t.back).clone())),
            })))
        }
        Bsdf::Blend(b) => {
            let weight = match &b.weight {
                Texture::MeshAttribute(m) => Some(Texture::MeshAttribute(Arc::new(m.bind(mesh)?))),
                _ => None,
            };
            let first = bound_copy(&b.bsdfs[0], mesh)?;
            let second = bound_copy(&b.bsdfs[1], mesh)?;
            if weight.is_none() && first.is_none() && second.is_none() {
                return Ok(None);
            }
            Ok(Some(Bsdf::Blend(BlendBsdf {
                weight: weight.unwrap_or_else(|| b.weight.clone()),
                bsdfs: Box::new([
                    first.unwrap_or_else(|| b.bsdfs[0].clone()),
                    second.unwrap_or_else(|| b.bsdfs[1].clone()),
                ]),
            })))
        }
        _ => Ok(None),
    }
}
