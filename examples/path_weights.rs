//! Where an image's largest sample values come from: traces a scene with the scalar path
//! integrator ([`Integrator::li_observed`], the same paths as `btfpt render --integrator scalar`)
//! and breaks the top 0.1 % of (a) the radiance contributions and (b) the BSDF sample weights
//! f·cos/pdf down by material, view (outgoing) elevation, NEE or BSDF-sampled, and the
//! sampler component that drew the direction.
//!
//! `cargo run --release --example path_weights -- scenes/showcase/scene.xml [SPP] [SEED]
//!  [-D name=value]…`; prints markdown tables.

use btfpt::bsdf::Bsdf;
use btfpt::bsdf::btf_sampler::DEFENSIVE_FRACTION;
use btfpt::geometry::SurfaceInteraction;
use btfpt::math::color::luminance;
use btfpt::math::{Pcg32, Vec2, Vec3};
use btfpt::render::RenderScene;
use btfpt::render::integrator::{TraceStats, film_sample_start};
use btfpt::render::path::PathEvent;
use btfpt::scene::{self, LoadOptions};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

/// One recorded value: its luminance and the vertex it is charged to.
#[derive(Clone, Debug)]
struct Rec {
    value: f32,
    /// "NEE", "BSDF-sampled" (a BSDF-sampled ray hit an emitter) or "camera" (emitter seen
    /// directly); for weights "BSDF sample".
    kind: &'static str,
    material: String,
    /// View elevation θ_v of the charged vertex, degrees (−1 for camera).
    theta: f32,
    component: &'static str,
    depth: u32,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut pos = Vec::new();
    let mut defines = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "-D" {
            let d = it
                .next()
                .ok_or_else(|| anyhow::anyhow!("-D needs name=value"))?;
            let (n, v) = d
                .split_once('=')
                .ok_or_else(|| anyhow::anyhow!("-D {d}: expected name=value"))?;
            defines.push((n.to_string(), v.to_string()));
        } else {
            pos.push(a.clone());
        }
    }
    let path = pos
        .first()
        .ok_or_else(|| anyhow::anyhow!("usage: path_weights SCENE [SPP] [SEED] [-D n=v]…"))?;
    let spp: u32 = pos.get(1).map_or(Ok(64), |s| s.parse())?;
    let seed: u64 = pos.get(2).map_or(Ok(0), |s| s.parse())?;
    let scene = scene::load(Path::new(path), &LoadOptions::with_defines(&defines))?;
    let names = material_names(&scene);
    let rs = RenderScene::new(scene)?;
    let (w, h) = rs.scene.camera.image_size();
    let component = |bsdf: u32, wi: Vec3, uv: Vec2, u1: f32| -> &'static str {
        match rs.scene.bsdfs.get(bsdf as usize) {
            Some(Bsdf::Plmc(b)) => b.sampling_component(&SurfaceInteraction::for_tests(wi, uv), u1),
            Some(Bsdf::Btf(_)) if u1 < DEFENSIVE_FRACTION => "uniform",
            Some(Bsdf::Btf(_)) => "table",
            _ => "-",
        }
    };
    let rows: Vec<(Vec<Rec>, Vec<Rec>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let (mut contrib, mut weights) = (Vec::new(), Vec::new());
            let mut events = Vec::new();
            let mut stats = TraceStats::default();
            for sample in 0..spp as u64 {
                for x in 0..w {
                    let (mut rng, fx, fy): (Pcg32, f32, f32) =
                        film_sample_start(seed, w, x, y, sample);
                    let (o, d, tmax) = rs.camera.ray(fx, fy);
                    events.clear();
                    rs.integrator
                        .li_observed(&rs, o, d, tmax, &mut rng, &mut stats, &mut |e| {
                            events.push(e)
                        });
                    charge(&events, &names, &component, &mut contrib, &mut weights);
                }
            }
            (contrib, weights)
        })
        .collect();
    let (mut contrib, mut weights): (Vec<Rec>, Vec<Rec>) = (Vec::new(), Vec::new());
    for (c, wt) in rows {
        contrib.extend(c);
        weights.extend(wt);
    }
    println!("scene {path}, {w}×{h}, {spp} spp, seed {seed} (scalar path integrator)\n");
    report(
        "radiance contributions (MIS-weighted, times throughput)",
        &mut contrib,
    );
    report("BSDF sample weights f·cos/pdf (luminance)", &mut weights);
    Ok(())
}

