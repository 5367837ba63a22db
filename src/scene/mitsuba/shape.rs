//! `<shape>`: the table from plugin name to the constructor that reads the shape's properties
//! (mesh files: `obj.rs`, `ply.rs`, `serialized.rs`; built-ins: [`Shape`]'s in `shapes.rs`),
//! then the shape's bsdf and area emitter.

use super::bsdf::Element;
use super::properties::Props;
use super::{Builder, Constructor, N, plugin_constructor};
use crate::Result;
use crate::bsdf::{BlendBsdf, Bsdf, Diffuse, Texture, TwoSided};
use crate::geometry::Mesh;
use crate::geometry::mesh::Placement;
use crate::light::emitter::Emitter;
use crate::math::Mat4;
use crate::math::transform::is_finite;
use crate::plugin::Properties;
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
        let p = Props::parse(self.x, node)?;
        match p.ty.as_str() {
            "shapegroup" => self.shapegroup(node).map(|_| ()),
            "instance" => self.instance(&p),
            _ => {
                let (mesh, _, emission) = self.plain_shape(node, &p)?;
                if let Some(t) = emission {
                    self.emission_textures.push((self.meshes.len() as u32, t));
                }
                self.meshes.push(mesh);
                Ok(())
            }
        }
    }

    /// A shape other than a group or instance, in world space; for an analytic sphere also its
    /// shape as read (an instance places a copy of it), and for an area emitter whose radiance
    /// is a spatially varying texture, that texture (the mesh's `emitter` is then 1).
    fn plain_shape(
        &mut self,
        node: N<'a>,
        p: &Props<'a, 'x>,
    ) -> Result<(crate::geometry::Mesh, Option<Shape>, Option<Texture>)> {
        let x = self.x;
        let shape =
            plugin_constructor(SHAPE_PLUGINS, p, "shape type", &["shapegroup", "instance"])?(p)?;
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
                let mut element = Element { b: self, p: e };
                let radiance = Emitter::area_radiance_from_props(&mut element)?;
                element.p.finish()?;
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
        let sphere = shape.local.is_none().then(|| shape.clone());
        let mut mesh = shape.into_mesh().map_err(|m| p.err(m))?;
        mesh.name = name;
        mesh.bsdf = match bound_copy(&self.bsdfs[bsdf as usize], &mesh).map_err(|m| p.err(m))? {
            Some(b) => {
                self.bsdfs.push(b);
                (self.bsdfs.len() - 1) as u32
            }
            None => bsdf,
        };
        let emission = emitter.and_then(|r| crate::scene::attach_emission(&mut mesh, r));
        Ok((mesh, sphere, emission))
    }

    /// Mitsuba's `shapegroup`: its shapes are kept in object space, tagged with the group,
    /// and rendered only where an `instance` places them; built once (the group's index).
    /// Emitters, sensors, nested groups and instances inside it are errors, as in Mitsuba.
    fn shapegroup(&mut self, node: N<'a>) -> Result<u32> {
        let x = self.x;
        let key = x.key(node);
        if let Some(&g) = self.groups.get(&key) {
            return Ok(g);
        }
        let p = Props::parse(x, node)?;
        let g = self.group_spheres.len() as u32;
        self.group_spheres.push(Vec::new());
        self.groups.insert(key, g);
        if let Some(c) = p.children_tagged("emitter").first() {
            return Err(x.err(c.at, "shape \"shapegroup\": instancing of emitters is not supported (Mitsuba refuses it)"));
        }
        if let Some(c) = p.children_tagged("sensor").first() {
            return Err(x.err(
                c.at,
                "shape \"shapegroup\": instancing of sensors is not supported (Mitsuba refuses it)",
            ));
        }
        for c in p.children_tagged("shape") {
            let cp = Props::parse(x, c.node)?;
            match cp.ty.as_str() {
                "shapegroup" => {
                    return Err(x.err(c.at, "shape \"shapegroup\": a nested shapegroup is not permitted (as in Mitsuba)"));
                }
                "instance" => {
                    return Err(x.err(c.at, "shape \"shapegroup\": nested instancing (an instance inside a shapegroup) is not permitted (as in Mitsuba)"));
                }
                _ => {}
            }
            if cp.single_child("emitter")?.is_some() {
                return Err(cp.err("instancing of emitters is not supported: a shape inside a shapegroup cannot carry an area emitter (Mitsuba refuses it)"));
            }
            let (mut mesh, sphere, _) = self.plain_shape(c.node, &cp)?;
            match sphere {
                // An analytic sphere costs no triangles: each instance gets its own copy.
                Some(shape) => self.group_spheres[g as usize].push((shape, mesh.bsdf, mesh.name)),
                None => {
                    mesh.group = Some(g);
                    self.meshes.push(mesh);
                }
            }
        }
        p.finish()?;
        Ok(g)
    }

    /// Mitsuba's `instance`: one `<ref>` to a shapegroup and `to_world` (identity).
    fn instance(&mut self, p: &Props<'a, 'x>) -> Result<()> {
        let x = self.x;
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        if !is_finite(&to_world) {
            return Err(p.err("to_world contains NaN or infinite values"));
        }
        let shapes = p.children_tagged("shape");
        let others: Vec<_> = ["bsdf", "emitter", "texture", "sensor"]
            .iter()
            .flat_map(|t| p.children_tagged(t))
            .collect();
        if let Some(c) = others.first() {
            return Err(x.err(
                c.at,
                "shape \"instance\": only a shapegroup can be specified in an instance",
            ));
        }
        let group_node = match shapes.as_slice() {
            [] => {
                return Err(
                    p.err("a reference to a shapegroup must be specified (<ref id=\"...\"/>)")
                );
            }
            [c] => {
                let ty = x.attr(c.node, "type").unwrap_or("");
                if ty != "shapegroup" {
                    return Err(x.err(c.at, format!("shape \"instance\": only a shapegroup can be specified in an instance (this refers to a shape of type \"{ty}\")")));
                }
                c.node
            }
            [_, c, ..] => {
                return Err(x.err(
                    c.at,
                    "shape \"instance\": only a single shapegroup can be specified per instance",
                ));
            }
        };
        p.finish()?;
        let g = self.shapegroup(group_node)?;
        let placement = Placement::new(g, to_world).ok_or_else(|| p.err("to_world is singular"))?;
        for (shape, bsdf, name) in self.group_spheres[g as usize].clone() {
            let mut s = shape;
            s.to_world = to_world * s.to_world;
            if !Shape::scales_uniformly(&s.to_world) {
                return Err(p.err(format!("the shapegroup's sphere \"{name}\" would be scaled non-uniformly (an analytic sphere must stay a sphere)")));
            }
            let mut mesh = s.into_mesh().map_err(|m| p.err(m))?;
            mesh.name = name;
            mesh.bsdf = bsdf;
            self.meshes.push(mesh);
        }
        let name = x.attr(p.node, "id").unwrap_or("instance").to_string();
        self.meshes.push(Mesh {
            name,
            instance: Some(Box::new(placement)),
            ..Default::default()
        });
        Ok(())
    }
}

/// A copy of `b` whose `mesh_attribute` textures are bound to `mesh`'s attributes (None when
/// it has none): each shape evaluates the attribute of its own mesh, as in Mitsuba. Binds the
/// slots of `bsdf.rs`'s `MESH_ATTRIBUTE_SLOTS` (the only ones the loader lets one stand in),
/// through `twosided` and `blendbsdf`.
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
