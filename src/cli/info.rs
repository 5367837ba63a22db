//! `btfpt info PATH`: what a BTF on disk is (format, directions, size, encoding), its value
//! range and mean per channel, and how much memory it takes.

use anyhow::Context;
use btfpt::btf::{self, BtfFormat, StoredEncoding};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `btfpt info`.
#[derive(clap::Args, Debug)]
pub struct InfoArgs {
    /// A UBO2003 image folder, a UBO2014 `.btf`, a `.btfc` cache, a `synth:` source or a fitted
    /// `.plmc` model.
    pub path: PathBuf,
    /// Compute the value statistics over at most this many views, evenly spaced (0 = all).
    #[arg(long, default_value_t = 0)]
    pub views: usize,
}

fn mib(bytes: f64) -> String {
    if bytes >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.2} GiB", bytes / (1024.0 * 1024.0 * 1024.0))
    } else {
        format!("{:.1} MiB", bytes / (1024.0 * 1024.0))
    }
}

/// Per-channel minimum, maximum and mean (f64 sums), plus non-finite values seen.
struct Stats {
    min: [f32; 3],
    max: [f32; 3],
    sum: [f64; 3],
    count: u64,
    non_finite: u64,
}

impl Stats {
    fn new() -> Self {
        Stats {
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
            sum: [0.0; 3],
            count: 0,
            non_finite: 0,
        }
    }

    fn add(&mut self, values: &[f32]) {
        for px in values.chunks_exact(3) {
            for (c, &v) in px.iter().enumerate() {
                if !v.is_finite() {
                    self.non_finite += 1;
                    continue;
                }
                self.min[c] = self.min[c].min(v);
                self.max[c] = self.max[c].max(v);
                self.sum[c] += v as f64;
            }
            self.count += 1;
        }
    }
}

fn describe_directions(set: &btf::DirectionSet) -> String {
    let max_theta = set.angles_deg.iter().map(|a| a.0).fold(0.0f32, f32::max);
    format!("{} (θ up to {max_theta:.1}°)", set.len())
}

/// Prints the summary of a fitted `.plmc` model: kind, directions, size, clusters, value space,
/// tiles, and the compression ratio against 8-bit raw data of the same texels.
fn describe_model(path: &std::path::Path, heading: impl Fn()) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let (model, tile) = btfpt::model::codec::read_tiled(path)?;
    heading();
    let bytes = std::fs::metadata(path)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
        .len();
    println!("model:       {}", model.kind.name());
    println!("views:       {}", describe_directions(&model.views));
    println!("lights:      {}", describe_directions(&model.lights));
    println!("size:        {} × {} texels", model.width, model.height);
    if let Some(c) = super::figures::clusters(&model, None) {
        println!("clusters:    {c}");
    }
    println!("value space: {}", super::figures::value_space(model.space));
    if let Some(t) = tile {
        println!("tile:        {} × {} texels", t.tile_w, t.tile_h);
    }
    println!(
        "file:        {bytes} bytes, {}",
        super::figures::compression(&model, bytes)
    );
    println!("read in:     {:.2} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// Prints the summary of one BTF.
pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let path = &super::btf_input::resolve(&args.path)?;
    let format = btf::detect_format(path)?;
    // The format is printed only once the file opened as one: a folder that is not a BTF
    // is an error, not a "UBO2003 image folder".
    let heading = || {
        println!("path:        {}", path.display());
        println!("format:      {}", format.name());
    };
    if format == BtfFormat::Plmc {
        return describe_model(path, heading);
    }
    let t0 = Instant::now();
    let src: Box<dyn btf::BtfSource + Send> = if format == BtfFormat::Ubo2014 {
        let b = btf::ubo2014::open_btf(path)?;
        heading();
        let h = b.header();
        println!(
            "header:      {} version {}, cosine flag {} ({}), rgb scale {:?} (not applied, as in btflib and btf.hh), colour model {:?}",
            h.signature,
            h.version,
            h.cosine_flag,
            if h.cosine_flag == 0 {
                "cos θ_l multiplied in on load"
            } else {
                "cosine in data"
            },
            h.rgb_scale,
            b.color_model()
        );
        Box::new(b)
    } else {
        let src = btf::open(path).with_context(|| format!("cannot open {}", path.display()))?;
        heading();
        src
    };
    let open_s = t0.elapsed().as_secs_f64();
    let (nv, nl, w, h) = (
        src.views().len(),
        src.lights().len(),
        src.width(),
        src.height(),
    );
    println!(
        "directions:  {} views × {} lights",
        describe_directions(src.views()),
        describe_directions(src.lights())
    );
    println!("size:        {w} × {h} texels");
    println!(
        "encoding:    {}",
        match src.encoding() {
            StoredEncoding::Srgb8 => "sRGB-encoded integer images (MAE on the sRGB code in [0, 1])",
            StoredEncoding::Linear => "linear floats",
        }
    );
    let values = (nv * nl * w * h * 3) as f64;
    println!(
        "memory:      {} as f16 (whole BTF), {} per view as f32 (streaming)",
        mib(values * 2.0),
        mib(values / nv as f64 * 4.0)
    );
    println!("opened in:   {open_s:.2} s");
    let step = if args.views == 0 || args.views >= nv {
        1
    } else {
        nv.div_ceil(args.views)
    };
    let chosen: Vec<usize> = (0..nv).step_by(step).collect();
    let t1 = Instant::now();
    let mut stats = Stats::new();
    for &v in &chosen {
        let data = src
            .load_view(v)
            .with_context(|| format!("cannot read view {v} of {}", path.display()))?;
        stats.add(&data);
    }
    let read_s = t1.elapsed().as_secs_f64();
    println!(
        "statistics:  over {} of {nv} views (linear, cosine-baked values), read in {read_s:.2} s",
        chosen.len()
    );
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        println!(
            "  {name}: min {:.5}  max {:.5}  mean {:.5}",
            stats.min[c],
            stats.max[c],
            stats.sum[c] / stats.count.max(1) as f64
        );
    }
    if stats.non_finite > 0 {
        println!("  warning: {} non-finite values", stats.non_finite);
    }
    Ok(())
}