/// The material names of the scene's BSDFs: the file of a measured material, else the kind.
fn material_names(scene: &btfpt::scene::Scene) -> Vec<String> {
    let mut files = scene.btf_uses.iter();
    let mut seen: Vec<(usize, String)> = Vec::new();
    scene
        .bsdfs
        .iter()
        .map(|b| {
            let key = match b {
                Bsdf::Plmc(p) => std::sync::Arc::as_ptr(p.material()) as *const u8 as usize,
                Bsdf::Btf(r) => std::sync::Arc::as_ptr(r.material()) as *const u8 as usize,
                other => return format!("{other:?}").chars().take(24).collect(),
            };
            if let Some((_, n)) = seen.iter().find(|(k, _)| *k == key) {
                return n.clone();
            }
            let n = files
                .next()
                .and_then(|u| u.file.file_stem())
                .map_or("btf".into(), |s| s.to_string_lossy().into_owned());
            seen.push((key, n.clone()));
            n
        })
        .collect()
}

/// Turns one path's events into records: each contribution charged to the vertex whose
/// sampling made it (NEE: that vertex; an emitter hit: the BSDF sample that found it), and
/// every BSDF sample weight.
fn charge(
    events: &[PathEvent],
    names: &[String],
    component: &impl Fn(u32, Vec3, Vec2, f32) -> &'static str,
    contrib: &mut Vec<Rec>,
    weights: &mut Vec<Rec>,
) {
    let name = |b: u32| names.get(b as usize).cloned().unwrap_or_default();
    let theta = |z: f32| z.clamp(-1.0, 1.0).acos().to_degrees();
    let mut last: Option<Rec> = None;
    for e in events {
        match *e {
            PathEvent::BsdfSampled {
                depth,
                bsdf,
                wi,
                uv,
                u1,
                weight,
                ..
            } => {
                let r = Rec {
                    value: luminance(weight),
                    kind: "BSDF sample",
                    material: name(bsdf),
                    theta: theta(wi.z),
                    component: component(bsdf, wi, uv, u1),
                    depth,
                };
                weights.push(r.clone());
                last = Some(r);
            }
            PathEvent::EmitterSampled {
                depth,
                bsdf,
                wi,
                value,
            } => contrib.push(Rec {
                value: luminance(value),
                kind: "NEE",
                material: name(bsdf),
                theta: theta(wi.z),
                component: "-",
                depth,
            }),
            PathEvent::Emitted { depth, value } => contrib.push(match (&last, depth) {
                (Some(r), d) if d > 0 => Rec {
                    value: luminance(value),
                    kind: "BSDF-sampled",
                    ..r.clone()
                },
                _ => Rec {
                    value: luminance(value),
                    kind: "camera",
                    material: "-".into(),
                    theta: -1.0,
                    component: "-",
                    depth: 0,
                },
            }),
        }
    }
}

/// An attribute records are grouped by.
type Key = fn(&Rec) -> String;

/// Prints the top 0.1 % of `recs` by value, grouped by each attribute.
fn report(title: &str, recs: &mut [Rec]) {
    recs.sort_by(|a, b| b.value.total_cmp(&a.value));
    let n = recs.len();
    let top = (n / 1000).max(1).min(n);
    let total: f64 = recs.iter().map(|r| r.value as f64).sum();
    let top_sum: f64 = recs[..top].iter().map(|r| r.value as f64).sum();
    println!("## {title}\n");
    println!(
        "{n} values, sum {total:.4e}; top 0.1 % = {top} values ≥ {:.3e} (max {:.3e}), {:.1} % of the sum\n",
        recs.get(top.saturating_sub(1)).map_or(0.0, |r| r.value),
        recs.first().map_or(0.0, |r| r.value),
        100.0 * top_sum / total.max(1e-30)
    );
    let keyed: [(&str, Key); 5] = [
        ("kind", |r| r.kind.to_string()),
        ("material", |r| r.material.clone()),
        ("view θ_v (15° bins)", |r| {
            if r.theta < 0.0 {
                "-".into()
            } else {
                let b = ((r.theta / 15.0) as u32).min(5) * 15;
                format!("{b:2}–{}°", b + 15)
            }
        }),
        ("sampler component", |r| r.component.to_string()),
        ("depth", |r| r.depth.to_string()),
    ];
    for (label, key) in keyed {
        let mut g: BTreeMap<String, (usize, f64)> = BTreeMap::new();
        for r in &recs[..top] {
            let e = g.entry(key(r)).or_default();
            e.0 += 1;
            e.1 += r.value as f64;
        }
        let mut all: BTreeMap<String, usize> = BTreeMap::new();
        for r in recs.iter() {
            *all.entry(key(r)).or_default() += 1;
        }
        println!("| {label} | top-0.1 % count | share of top-0.1 % sum | share of all values |");
        println!("|---|---|---|---|");
        for (k, (c, s)) in &g {
            println!(
                "| {k} | {c} | {:.1} % | {:.2} % |",
                100.0 * s / top_sum.max(1e-30),
                100.0 * *all.get(k).unwrap_or(&0) as f64 / n as f64
            );
        }
        println!();
    }
}
