//! `btfpt.Btf`: a measured material (raw data or a fitted model) evaluated, sampled and looked at
//! on numpy arrays.

use crate::arrays::{
    Rows, check_rows, check_unit_interval, rows, same_len, to_numpy, to_numpy1, values,
};
use crate::errors::{IntoPy, invalid, missing};
use crate::query::{self, Model};
use btfpt::bsdf::plmc::PlmcMaterial;
use btfpt::bsdf::{BtfBsdf, BtfMaterial, PlmcBsdf};
use btfpt::btf::BtfSource;
use btfpt::btf::synth::disk_cache;
use btfpt::model::{BtfFile, BtfModel, PlmcModel, codec, resolve_model_file};
use btfpt::scene::measured_material::SynthSpec;
use numpy::ndarray::Array3;
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;

/// A measured material: raw BTF data (UBO2003 folder, UBO2014 `.btf`, `.btfc` cache or a
/// `synth:` source) or a fitted LM / PLM / PLM-C model (`.plmc`), evaluated exactly as the
/// renderer evaluates it (docs/conventions.md: local shading frame, ω_i towards the camera, ω_l
/// towards the light, B = π · f · cos θ_l).
#[pyclass(module = "btfpt", frozen)]
pub struct Btf {
    model: Model,
    /// The fitted model's parameters (texel images); None for raw data.
    fitted: Option<Arc<PlmcModel>>,
    path: PathBuf,
    kind: BtfModel,
    views: Vec<[f32; 3]>,
    lights: Vec<[f32; 3]>,
    width: usize,
    height: usize,
    uv_scale: f32,
}

fn dirs(set: &btfpt::btf::DirectionSet) -> Vec<[f32; 3]> {
    set.dirs.iter().map(|d| d.to_array()).collect()
}

impl Btf {
    fn load(path: &str, model: Option<&str>, uv_scale: f32) -> PyResult<Btf> {
        let model = model.map(BtfModel::parse).transpose().py_err()?;
        if let Some(spec) = SynthSpec::parse(path) {
            if let Some(m @ BtfModel::Fitted(_)) = model {
                return Err(invalid(format!(
                    "\"{path}\" is a synthetic raw BTF; model \"{m}\" needs a fitted .plmc file"
                )));
            }
            // As a scene's `synth:` source: read from the user's cache folder, generated and
            // cached when missing, in memory only when no folder is known.
            let dir = disk_cache::default_cache_dir();
            let (raw, _) = spec
                .and_then(|s| disk_cache::load_or_generate(&s, dir.as_deref()))
                .py_err()?;
            let material = BtfMaterial::new(Arc::new(raw)).py_err()?;
            return Btf::raw(material, PathBuf::from(path), uv_scale);
        }
        let p = PathBuf::from(path);
        if !p.exists() {
            return Err(missing(format!("{path}: no such file or folder")));
        }
        match resolve_model_file(&p, model).py_err()? {
            BtfFile::Raw(source) => {
                Btf::raw(BtfMaterial::load(&source).py_err()?, source, uv_scale)
            }
            BtfFile::Model(source) => {
                let fitted = codec::read(&source).py_err()?;
                let material = PlmcMaterial::new(&fitted)
                    .map_err(|e| btfpt::Error::format(&source, e.to_string()))
                    .py_err()?;
                let bsdf = PlmcBsdf::new(Arc::new(material), uv_scale, false).py_err()?;
                Ok(Btf {
                    model: Model::Fitted(bsdf),
                    path: source,
                    kind: BtfModel::Fitted(fitted.kind),
                    views: dirs(&fitted.views),
                    lights: dirs(&fitted.lights),
                    width: fitted.width,
                    height: fitted.height,
                    uv_scale,
                    fitted: Some(Arc::new(fitted)),
                })
            }
        }
    }

    fn raw(material: BtfMaterial, path: PathBuf, uv_scale: f32) -> PyResult<Btf> {
        let b = material.btf();
        let (views, lights, width, height) =
            (dirs(b.views()), dirs(b.lights()), b.width(), b.height());
        Ok(Btf {
            model: Model::Raw(BtfBsdf::new(Arc::new(material), uv_scale).py_err()?),
            fitted: None,
            path,
            kind: BtfModel::Raw,
            views,
            lights,
            width,
            height,
            uv_scale,
        })
    }

