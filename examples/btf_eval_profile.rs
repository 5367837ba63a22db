//! Runs the workloads of `benches/btf_eval.rs` once, for instruction counts under callgrind
//! (load-independent, unlike timings on a shared machine) and ray counts:
//!
//! `cargo build --release --example btf_eval_profile &&
//!  valgrind --tool=callgrind target/release/examples/btf_eval_profile eval 64`
//!
//! Modes: `eval SIZE` (4096 PLM-C evaluations on a SIZE² model, after a warm-up pass),
//! `sample SIZE`, `eval_pdf SIZE`, `batch16 SIZE` / `batch16_pdf SIZE` (the bench's
//! `plmc_batch16` / `plmc_eval_pdf_batch16` loops: `prepare16` for 16 hits, one `eval_pdf_batch`),
//! `prep SIZE` (their `prepare16` calls alone), `kernel16 SIZE` (their 16-query kernel alone, on
//! queries located beforehand), `render diffuse|plmc` (the bench's 64 × 64 × 4 spp box, one
//! thread; prints the rays traced; `PACKET=1`: with the packet integrator). `NO_AVX512=1` runs the generic kernel (valgrind does not
//! emulate AVX-512, so under callgrind it always does); `NO_PREFETCH=1` turns off
//! `PlmcBsdf::prepare`'s prefetch; `K=n` keeps n clusters (smaller record tables); with
//! `kernel16`, `FIXV=1` / `FIXL=1` give every query the first one's views / lights (hot
//! records and polynomial rows: what is left is the kernel's compute and the index misses).

use btfpt::bsdf::plmc::{BATCH, PlmcHit, PlmcMaterial};
use btfpt::bsdf::{Bsdf, Diffuse, PlmcBsdf, Texture};
use btfpt::math::{Pcg32, Spectrum};
use btfpt::model::ModelKind;
use btfpt::render::film::RenderState;
use std::hint::black_box;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
#[path = "../benches/common/btf_scene.rs"]
#[allow(dead_code)]
mod btf_scene;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("eval", |s| s.as_str());
    let arg = args.get(2).map_or("64", |s| s.as_str());
    let reps: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    if mode == "render" {
        let bsdf = if arg == "diffuse" {
            Bsdf::Diffuse(Diffuse {
                reflectance: Texture::Constant(Spectrum::splat(0.5)),
            })
        } else {
            let size = std::env::var("SIZE").map_or(btf_scene::SIZE, |s| s.parse().unwrap());
            let mut m = PlmcMaterial::new(&btf_scene::model_sized(ModelKind::PlmC, size)).unwrap();
            if std::env::var_os("NO_AVX512").is_some() {
                m = m.without_avx512();
            }
            let mut b = PlmcBsdf::new(Arc::new(m), 4.0, false).unwrap();
            if std::env::var_os("NO_PREFETCH").is_some() {
                b = b.without_prefetch();
            }
            Bsdf::Plmc(b)
        };
        let mut rs = btf_scene::scene(bsdf);
        if std::env::var_os("PACKET").is_some() {
            rs.kind = btfpt::render::IntegratorKind::Packet(Default::default());
        }
        let settings = btf_scene::box_scene::settings();
        let pool = btf_scene::box_scene::single_thread_pool();
        let stop = AtomicBool::new(false);
        let mut best = f64::INFINITY;
        let mut rays = 0;
        for _ in 0..reps {
            let t = cpu_ns(libc::CLOCK_PROCESS_CPUTIME_ID);
            let mut st = RenderState::new(settings).unwrap();
            pool.install(|| btfpt::render::driver::run_pass(&rs, &mut st, 4, &stop, &|_, _| {}));
            best = best.min((cpu_ns(libc::CLOCK_PROCESS_CPUTIME_ID) - t) as f64 * 1e-6);
            rays = st.rays();
        }
        println!("render {arg}: {rays} rays, {best:.2} ms (process CPU, best of {reps})");
        return;
    }
    let size: usize = arg.parse().unwrap();
    let mut model = btf_scene::model_sized(ModelKind::PlmC, size);
    if let Some(kk) = std::env::var("K")
        .ok()
        .and_then(|s| s.parse::<usize>().ok())
    {
        // Fewer clusters (smaller record tables), same texel pattern.
        model.clusters = kk;
        for p in &mut model.params {
            if let btfpt::model::ViewParams::Clustered { k, table, index } = p {
                *k = kk;
                table.truncate(3 * kk);
                index.iter_mut().for_each(|i| *i %= kk as u16);
            }
        }
    }
    let mut m = PlmcMaterial::new(&model).unwrap();
    if std::env::var_os("NO_AVX512").is_some() {
        m = m.without_avx512();
    }
    let mut bsdf = PlmcBsdf::new(Arc::new(m), 1.0, false).unwrap();
    if std::env::var_os("NO_PREFETCH").is_some() {
        bsdf = bsdf.without_prefetch();
    }
    let q = btf_scene::queries();
    let mut rng = Pcg32::new(7, 3);
    let mut best = f64::INFINITY;
    if mode.starts_with("kernel16") || mode.starts_with("prep") {
        use btfpt::bsdf::plmc::BatchQuery;
        let m = bsdf.material();
        let mut pre: Vec<BatchQuery> = q
            .iter()
            .map(|(si, wo)| {
                let (x, y) = bsdf.texel(si.uv);
                let (vi, vw) = m.view_lookup(si.wi);
                let (li, lw) = m.light_lookup(*wo);
                BatchQuery {
                    texel: (y * m.width() + x) as u32,
                    vi,
                    vw,
                    li,
                    lw,
                    wo: [wo.x, wo.y, wo.z],
                }
            })
            .collect();
        if std::env::var_os("FIXL").is_some() {
            // Every query at query 0's lights (hot polynomial rows; views and texels random).
            let (li, lw) = (pre[0].li, pre[0].lw);
            pre.iter_mut().for_each(|p| (p.li, p.lw) = (li, lw));
        }
        if std::env::var_os("FIXV").is_some() {
            // Every query at query 0's views (hot records and rows; texels random).
            let (vi, vw) = (pre[0].vi, pre[0].vw);
            pre.iter_mut().for_each(|p| (p.vi, p.vw) = (vi, vw));
        }

        for pass in 0..=reps {
            let t = thread_cpu_ns();
            let mut acc = [0f32; 3];
            if mode.starts_with("prep") {
                for chunk in q.chunks(BATCH) {
                    let hits: [PlmcHit; BATCH] = btf_scene::hits16(&bsdf, black_box(chunk));
                    black_box(&hits);
                }
            } else {
                let mut out = [[0f32; 3]; BATCH];
                for c in pre.chunks(BATCH) {
                    m.eval_b_batch(black_box(c), &mut out);
                    acc[0] += out[0][0];
                }
            }
            black_box(acc);
            if pass > 0 {
                best = best.min((thread_cpu_ns() - t) as f64 / q.len() as f64);
            }
        }
        println!("{mode} {size}²: {best:.1} ns per call (thread CPU, best of {reps})");
        return;
    }
    if mode == "kernel" {
        // The kernel alone: lookups and texels done before (as a per-hit state would).
        let m = bsdf.material();
        let pre: Vec<_> = q
            .iter()
            .map(|(si, wo)| {
                let (x, y) = bsdf.texel(si.uv);
                (
                    m.view_lookup(si.wi),
                    m.light_lookup(*wo),
                    *wo,
                    y * m.width() + x,
                )
            })
            .collect();
        for pass in 0..=reps {
            let t = thread_cpu_ns();
            let mut acc = [0f32; 3];
            for &((vi, vw), (li, lw), wo, texel) in &pre {
                let b = m.eval_b_with(vi, vw, li, lw, black_box(wo), &[(texel, 1.0)]);
                acc[0] += b[0];
            }
            black_box(acc);
            if pass > 0 {
                best = best.min((thread_cpu_ns() - t) as f64 / q.len() as f64);
            }
        }
        println!("{mode} {size}²: {best:.1} ns per call (thread CPU, best of {reps})");
        return;
    }
    for pass in 0..=reps {
        let t = thread_cpu_ns();
        black_box(queries(&bsdf, &q, mode, &mut rng));
        if pass > 0 {
            best = best.min((thread_cpu_ns() - t) as f64 / q.len() as f64);
        }
    }
    println!("{mode} {size}²: {best:.1} ns per call (thread CPU, best of {reps})");
}

