//! `btfpt.synth`, `btfpt.fit`, `btfpt.eval_model`: the `synth`, `fit` and `eval` commands as
//! functions, through the same library calls, returning the figures the CLI prints or writes.

use crate::errors::{IntoPy, invalid, missing};
use crate::interrupt::{self, Progress};
use btfpt::btf::synth::{MaterialKind, SynthSettings, disk_cache, measure};
use btfpt::btf::ubo2003::{ImageKind, write_folder};
use btfpt::btf::{self, DirectionSet, tiling};
use btfpt::fit::pipeline::{self, FitOptions};
use btfpt::fit::report::raw_bytes;
use btfpt::fit::view_selection::ViewSelection;
use btfpt::model::{ModelKind, codec};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

fn exists(p: &Path, what: &str) -> PyResult<()> {
    if p.exists() {
        Ok(())
    } else {
        Err(missing(format!("{}: {what} not found", p.display())))
    }
}

/// The file to read for the BTF data `data`, as the CLI's `fit` and `eval --against` read it:
/// `data` itself, or for a `synth:` source its entry in the user's cache folder (generated
/// first, GIL released; with `progress` the note of where it came from goes to stderr).
fn data_file(py: Python<'_>, data: PathBuf, progress: bool) -> PyResult<PathBuf> {
    let dir = disk_cache::default_cache_dir();
    let (path, note) = py
        .detach(|| disk_cache::resolve_input(&data, dir.as_deref()))
        .py_err()?;
    if let (Some(note), true) = (note, progress) {
        eprintln!("{note}");
    }
    exists(&path, "BTF data")?;
    Ok(path)
}

/// Measures the procedural material `material` ("wool", "corduroy", "leather", "wood", "foil")
/// with the virtual gonioreflectometer, as `btfpt synth`: `size` texels (N or (W, H); 64),
/// `directions` "ubo2003" (81) or "ubo2014" (151, needs a `.btfc` output), written to `out` (a
/// folder of `format` "png8", "png16" or "exr" images, or NAME.btfc). Returns `out`.
#[pyfunction]
#[pyo3(signature = (material, size=None, seed=1, out=None, directions="ubo2003", format="png8", progress=true))]
#[allow(clippy::too_many_arguments)]
pub fn synth(
    py: Python<'_>,
    material: &str,
    size: Option<&Bound<'_, PyAny>>,
    seed: u64,
    out: Option<PathBuf>,
    directions: &str,
    format: &str,
    progress: bool,
) -> PyResult<PathBuf> {
    let kind = MaterialKind::from_name(material).py_err()?;
    let (w, h): (usize, usize) = match size {
        None => (64, 64),
        Some(s) => match s.extract::<usize>() {
            Ok(n) => (n, n),
            Err(_) => s
                .extract()
                .map_err(|_| invalid("size: expected N or (W, H)"))?,
        },
    };
    if !(1..=4096).contains(&w) || !(1..=4096).contains(&h) {
        return Err(invalid(format!(
            "size: {w}×{h} texels is out of range 1..=4096"
        )));
    }
    let dirs = match directions.to_ascii_lowercase().as_str() {
        "ubo2003" => DirectionSet::ubo2003(),
        "ubo2014" => DirectionSet::ubo2014(),
        o => {
            return Err(invalid(format!(
                "directions: unknown set '{o}' (expected ubo2003 or ubo2014)"
            )));
        }
    };
    let image = match format.to_ascii_lowercase().as_str() {
        "png8" => ImageKind::Png8,
        "png16" => ImageKind::Png16,
        "exr" => ImageKind::Exr,
        o => {
            return Err(invalid(format!(
                "format: unknown '{o}' (expected png8, png16 or exr)"
            )));
        }
    };
    let Some(out) = out else {
        return Err(invalid("out: give an output (a folder, or NAME.btfc)"));
    };
    let cache = out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("btfc"));
    if !cache && dirs.len() != 81 {
        return Err(invalid(format!(
            "{}: --directions ubo2014 has 151 directions but a UBO2003 folder holds the 81 UBO2003 directions; write the .btfc cache instead (out=NAME.btfc)",
            out.display()
        )));
    }
    if out.exists() {
        return Err(invalid(format!(
            "{}: already exists; remove it or choose another output",
            out.display()
        )));
    }
    let bar = Progress::new(format!("synth {material}"), "steps", 1, progress);
    let r = interrupt::run(py, &bar, |_| -> btfpt::Result<()> {
        let surface = kind.build(w, h, 4, seed)?;
        let settings = SynthSettings {
            views: dirs.clone(),
            lights: dirs,
            strata: 2,
            seed,
            interreflection: true,
            indirect_clamp: 1.0,
            progress: false,
        };
        let btf = measure(&surface, &settings)?;
        if cache {
            btf::cache::write_raw(&btf, &out)?;
        } else {
            write_folder(&btf, &out, image)?;
        }
        bar.done.store(1, Ordering::Relaxed);
        Ok(())
    })?;
    r.py_err()?;
    Ok(out)
}