    /// The three query arrays (numpy's buffers where they are C-contiguous float32).
    #[allow(clippy::type_complexity)]
    fn queries<'py>(
        uv: &Bound<'py, PyAny>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
    ) -> PyResult<(Rows<'py, 2>, Rows<'py, 3>, Rows<'py, 3>)> {
        let (uv, wi, wo) = (
            rows::<2>(uv, "uv")?,
            rows::<3>(wi, "wi")?,
            rows::<3>(wo, "wo")?,
        );
        same_len(&[("uv", uv.len()), ("wi", wi.len()), ("wo", wo.len())])?;
        Ok((uv, wi, wo))
    }

    /// B (N, 3) and, with `want_pdf`, the pdf (N,) written straight into new numpy arrays; the
    /// checks and the kernel run on rayon with the GIL released.
    #[allow(clippy::type_complexity)]
    fn eval_pdf_arrays<'py>(
        &self,
        py: Python<'py>,
        uv: &Bound<'py, PyAny>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
        want_pdf: bool,
    ) -> PyResult<(Bound<'py, PyArray2<f32>>, Option<Bound<'py, PyArray1<f32>>>)> {
        let (uv, wi, wo) = Btf::queries(uv, wi, wo)?;
        let n = uv.len();
        let b_arr = PyArray2::<f32>::zeros(py, [n, 3], false);
        let pdf_arr = want_pdf.then(|| PyArray1::<f32>::zeros(py, n, false));
        {
            let mut b_rw = b_arr.readwrite();
            let mut pdf_rw = pdf_arr.as_ref().map(|a| a.readwrite());
            let b = b_rw.as_slice_mut().map_err(|e| invalid(e.to_string()))?;
            let b = b.as_chunks_mut::<3>().0;
            let pdf = match pdf_rw.as_mut() {
                Some(p) => Some(p.as_slice_mut().map_err(|e| invalid(e.to_string()))?),
                None => None,
            };
            let (uv, wi, wo) = (&*uv, &*wi, &*wo);
            py.detach(|| -> PyResult<()> {
                check_rows(uv, "uv", false)?;
                check_rows(wi, "wi", true)?;
                check_rows(wo, "wo", true)?;
                query::eval_b_pdf(&self.model, uv, wi, wo, b, pdf);
                Ok(())
            })?;
        }
        Ok((b_arr, pdf_arr))
    }
}

#[pymethods]
impl Btf {
    /// Opens raw data or a fitted model. `model` ("raw", "lm", "plm", "plmc") picks another
    /// representation of the same material found next to `path` (S, S.btfc, S.plmc,
    /// S.lm.plmc, …; as `<bsdf type="btf" model=…>`); None uses what the file holds.
    /// `uv_scale`: texture repeats per unit uv.
    #[staticmethod]
    #[pyo3(signature = (path, model=None, uv_scale=1.0))]
    fn open(py: Python<'_>, path: PathBuf, model: Option<String>, uv_scale: f32) -> PyResult<Btf> {
        let path = path.to_string_lossy().into_owned();
        py.detach(|| Btf::load(&path, model.as_deref(), uv_scale))
    }

