//! `btfpt.Scene` and `btfpt.render`: a scene loaded once and rendered through the library's
//! render driver (`render::driver`), the same passes, samples and bits as `btfpt render`.

use crate::errors::{IntoPy, invalid, missing};
use crate::interrupt::{self, Progress};
use btfpt::model::BtfModel;
use btfpt::render::driver::{self, DriverOptions, Outcome};
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::render::packet::PacketOptions;
use btfpt::render::{IntegratorKind, RenderScene};
use numpy::PyArray3;
use numpy::ndarray::Array3;
use pyo3::prelude::*;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::Ordering;

/// A loaded scene (Mitsuba 3 XML or glTF) with its acceleration structure, reusable across
/// renders.
#[pyclass(module = "btfpt", frozen)]
pub struct Scene {
    rs: Mutex<RenderScene>,
    path: PathBuf,
    size: (u32, u32),
    crop: [u32; 4],
    spp: u32,
    btf_uses: Vec<(String, String, (usize, usize), f64)>,
    summary: String,
}

impl Scene {
    fn load_impl(
        path: PathBuf,
        defines: BTreeMap<String, String>,
        btf_model: Option<String>,
    ) -> PyResult<Scene> {
        if !path.is_file() {
            return Err(missing(format!("{}: scene file not found", path.display())));
        }
        let load_options = btfpt::scene::LoadOptions {
            defines: defines.into_iter().collect(),
            btf_model: btf_model
                .as_deref()
                .map(BtfModel::parse)
                .transpose()
                .py_err()?,
            synth_cache: btfpt::btf::synth::disk_cache::default_cache_dir(),
        };
        let scene = btfpt::scene::load(&path, &load_options).py_err()?;
        if scene.meshes.is_empty() && scene.emitters.is_empty() {
            return Err(invalid(format!(
                "{}: the scene is empty (no shapes and no emitters), the image would be black",
                path.display()
            )));
        }
        let cam = &scene.camera;
        let size = (cam.width, cam.height);
        let crop = cam.crop.unwrap_or([0, 0, cam.width, cam.height]);
        let spp = scene.spp;
        let btf_uses = scene
            .btf_uses
            .iter()
            .map(|b| {
                (
                    b.file.display().to_string(),
                    b.model.name().to_string(),
                    b.texels,
                    b.seconds,
                )
            })
            .collect();
        let rs = RenderScene::new(scene).py_err()?;
        let summary = rs.summary();
        Ok(Scene {
            rs: Mutex::new(rs),
            path,
            size,
            crop,
            spp,
            btf_uses,
            summary,
        })
    }
}

#[pymethods]
impl Scene {
    /// Loads a scene; `defines` overrides its `<default>` parameters (as `-D name=value`),
    /// `btf_model` renders every BTF with another model of the same material ("raw", "lm",
    /// "plm", "plmc"; as `--btf-model`).
    #[staticmethod]
    #[pyo3(signature = (path, defines=None, btf_model=None))]
    fn load(
        py: Python<'_>,
        path: PathBuf,
        defines: Option<BTreeMap<String, String>>,
        btf_model: Option<String>,
    ) -> PyResult<Scene> {
        let defines = defines.unwrap_or_default();
        py.detach(|| Scene::load_impl(path, defines, btf_model))
    }

    /// Film size in pixels (width, height).
    #[getter]
    fn size(&self) -> (u32, u32) {
        self.size
    }

    /// The samples per pixel the scene asks for.
    #[getter]
    fn spp(&self) -> u32 {
        self.spp
    }

    /// The measured materials: a list of dicts {file, model, texels, seconds}.
    #[getter]
    fn btf_uses<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, pyo3::types::PyDict>>> {
        self.btf_uses
            .iter()
            .map(|(f, m, t, s)| {
                let d = pyo3::types::PyDict::new(py);
                d.set_item("file", f)?;
                d.set_item("model", m)?;
                d.set_item("texels", *t)?;
                d.set_item("seconds", *s)?;
                Ok(d)
            })
            .collect()
    }

    /// The scene file.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    fn __repr__(&self) -> String {
        format!("Scene('{}')\n{}", self.path.display(), self.summary)
    }
}

