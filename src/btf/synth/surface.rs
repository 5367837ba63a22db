//! A virtual material sample: a periodic height field over a W × H texel tile plus per-cell
//! reflectance parameters. Heights and lengths are in texel units; the reference plane is z = 0.

use super::brdf::BrdfParams;
use super::heightfield::HeightField;
use crate::{Error, Result};

/// The micro-geometry and micro-reflectance of one material tile.
#[derive(Clone, Debug)]
pub struct MicroSurface {
    width: usize,
    height: usize,
    hf: HeightField,
    /// Per fine cell, row-major like the height field's cells (one fetch per hit, so AoS).
    params: Vec<BrdfParams>,
}

impl MicroSurface {
    /// Samples `height(x, y)` at the grid vertices and `params(x, y)` at the cell centres of a
    /// grid with `subdiv × subdiv` cells per texel; (x, y) are texel coordinates in
    /// [0, width) × [0, height) (x = column, y = row). The functions should be periodic over the
    /// tile; the grid wraps regardless. `smooth` interpolates vertex normals for shading.
    pub fn from_fn(
        width: usize,
        height: usize,
        subdiv: usize,
        smooth: bool,
        height_fn: impl Fn(f32, f32) -> f32,
        params_fn: impl Fn(f32, f32) -> BrdfParams,
    ) -> Result<Self> {
        if width == 0 || height == 0 || subdiv == 0 {
            return Err(Error::Invalid(format!(
                "material tile {width}×{height} with {subdiv} cells per texel is empty"
            )));
        }
        if width.saturating_mul(height).saturating_mul(subdiv * subdiv) > 1 << 26 {
            return Err(Error::Invalid(format!(
                "material tile {width}×{height} × {subdiv}² cells is too large"
            )));
        }
        let (nx, ny) = (width * subdiv, height * subdiv);
        let step = 1.0 / subdiv as f32;
        let mut heights = Vec::with_capacity(nx * ny);
        let mut params = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                heights.push(height_fn(i as f32 * step, j as f32 * step));
                params.push(params_fn((i as f32 + 0.5) * step, (j as f32 + 0.5) * step));
            }
        }
        // The reference plane is the mean surface height (as a rectified measurement sees it).
        let mean = heights.iter().map(|&h| h as f64).sum::<f64>() / heights.len() as f64;
        for h in &mut heights {
            *h -= mean as f32;
        }
        if params.iter().any(|p| !params_ok(p)) {
            return Err(Error::Invalid(
                "material parameters out of range (negative or non-finite colour, roughness ≤ 0)"
                    .into(),
            ));
        }
        let hf = HeightField::new(
            nx,
            ny,
            width as f32,
            height as f32,
            heights,
            subdiv, // one block per texel: always divides the grid
            smooth,
        )?;
        Ok(MicroSurface {
            width,
            height,
            hf,
            params,
        })
    }

    /// Texels per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows of texels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The geometry.
    pub fn heightfield(&self) -> &HeightField {
        &self.hf
    }

    /// Reflectance of fine cell `cell`.
    #[inline]
    pub fn params(&self, cell: usize) -> &BrdfParams {
        &self.params[cell]
    }
}

fn params_ok(p: &BrdfParams) -> bool {
    let col_ok = |c: crate::math::Vec3| c.is_finite() && c.min_element() >= 0.0;
    col_ok(p.diffuse)
        && col_ok(p.specular)
        && col_ok(p.sheen)
        && p.alpha.is_finite()
        && p.alpha.min_element() > 0.0
        && p.sheen_roughness > 0.0
        && p.coat_alpha > 0.0
        && (0.0..=1.0).contains(&p.coat)
        && p.tangent_angle.is_finite()
}