/// Fits a model to measured data, as `btfpt fit DATA -o OUT` (`data` a UBO2003 folder, `.btf`,
/// `.btfc` or a `synth:` source, read through the cache folder as the CLI reads it): `model`
/// "lm", "plm" or "plmc",
/// `clusters` per view and colour channel, `views` (e.g. "0..10" or "1/4": fit only those into
/// OUT.parts/, as `--views`), `tile` ("WxH": one seamless tile, as `--tile`). Ctrl-C keeps the
/// finished views in OUT.parts/; the same call resumes. Returns a dict of the figures `fit`
/// prints: path, model, bytes, ratio, seconds, clusters (lo, hi), resumed_views and the
/// fit statistics.
#[pyfunction]
#[pyo3(signature = (data, out, model="plmc", clusters=256, views=None, tile=None, progress=true))]
#[allow(clippy::too_many_arguments)]
pub fn fit<'py>(
    py: Python<'py>,
    data: PathBuf,
    out: PathBuf,
    model: &str,
    clusters: usize,
    views: Option<String>,
    tile: Option<String>,
    progress: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let kind = match model {
        "lm" => ModelKind::Lm,
        "plm" => ModelKind::Plm,
        "plmc" => ModelKind::PlmC,
        o => {
            return Err(invalid(format!(
                "model \"{o}\": expected \"lm\", \"plm\" or \"plmc\""
            )));
        }
    };
    if out.is_dir() {
        return Err(invalid(format!(
            "{}: is a folder; give a .plmc file name",
            out.display()
        )));
    }
    let spec = tile
        .as_deref()
        .map(|t| {
            tiling::parse_size(t).map(|(width, height)| tiling::TileSpec {
                width,
                height,
                count: 1,
                overlap: None,
            })
        })
        .transpose()
        .py_err()?;
    let opts = FitOptions {
        kind,
        clusters,
        ..FitOptions::default()
    };
    let data = data_file(py, data, progress)?;
    let source_data = py.detach(|| btf::open(&data)).py_err()?;
    let nviews = source_data.views().len();
    let selection = views
        .as_deref()
        .map(|s| ViewSelection::parse(s, nviews))
        .transpose()
        .py_err()?;
    let bar = Progress::new(
        format!("fit {}", kind.name()),
        "views",
        selection.as_ref().map_or(nviews, |s| s.len()) as u64,
        progress,
    );
    let parts = pipeline::parts_dir(&out);
    let start = std::time::Instant::now();
    let result = interrupt::run(
        py,
        &bar,
        |stop| -> btfpt::Result<Option<(pipeline::FitOutcome, u64)>> {
            let stitch = spec
                .as_ref()
                .map(|s| tiling::find_stitch(&*source_data, s))
                .transpose()?;
            let tiled = stitch
                .as_ref()
                .map(|s| tiling::TiledSource::new(&*source_data, s))
                .transpose()?;
            let source: &dyn btf::BtfSource = match &tiled {
                Some(t) => t,
                None => &*source_data,
            };
            let key = stitch.as_ref().map_or(0, |s| s.key());
            let step = |_, stage| {
                if stage == pipeline::Stage::Done {
                    bar.done.fetch_add(1, Ordering::Relaxed);
                }
            };
            if let Some(sel) = &selection {
                pipeline::fit_views_keyed(source, &opts, key, &parts, sel, stop, &step)?;
                return Ok(None);
            }
            let outcome = pipeline::fit_model_keyed(source, &opts, key, Some(&parts), stop, &step)?;
            let section = stitch
                .as_ref()
                .map(codec::TileSection::from_stitch)
                .transpose()?;
            codec::write_tiled(&out, &outcome.model, section.as_ref())?;
            std::fs::remove_dir_all(&parts).map_err(|e| btfpt::Error::io(&parts, e))?;
            let bytes = std::fs::metadata(&out)
                .map_err(|e| btfpt::Error::io(&out, e))?
                .len();
            Ok(Some((outcome, bytes)))
        },
    )?
    .py_err()?;
    let seconds = start.elapsed().as_secs_f64();
    let d = PyDict::new(py);
    d.set_item("path", &out)?;
    d.set_item("model", kind.name())?;
    d.set_item("seconds", seconds)?;
    let Some((o, bytes)) = result else {
        d.set_item("parts", &parts)?;
        return Ok(d);
    };
    let m = &o.model;
    d.set_item("bytes", bytes)?;
    d.set_item(
        "raw_bytes",
        raw_bytes(m.views.len(), m.lights.len(), m.width * m.height),
    )?;
    d.set_item(
        "ratio",
        raw_bytes(m.views.len(), m.lights.len(), m.width * m.height) as f64 / bytes.max(1) as f64,
    )?;
    d.set_item("size", (m.width, m.height))?;
    d.set_item("resumed_views", o.resumed_views)?;
    let ks: Vec<usize> = m
        .params
        .iter()
        .filter_map(|p| match p {
            btfpt::model::ViewParams::Clustered { k, .. } => Some(*k),
            btfpt::model::ViewParams::Texel(_) => None,
        })
        .collect();
    if let (Some(lo), Some(hi)) = (ks.iter().min(), ks.iter().max()) {
        d.set_item("clusters", (*lo, *hi))?;
    }
    let s = o.stats;
    let st = PyDict::new(py);
    st.set_item("refit_wins", s.refit_wins)?;
    st.set_item("average_wins", s.average_wins)?;
    st.set_item("kmeans_iterations", s.kmeans_iterations)?;
    st.set_item("matched_polys", s.matched_polys)?;
    st.set_item("regression_polys", s.regression_polys)?;
    st.set_item("refine_rounds", s.refine_rounds)?;
    st.set_item("refine_moves", s.refine_moves)?;
    d.set_item("stats", st)?;
    Ok(d)
}

