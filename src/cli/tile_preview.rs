//! `btfpt tile-preview mat.plmc -o tiles.png --repeat 4x4`: the model's image for one measured
//! view and light repeated over a grid (sRGB PNG), so seams can be looked at.

use anyhow::{Context, bail};
use btfpt::btf::format;
use btfpt::fit::tiling;
use btfpt::io::{RgbImage, write_png_srgb};
use btfpt::math::rng::mix64;
use std::path::PathBuf;

/// Render a model's tile(s) repeated over a grid.
#[derive(clap::Args, Debug)]
pub struct TilePreviewArgs {
    /// The model file (.plmc).
    pub model: PathBuf,
    /// Output PNG (sRGB).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Grid of tiles: CxR (or N for N×N).
    #[arg(long, default_value = "4x4")]
    pub repeat: String,
    /// Measured view index.
    #[arg(long, default_value_t = 0)]
    pub view: usize,
    /// Measured light index.
    #[arg(long, default_value_t = 0)]
    pub light: usize,
    /// Texel magnification (nearest neighbour).
    #[arg(long, default_value_t = 1)]
    pub zoom: usize,
    /// Exposure multiplier on the linear values before sRGB encoding.
    #[arg(long, default_value_t = 1.0)]
    pub exposure: f32,
    /// Seed of the random tile chosen per cell when the model holds several tiles.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Always use this tile (index) instead of a random choice per cell.
    #[arg(long)]
    pub tile: Option<usize>,
}

/// Runs `btfpt tile-preview`.
pub fn run(a: TilePreviewArgs) -> anyhow::Result<()> {
    let (cols, rows) = tiling::parse_size(&a.repeat).context("--repeat")?;
    if cols * rows > 1 << 16 {
        bail!("--repeat {cols}x{rows}: at most 65536 cells");
    }
    if a.zoom == 0 || a.zoom > 64 {
        bail!("--zoom {} is out of range 1..=64", a.zoom);
    }
    if !(a.exposure.is_finite() && a.exposure > 0.0) {
        bail!("--exposure must be a positive number");
    }
    let (model, section) = format::read_tiled(&a.model)?;
    if a.view >= model.views.len() {
        bail!(
            "--view {} is out of range: {} has {} views",
            a.view,
            a.model.display(),
            model.views.len()
        );
    }
    if a.light >= model.lights.len() {
        bail!(
            "--light {} is out of range: {} has {} lights",
            a.light,
            a.model.display(),
            model.lights.len()
        );
    }
    let (tw, th) = section
        .as_ref()
        .map_or((model.width, model.height), |s| (s.tile_w, s.tile_h));
    let count = (model.width / tw) * (model.height / th);
    if let Some(t) = a.tile
        && t >= count
    {
        bail!("--tile {t} is out of range: the model has {count} tiles");
    }
    let mut recon = Vec::new();
    model.reconstruct_view(a.view, &mut recon);
    let texels = model.width * model.height;
    let img = &recon[a.light * texels * 3..(a.light + 1) * texels * 3];
    let tiles_per_row = model.width / tw;
    let (z, out_w, out_h) = (a.zoom, cols * tw * a.zoom, rows * th * a.zoom);
    let mut out = RgbImage::new(out_w, out_h);
    for r in 0..rows {
        for c in 0..cols {
            let k = a.tile.unwrap_or_else(|| {
                (mix64(a.seed ^ mix64(((r as u64) << 32) | c as u64)) % count as u64) as usize
            });
            let (kx, ky) = (k % tiles_per_row * tw, k / tiles_per_row * th);
            for y in 0..th * z {
                for x in 0..tw * z {
                    let t = (ky + y / z) * model.width + kx + x / z;
                    let v = [img[3 * t], img[3 * t + 1], img[3 * t + 2]].map(|v| v * a.exposure);
                    out.set(c * tw * z + x, r * th * z + y, v);
                }
            }
        }
    }
    write_png_srgb(&a.output, &out)?;
    println!(
        "{}: {}×{} texels, {cols}×{rows} cells of {tw}×{th} ({count} tile{}), view {} light {}",
        a.output.display(),
        out_w,
        out_h,
        if count == 1 { "" } else { "s" },
        a.view,
        a.light
    );
    Ok(())
}