/// CPU time of the calling thread in ns.
fn thread_cpu_ns() -> u64 {
    cpu_ns(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// CPU time of `clock` in ns.
fn cpu_ns(clock: libc::clockid_t) -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec.
    unsafe { libc::clock_gettime(clock, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// One pass over the queries (out of line: `--toggle-collect=*queries*` counts only this).
#[inline(never)]
fn queries(
    bsdf: &PlmcBsdf,
    q: &[(btfpt::geometry::SurfaceInteraction, btfpt::math::Vec3)],
    mode: &str,
    rng: &mut Pcg32,
) -> Spectrum {
    let mut acc = Spectrum::ZERO;
    if mode.starts_with("batch16") {
        // The bench's `plmc_batch16` / `plmc_eval_pdf_batch16` loop.
        let want = [mode == "batch16_pdf"; BATCH];
        let mut out = [(Spectrum::ZERO, 0.0); BATCH];
        for chunk in q.chunks(BATCH) {
            let n = chunk.len();
            let hits: [PlmcHit; BATCH] = btf_scene::hits16(bsdf, black_box(chunk));
            let wo: [btfpt::math::Vec3; BATCH] = std::array::from_fn(|j| chunk[j.min(n - 1)].1);
            bsdf.eval_pdf_batch(&hits[..n], black_box(&wo[..n]), &want[..n], &mut out[..n]);
            for (f, pdf) in &out[..n] {
                acc += *f * pdf.max(1.0);
            }
        }
        return acc;
    }
    for (si, wo) in q {
        match mode {
            "eval" => acc += bsdf.eval(black_box(si), black_box(*wo)),
            "eval_pdf" => {
                let (f, p) = bsdf.eval_pdf(black_box(si), black_box(*wo));
                acc += f * p;
            }
            "sample" => {
                if let Some((_, w)) = bsdf.sample(black_box(si), rng.next_f32(), rng.next_2d()) {
                    acc += w;
                }
            }
            "lookups" => {
                let m = bsdf.material();
                let (vi, vw) = m.view_lookup(black_box(si.wi));
                let (li, lw) = m.light_lookup(black_box(*wo));
                acc += Spectrum::new(vw[0] + lw[1], (vi[0] + li[2]) as f32, 0.0);
            }
            "texel" => {
                let (x, y) = bsdf.texel(black_box(si.uv));
                acc += Spectrum::splat((x + y) as f32);
            }
            _ => panic!("unknown mode {mode}"),
        }
    }
    acc
}