/// Evaluates a model file against the measured data it was fitted to, as `btfpt eval MODEL
/// --against DATA --json` (`against` as `fit`'s `data`, `synth:` sources included): returns the
/// JSON document as a dict (error table per model kind,
/// raw size, seam figures, the tile's figures for tiled models).
#[pyfunction]
#[pyo3(signature = (model, against, clusters=256, features=20, seed=0, pca_k=None, progress=true))]
#[allow(clippy::too_many_arguments)]
pub fn eval_model<'py>(
    py: Python<'py>,
    model: PathBuf,
    against: PathBuf,
    clusters: usize,
    features: usize,
    seed: u64,
    pca_k: Option<usize>,
    progress: bool,
) -> PyResult<Bound<'py, PyAny>> {
    exists(&model, "model file")?;
    let against = data_file(py, against, progress)?;
    let views = codec::read_header(&model).py_err()?.views.len();
    let opts = FitOptions {
        clusters,
        features,
        seed,
        ..FitOptions::default()
    };
    let bar = Progress::new("eval", "views", views as u64, progress);
    let doc = interrupt::run(py, &bar, |_| {
        btfpt::fit::eval_file::evaluate_file(&model, &against, &opts, pca_k, &|_| {
            bar.done.fetch_add(1, Ordering::Relaxed);
        })
        .and_then(|e| e.json())
    })?
    .py_err()?;
    json_to_py(py, &doc)
}

/// A JSON value as Python objects (through the json module, so floats round-trip exactly).
pub fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| invalid(format!("cannot serialise: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// Compares a render with a reference, as `btfpt compare TEST REF [--spp N | --test-variance
/// TV] [--variance V]`: returns the document `compare --json` writes (MAE, RMSE, relMSE,
/// luminance ratio, the calibrated verdict with its scales and bias test, `calibration`,
/// `passed`, `failures`) as a dict. A failed
/// comparison is a result (`passed` False), not an exception.
#[pyfunction]
#[pyo3(signature = (test, reference, spp=None, test_variance=None, variance=None, sample_variance=None, alpha=0.01, scales=vec![4, 8, 16, 32], sample_variance_floor=1e-4, block=4, max_failing_pixels=None, max_failing_blocks=None, max_abs_mean_z=None, max_relmse=None))]
pub fn compare<'py>(
    py: Python<'py>,
    test: PathBuf,
    reference: PathBuf,
    spp: Option<u32>,
    test_variance: Option<PathBuf>,
    variance: Option<PathBuf>,
    sample_variance: Option<PathBuf>,
    alpha: f64,
    scales: Vec<usize>,
    sample_variance_floor: f64,
    block: usize,
    max_failing_pixels: Option<usize>,
    max_failing_blocks: Option<usize>,
    max_abs_mean_z: Option<f64>,
    max_relmse: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    use btfpt::metrics::compare_files::{CompareFiles, compare_files};
    if test_variance.is_some() && (spp.is_some() || sample_variance.is_some()) {
        return Err(invalid(
            "test_variance: give either the test's own variance or spp (with the reference's sample variance), not both",
        ));
    }
    if sample_variance.is_some() && spp.is_none() {
        return Err(invalid(
            "sample_variance: needs spp (the test render's samples per pixel)",
        ));
    }
    for (p, what) in [(Some(&test), "test image"), (Some(&reference), "reference")]
        .into_iter()
        .chain([
            (test_variance.as_ref(), "test variance"),
            (variance.as_ref(), "variance"),
            (sample_variance.as_ref(), "sample variance"),
        ])
    {
        if let Some(p) = p
            && !p.exists()
        {
            return Err(missing(format!(
                "cannot read the {what}: {}: file not found",
                p.display()
            )));
        }
    }
    let files = CompareFiles {
        test,
        reference,
        variance,
        sample_variance,
        spp,
        test_variance,
        alpha,
        scales,
        sample_variance_floor,
        block,
        max_failing_pixels,
        max_failing_blocks,
        max_abs_mean_z,
        max_relmse,
    };
    let doc = py
        .detach(|| compare_files(&files).map(|o| o.json(&files)))
        .py_err()?;
    json_to_py(py, &doc)
}
