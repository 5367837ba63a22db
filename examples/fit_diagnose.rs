//! Accuracy diagnostics of the per-view fit (issue 4): for the given views of a BTF, the MAE
//! (stored encoding) of LM, PLM, the "oracle" per-image histogram match of the LM image (each
//! texel gets the original value of its LM rank: the lower bound of any monotone per-image
//! mapping, hence of PLM), a per-texel 10-coefficient quadratic in u (more freedom than LM), and
//! the per-image mean; with `--lights`, per light; with `--align`, the shift maximising the
//! correlation of pairs of images of one view (registration between light directions).
//!
//! usage: cargo run --release --example fit_diagnose -- DATA VIEWS [--linear] [--lights] [--align]
//!        VIEWS = comma-separated view indices, e.g. 0,40,70
#![allow(clippy::needless_range_loop)] // small dense linear algebra reads best with indices
use anyhow::{Context, bail};
use btfpt::btf::{self, BtfSource, StoredEncoding};
use btfpt::fit::lafortune::LobeFitter;
use btfpt::fit::mapping;
use btfpt::math::color::linear_to_srgb;
use btfpt::model::{lobe, polynomial};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        bail!("usage: fit_diagnose DATA VIEWS [--linear] [--lights] [--align]");
    }
    let src = btf::open(std::path::Path::new(&args[0]))?;
    let views = args[1]
        .split(',')
        .map(|s| {
            s.parse::<usize>()
                .ok()
                .filter(|&v| v < src.views().len())
                .with_context(|| format!("'{s}' is not a view index below {}", src.views().len()))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let flag = |f: &str| args.iter().any(|a| a == f);
    for &v in &views {
        if flag("--align") {
            align(&*src, v)?;
        } else {
            diagnose(&*src, v, flag("--linear"), flag("--lights"))?;
        }
    }
    Ok(())
}

fn stored(enc: StoredEncoding, v: f32) -> f32 {
    match enc {
        StoredEncoding::Srgb8 => linear_to_srgb(v.clamp(0.0, 1.0)),
        StoredEncoding::Linear => v,
    }
}

fn diagnose(src: &dyn BtfSource, v: usize, linear: bool, per_light: bool) -> anyhow::Result<()> {
    let (texels, nl, enc) = (
        src.width() * src.height(),
        src.lights().len(),
        src.encoding(),
    );
    let fitter = LobeFitter::new(&src.lights().dirs)?;
    let data = src.load_view(v)?;
    let sdata: Vec<f32> = data.iter().map(|&x| stored(enc, x)).collect();
    let fit_data = if linear { &data } else { &sdata };
    // Model value (fitting space) → stored encoding, as the evaluation clamps it.
    let to_stored = |x: f32| {
        if linear {
            stored(enc, x.max(0.0))
        } else {
            x.clamp(0.0, 1.0)
        }
    };
    let dirs = &src.lights().dirs;
    let quad = |l: usize| {
        let (a, b, z) = (dirs[l].x as f64, dirs[l].y as f64, dirs[l].z as f64);
        [1.0, a, b, z, a * a, b * b, a * b, a * z, b * z, z * z]
    };
    let mut lobes = vec![[0f32; 5]; texels * 3];
    let mut y = vec![0f32; nl];
    let mut e_quad = 0f64;
    for t in 0..texels {
        for c in 0..3 {
            for (l, yl) in y.iter_mut().enumerate() {
                *yl = fit_data[(l * texels + t) * 3 + c];
            }
            lobes[3 * t + c] = fitter.fit(&y).lobe;
            let mut ata = [[0f64; 10]; 10];
            let mut atb = [0f64; 10];
            for (l, &yl) in y.iter().enumerate() {
                let f = quad(l);
                for i in 0..10 {
                    atb[i] += f[i] * yl as f64;
                    for j in 0..10 {
                        ata[i][j] += f[i] * f[j];
                    }
                }
            }
            let x = solve10(ata, atb);
            for l in 0..nl {
                let p: f64 = quad(l).iter().zip(&x).map(|(a, b)| a * b).sum();
                e_quad += (to_stored(p as f32) - sdata[(l * texels + t) * 3 + c]).abs() as f64;
            }
        }
    }
    let mut scratch = mapping::Scratch::default();
    let mut e = vec![[0f64; 4]; nl]; // LM, PLM, oracle, mean
    for l in 0..nl {
        for c in 0..3 {
            let m: Vec<f32> = (0..texels)
                .map(|t| lobe::eval(&lobes[3 * t + c], dirs[l]))
                .collect();
            let o: Vec<f32> = (0..texels)
                .map(|t| fit_data[(l * texels + t) * 3 + c])
                .collect();
            let os: Vec<f32> = (0..texels)
                .map(|t| sdata[(l * texels + t) * 3 + c])
                .collect();
            let a = mapping::fit_mapping(&m, &o, &mut scratch);
            let mut rank: Vec<usize> = (0..texels).collect();
            rank.sort_by(|&i, &j| m[i].total_cmp(&m[j]));
            let mut sorted = o.clone();
            sorted.sort_by(f32::total_cmp);
            let mut oracle = vec![0f32; texels];
            for (r, &i) in rank.iter().enumerate() {
                oracle[i] = sorted[r];
            }
            let mean = os.iter().sum::<f32>() / texels as f32;
            for t in 0..texels {
                e[l][0] += (to_stored(m[t]) - os[t]).abs() as f64;
                e[l][1] += (to_stored(polynomial::eval(&a, m[t])) - os[t]).abs() as f64;
                e[l][2] += (to_stored(oracle[t]) - os[t]).abs() as f64;
                e[l][3] += (mean - os[t]).abs() as f64;
            }
        }
    }
    let per = (texels * 3) as f64;
    let tot: Vec<f64> = (0..4)
        .map(|k| e.iter().map(|r| r[k]).sum::<f64>() / (per * nl as f64))
        .collect();
    let mut ns: Vec<f32> = lobes.iter().map(|l| l[4]).collect();
    ns.sort_by(f32::total_cmp);
    println!(
        "view {v} {:?} ({} fit): LM {:.4}  PLM {:.4}  oracle-match {:.4}  quadratic-10 {:.4}  image-mean {:.4}  | n p10/p50/p90 {:.2}/{:.2}/{:.2}",
        src.views().angles_deg[v],
        if linear { "linear" } else { "stored" },
        tot[0],
        tot[1],
        tot[2],
        e_quad / (per * nl as f64),
        tot[3],
        ns[ns.len() / 10],
        ns[ns.len() / 2],
        ns[ns.len() * 9 / 10]
    );
    if per_light {
        for (l, r) in e.iter().enumerate() {
            println!(
                "  light {l:2} {:?}: LM {:.4} PLM {:.4} oracle {:.4}",
                src.lights().angles_deg[l],
                r[0] / per,
                r[1] / per,
                r[2] / per
            );
        }
    }
    Ok(())
}

/// For pairs of light directions of view `v`: correlation of the two (summed-channel, stored
/// encoding) images at zero shift and the best shift within ±R texels.
fn align(src: &dyn BtfSource, v: usize) -> anyhow::Result<()> {
    const R: i64 = 12;
    let (w, h) = (src.width() as i64, src.height() as i64);
    if w <= 2 * R + 4 || h <= 2 * R + 4 {
        bail!("--align needs images larger than {}² texels", 2 * R + 4);
    }
    let texels = (w * h) as usize;
    let data = src.load_view(v)?;
    let enc = src.encoding();
    let lum = |l: usize, x: i64, y: i64| {
        let b = (l * texels + (y * w + x) as usize) * 3;
        (stored(enc, data[b]) + stored(enc, data[b + 1]) + stored(enc, data[b + 2])) as f64
    };
    for (a, b) in [
        (1, 2),
        (7, 8),
        (19, 20),
        (20, 21),
        (37, 38),
        (57, 58),
        (58, 59),
    ] {
        let (mut best, mut at0) = ((f64::MIN, 0, 0), 0.0);
        for dy in -R..=R {
            for dx in -R..=R {
                let (mut sa, mut sb, mut sab, mut saa, mut sbb, mut n) =
                    (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
                for y in R..h - R {
                    for x in R..w - R {
                        let (p, q) = (lum(a, x, y), lum(b, x + dx, y + dy));
                        (sa, sb, sab, saa, sbb, n) = (
                            sa + p,
                            sb + q,
                            sab + p * q,
                            saa + p * p,
                            sbb + q * q,
                            n + 1.0,
                        );
                    }
                }
                let cov = sab / n - sa * sb / (n * n);
                let r =
                    cov / ((saa / n - sa * sa / (n * n)) * (sbb / n - sb * sb / (n * n))).sqrt();
                if (dx, dy) == (0, 0) {
                    at0 = r;
                }
                if r > best.0 {
                    best = (r, dx, dy);
                }
            }
        }
        println!(
            "view {v} lights {a}-{b} {:?}-{:?}: correlation {at0:.3} at (0, 0), best {:.3} at ({}, {})",
            src.lights().angles_deg[a],
            src.lights().angles_deg[b],
            best.0,
            best.1,
            best.2
        );
    }
    Ok(())
}

fn solve10(mut a: [[f64; 10]; 10], mut b: [f64; 10]) -> [f64; 10] {
    for i in 0..10 {
        a[i][i] += 1e-9;
    }
    for c in 0..10 {
        let p = (c..10)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap_or(c);
        a.swap(c, p);
        b.swap(c, p);
        for r in 0..10 {
            if r != c && a[c][c] != 0.0 {
                let f = a[r][c] / a[c][c];
                for k in c..10 {
                    a[r][k] -= f * a[c][k];
                }
                b[r] -= f * b[c];
            }
        }
    }
    std::array::from_fn(|i| if a[i][i] != 0.0 { b[i] / a[i][i] } else { 0.0 })
}
