//! Levenberg–Marquardt cost profile: evaluations per fit (histogram) on the curves of a BTF view,
//! in the stored encoding, to tune the solver's stopping rules.
//!
//! usage: cargo run --release --example fit_iterations -- DATA VIEW
#![allow(clippy::needless_range_loop)]

use anyhow::Context;
use btfpt::btf::{self, StoredEncoding};
use btfpt::fit::lafortune::LobeFitter;
use btfpt::math::color::linear_to_srgb;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().context("usage: fit_iterations DATA VIEW")?;
    let src = btf::open(std::path::Path::new(path))?;
    let v: usize = args
        .get(1)
        .and_then(|s| s.parse().ok())
        .filter(|&v| v < src.views().len())
        .context("VIEW must be a view index")?;
    let (texels, nl) = (src.width() * src.height(), src.lights().len());
    let fitter = LobeFitter::new(&src.lights().dirs)?;
    let data = src.load_view(v)?;
    let srgb = src.encoding() == StoredEncoding::Srgb8;
    let mut hist = [0usize; 42];
    let (mut total, mut sse) = (0usize, 0f64);
    let mut y = vec![0f32; nl];
    for t in 0..texels {
        for c in 0..3 {
            for (l, yl) in y.iter_mut().enumerate() {
                let x = data[(l * texels + t) * 3 + c];
                *yl = if srgb {
                    linear_to_srgb(x.clamp(0.0, 1.0))
                } else {
                    x
                };
            }
            let f = fitter.fit(&y);
            hist[(f.evaluations as usize).min(41)] += 1;
            total += f.evaluations as usize;
            sse += f.sse;
        }
    }
    println!(
        "view {v}: {:.2} evaluations per fit, total SSE {sse:.4}",
        total as f64 / (3 * texels) as f64
    );
    for (k, n) in hist.iter().enumerate().filter(|(_, n)| **n > 0) {
        println!("  {k:2}: {n}");
    }
    Ok(())
}