    /// B = π · f · cos θ_l (linear RGB, cosine-baked) of N queries: `uv` (N, 2), `wi` (N, 3)
    /// view and `wo` (N, 3) light directions, unit, in the local shading frame. Returns (N, 3)
    /// float32; 0 where either direction is below the horizon.
    fn eval<'py>(
        &self,
        py: Python<'py>,
        uv: &Bound<'py, PyAny>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        Ok(self.eval_pdf_arrays(py, uv, wi, wo, false)?.0)
    }

    /// The solid-angle pdf with which [`Btf.sample`] draws `wo` (N,) float32.
    fn pdf<'py>(
        &self,
        py: Python<'py>,
        uv: &Bound<'py, PyAny>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        match self.eval_pdf_arrays(py, uv, wi, wo, true)? {
            (_, Some(pdf)) => Ok(pdf),
            (_, None) => unreachable!("a pdf was asked for"),
        }
    }

    /// `(B, pdf)` in one pass (the light location shared): (N, 3) and (N,) float32.
    #[allow(clippy::type_complexity)]
    fn eval_pdf<'py>(
        &self,
        py: Python<'py>,
        uv: &Bound<'py, PyAny>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>)> {
        match self.eval_pdf_arrays(py, uv, wi, wo, true)? {
            (b, Some(pdf)) => Ok((b, pdf)),
            (_, None) => unreachable!("a pdf was asked for"),
        }
    }

    /// Draws one light direction per query from the material's tabulated light sampler with
    /// uniform numbers `sample1` (N,) and `sample2` (N, 2) in [0, 1]. Returns `(wo, weight,
    /// pdf)`: (N, 3) directions, (N, 3) weights f · cos θ_l / pdf = B / (π · pdf), (N,) pdfs;
    /// all 0 where no direction could be drawn (ω_i below the horizon).
    #[allow(clippy::type_complexity)]
    fn sample<'py>(
        &self,
        py: Python<'py>,
        uv: &Bound<'py, PyAny>,
        wi: &Bound<'py, PyAny>,
        sample1: &Bound<'py, PyAny>,
        sample2: &Bound<'py, PyAny>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray1<f32>>,
    )> {
        let (uv, wi) = (rows::<2>(uv, "uv")?, rows::<3>(wi, "wi")?);
        let (u1, u2) = (values(sample1, "sample1")?, rows::<2>(sample2, "sample2")?);
        let n = same_len(&[
            ("uv", uv.len()),
            ("wi", wi.len()),
            ("sample1", u1.len()),
            ("sample2", u2.len()),
        ])?;
        check_rows(&uv, "uv", false)?;
        check_rows(&wi, "wi", true)?;
        let u1r: Vec<[f32; 1]> = u1.iter().map(|&x| [x]).collect();
        check_unit_interval(&u1r, "sample1")?;
        check_unit_interval(&u2, "sample2")?;
        let (uv, wi, u2) = (&*uv, &*wi, &*u2);
        let (wo, weight, pdf) = py.detach(|| {
            let (mut wo, mut weight, mut pdf) =
                (vec![[0f32; 3]; n], vec![[0f32; 3]; n], vec![0f32; n]);
            query::sample(&self.model, uv, wi, &u1, u2, &mut wo, &mut weight, &mut pdf);
            (wo, weight, pdf)
        });
        Ok((to_numpy(py, wo), to_numpy(py, weight), to_numpy1(py, pdf)))
    }

    /// The scalar renderer's calls for each query one by one (test oracle of the batched path):
    /// `(B, f·cos, pdf, sample_wo, sample_weight, sample_pdf)`.
    #[allow(clippy::type_complexity)]
    fn _reference<'py>(
        &self,
        py: Python<'py>,
        uv: &Bound<'py, PyAny>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
        sample1: &Bound<'py, PyAny>,
        sample2: &Bound<'py, PyAny>,
    ) -> PyResult<Vec<Bound<'py, PyAny>>> {
        let (uv, wi, wo) = Btf::queries(uv, wi, wo)?;
        check_rows(&uv, "uv", false)?;
        check_rows(&wi, "wi", true)?;
        check_rows(&wo, "wo", true)?;
        let (u1, u2) = (values(sample1, "sample1")?, rows::<2>(sample2, "sample2")?);
        same_len(&[
            ("uv", uv.len()),
            ("sample1", u1.len()),
            ("sample2", u2.len()),
        ])?;
        let r: Vec<_> = (0..uv.len())
            .map(|q| query::reference(&self.model, uv[q], wi[q], wo[q], u1[q], u2[q]))
            .collect();
        Ok(vec![
            to_numpy(py, r.iter().map(|x| x.0).collect()).into_any(),
            to_numpy(py, r.iter().map(|x| x.1).collect()).into_any(),
            to_numpy1(py, r.iter().map(|x| x.2).collect()).into_any(),
            to_numpy(py, r.iter().map(|x| x.3.0).collect()).into_any(),
            to_numpy(py, r.iter().map(|x| x.3.1).collect()).into_any(),
            to_numpy1(py, r.iter().map(|x| x.3.2).collect()).into_any(),
        ])
    }

    /// The measured view directions (unit, local frame), (V, 3) float32.
    #[getter]
    fn views<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        to_numpy(py, self.views.clone())
    }

    /// The measured light directions (unit, local frame), (L, 3) float32.
    #[getter]
    fn lights<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        to_numpy(py, self.lights.clone())
    }

    /// Texels (width, height).
    #[getter]
    fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// "raw", "lm", "plm" or "plmc".
    #[getter]
    fn kind(&self) -> &'static str {
        self.kind.name()
    }

    /// The file read (for `model=` the model file found next to the path given).
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// Texture repeats per unit uv.
    #[getter]
    fn uv_scale(&self) -> f32 {
        self.uv_scale
    }

    /// The material's image at measured view `view` and light `light` (indices into `views`
    /// and `lights`): (height, width, 3) float32 linear B, row 0 the first row of the image
    /// file. For a fitted model, its reconstruction at those directions.
    fn texel_image<'py>(
        &self,
        py: Python<'py>,
        view: usize,
        light: usize,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        if view >= self.views.len() {
            return Err(invalid(format!(
                "view {view}: the material has {} views (0..{})",
                self.views.len(),
                self.views.len()
            )));
        }
        if light >= self.lights.len() {
            return Err(invalid(format!(
                "light {light}: the material has {} lights (0..{})",
                self.lights.len(),
                self.lights.len()
            )));
        }
        let (w, h) = (self.width, self.height);
        let img = py.detach(|| match (&self.fitted, &self.model) {
            (Some(m), _) => {
                let mut out = Vec::new();
                m.reconstruct_view(view, &mut out);
                out[light * w * h * 3..(light + 1) * w * h * 3].to_vec()
            }
            (None, Model::Raw(b)) => {
                let btf = b.material().btf();
                let mut out = Vec::with_capacity(w * h * 3);
                for y in 0..h {
                    for x in 0..w {
                        out.extend_from_slice(&btf.texel(view, light, x, y));
                    }
                }
                out
            }
            (None, Model::Fitted(_)) => unreachable!("a fitted model keeps its parameters"),
        });
        let a = Array3::from_shape_vec((h, w, 3), img).expect("h × w × 3 values");
        Ok(PyArray3::from_owned_array(py, a))
    }

    fn __repr__(&self) -> String {
        format!(
            "Btf('{}', kind='{}', size={}x{}, views={}, lights={}, uv_scale={})",
            self.path.display(),
            self.kind.name(),
            self.width,
            self.height,
            self.views.len(),
            self.lights.len(),
            self.uv_scale
        )
    }
}