/// Renders `scene` (a path or a [`Scene`]) and returns the (H, W, 3) float32 linear RGB image
/// of the scene's window, the same bits as `btfpt render` with the same arguments; with
/// `variance=True` also the per-pixel variance of the mean (as `--variance`).
#[pyfunction]
#[pyo3(signature = (scene, spp=None, seed=0, defines=None, threads=None, integrator="packet", variance=false, progress=true))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    spp: Option<u32>,
    seed: u64,
    defines: Option<BTreeMap<String, String>>,
    threads: Option<usize>,
    integrator: &str,
    variance: bool,
    progress: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let loaded;
    let scene: &Scene = if let Ok(s) = scene.cast::<Scene>() {
        if defines.is_some() {
            return Err(invalid(
                "defines: give them to Scene.load, not to render() of a loaded Scene",
            ));
        }
        loaded = s.clone();
        loaded.get()
    } else {
        let path: PathBuf = scene
            .extract()
            .map_err(|_| invalid("scene: expected a path or a btfpt.Scene"))?;
        let s = Py::new(py, Scene::load(py, path, defines, None)?)?;
        loaded = s.into_bound(py);
        loaded.get()
    };
    let kind = match integrator {
        "scalar" => IntegratorKind::Scalar,
        "packet" => IntegratorKind::Packet(PacketOptions {
            pool: 256,
            refill: true,
        }),
        other => {
            return Err(invalid(format!(
                "integrator \"{other}\": expected \"packet\" or \"scalar\""
            )));
        }
    };
    if spp == Some(0) {
        return Err(invalid("spp: the sample count must be at least 1"));
    }
    if let Some(t) = threads
        && (t == 0 || t > 4096)
    {
        return Err(invalid(format!("threads {t}: must be in 1..=4096")));
    }
    let settings = RenderSettings {
        width: scene.size.0,
        height: scene.size.1,
        crop: scene.crop,
        spp_begin: 0,
        spp_end: spp.unwrap_or(scene.spp),
        seed,
    };
    settings.validate().py_err()?;
    if variance && settings.spp() < 2 {
        return Err(invalid("variance: needs at least 2 samples per pixel"));
    }
    let mut rs = scene
        .rs
        .lock()
        .map_err(|_| invalid("the scene is unusable after a failed render"))?;
    rs.kind = kind;
    let mut state = RenderState::with_filter(settings, rs.scene.camera.filter).py_err()?;
    if !variance {
        state = state.without_moments();
    }
    let bar = Progress::new("render", "pixel-samples", state.samples_total(), progress);
    let opts = DriverOptions {
        threads,
        checkpoint: None,
    };
    let rs_ref = &*rs;
    let (outcome, state) = interrupt::run(py, &bar, |stop| {
        let r = driver::render(rs_ref, &mut state, &opts, stop, &|n, _| {
            bar.done.fetch_add(n, Ordering::Relaxed);
        });
        (r, state)
    })?;
    match outcome.py_err()? {
        Outcome::Complete => {}
        Outcome::Interrupted => {
            return Err(pyo3::exceptions::PyKeyboardInterrupt::new_err(
                "render interrupted",
            ));
        }
    }
    let image = to_image(py, state.mean_image());
    if variance {
        let var = to_image(py, state.variance_image().py_err()?);
        Ok((image, var).into_pyobject(py)?.into_any())
    } else {
        Ok(image.into_any())
    }
}

/// An image as an (H, W, 3) float32 array.
pub fn to_image(py: Python<'_>, img: btfpt::io::RgbImage) -> Bound<'_, PyArray3<f32>> {
    let a = Array3::from_shape_vec((img.height, img.width, 3), img.data).expect("h × w × 3 values");
    PyArray3::from_owned_array(py, a)
}

/// Reads an image (EXR, PNG/JPEG decoded to linear, HDR, PFM) as (H, W, 3) float32.
#[pyfunction]
pub fn read_image(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray3<f32>>> {
    let img = py.detach(|| btfpt::io::read_image(&path)).py_err()?;
    Ok(to_image(py, img))
}
