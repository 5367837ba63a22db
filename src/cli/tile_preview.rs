//! `btfpt tile-preview mat.plmc -o tiles.png --repeat 4x4`: the model's image for one measured
//! view and light repeated over a grid (sRGB PNG), so seams can be looked at.

use anyhow::{Context, bail};
use btfpt::btf::tiling;
use btfpt::io::RgbImage;
use btfpt::math::rng::mix64;
use btfpt::model::codec;
use std::path::PathBuf;

/// Render a model's tile(s) repeated over a grid.
#[derive(clap::Args, Debug)]
pub struct TilePreviewArgs {
    /// The model file (.plmc).
    pub model: PathBuf,
    /// Output image: `.png` (8-bit sRGB) or `.exr` (linear float), by its extension.
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
    /// Tiled models only (fitted with `fit --tile`): show the measured data instead of the
    /// model, the model's stitched tiles cut from this sample (the one it was fitted to), or with
    /// --crop a plain crop of the same size. A model without tiles is refused.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// With --data (tiled models only): a plain crop at the template's origin instead of the
    /// stitched tiles.
    #[arg(long)]
    pub crop: bool,
}

/// Runs `btfpt tile-preview`.
pub fn run(a: TilePreviewArgs) -> anyhow::Result<()> {
    super::output::image_file(&a.output, &super::output::ANY_IMAGE, "-o")?;
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
    let (model, section) = codec::read_tiled(&a.model)?;
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
    if a.crop && a.data.is_none() {
        bail!("--crop needs --data");
    }
    if let Some(t) = a.tile
        && t >= count
    {
        bail!("--tile {t} is out of range: the model has {count} tiles");
    }
    let texels = model.width * model.height;
    let mut recon = vec![0.0f32; texels * 3];
    let mut plane_w = model.width;
    match &a.data {
        Some(d) => {
            let section = section.as_ref().with_context(|| {
                format!(
                    "--data needs a tiled model: {} has no tiles",
                    a.model.display()
                )
            })?;
            let stitch = section.stitch(&a.model)?;
            let source = btfpt::btf::open(&super::btf_input::resolve(d)?)?;
            if (source.width(), source.height()) != (stitch.sample_w, stitch.sample_h)
                || source.views().len() != model.views.len()
                || source.lights().len() != model.lights.len()
            {
                bail!(
                    "{} is not the sample the tiles of {} were cut from",
                    d.display(),
                    a.model.display()
                );
            }
            let n_in = source.width() * source.height() * 3;
            let full = source.load_view(a.view)?;
            let img = &full[a.light * n_in..(a.light + 1) * n_in];
            if a.crop {
                let c =
                    tiling::Stitch::crop(stitch.sample_w, stitch.sample_h, stitch.origin, tw, th);
                recon.truncate(tw * th * 3);
                c.apply(img, &mut recon);
                plane_w = tw;
            } else {
                stitch.apply(img, &mut recon);
            }
        }
        None => {
            let mut all = Vec::new();
            model.reconstruct_view(a.view, &mut all);
            recon.copy_from_slice(&all[a.light * texels * 3..(a.light + 1) * texels * 3]);
        }
    }
    let count = if a.crop { 1 } else { count };
    let img = &recon;
    let tiles_per_row = plane_w / tw;
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
                    let t = (ky + y / z) * plane_w + kx + x / z;
                    let v = [img[3 * t], img[3 * t + 1], img[3 * t + 2]].map(|v| v * a.exposure);
                    out.set(c * tw * z + x, r * th * z + y, v);
                }
            }
        }
    }
    super::output::write_image(&a.output, &out)?;
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
