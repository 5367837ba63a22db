//! numpy arrays in and out: an (N, K) float array argument checked for shape, dtype and finite
//! values (errors name the argument and the first bad row), and result arrays handed to numpy
//! without a copy.

use crate::errors::invalid;
use numpy::ndarray::{Array1, Array2};
use numpy::{PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use rayon::prelude::*;

/// An (N, K) argument's rows: numpy's own buffer when it is C-contiguous float32 (no copy), else
/// a float32 copy (float64 rounded to float32, as the kernels are).
pub enum Rows<'py, const K: usize> {
    Borrowed(numpy::PyReadonlyArrayDyn<'py, f32>),
    Owned(Vec<[f32; K]>),
}

impl<const K: usize> std::ops::Deref for Rows<'_, K> {
    type Target = [[f32; K]];
    fn deref(&self) -> &[[f32; K]] {
        match self {
            Rows::Borrowed(a) => match a.as_slice() {
                // `rows` checked the shape (N, K) and the contiguity.
                Ok(flat) => flat.as_chunks::<K>().0,
                Err(_) => &[],
            },
            Rows::Owned(v) => v,
        }
    }
}

/// An (N, K) argument as rows of f32 (see [`Rows`]).
pub fn rows<'py, const K: usize>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Rows<'py, K>> {
    let py = obj.py();
    let arr = if obj.is_instance_of::<numpy::PyUntypedArray>() {
        obj.clone()
    } else {
        py.import("numpy")?.call_method1("asarray", (obj,))?
    };
    let u = arr
        .cast::<numpy::PyUntypedArray>()
        .map_err(|_| invalid(format!("{name}: expected an array of shape (N, {K})")))?;
    let shape = u.shape().to_vec();
    if shape.len() != 2 || shape[1] != K {
        return Err(invalid(format!(
            "{name}: expected an array of shape (N, {K}), got shape {shape:?}"
        )));
    }
    let out: Vec<[f32; K]> = if let Ok(a) = arr.cast::<PyArrayDyn<f32>>() {
        let a = a.readonly();
        // C-contiguous float32 (the common case): the kernels read numpy's buffer.
        if a.as_slice().is_ok() {
            return Ok(Rows::Borrowed(a));
        }
        let v = a.as_array();
        v.rows()
            .into_iter()
            .map(|r| std::array::from_fn(|k| r[k]))
            .collect()
    } else if let Ok(a) = arr.cast::<PyArrayDyn<f64>>() {
        let a = a.readonly();
        let v = a.as_array();
        v.rows()
            .into_iter()
            .map(|r| std::array::from_fn(|k| r[k] as f32))
            .collect()
    } else {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{name}: expected float32 or float64 values, got dtype {}",
            u.dtype()
        )));
    };
    Ok(Rows::Owned(out))
}

/// An (N,) argument as f32 (float64 rounded to float32).
pub fn values(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f32>> {
    let py = obj.py();
    let arr = py.import("numpy")?.call_method1("asarray", (obj,))?;
    let u = arr
        .cast::<numpy::PyUntypedArray>()
        .map_err(|_| invalid(format!("{name}: expected an array of shape (N,)")))?;
    if u.ndim() != 1 {
        return Err(invalid(format!(
            "{name}: expected an array of shape (N,), got shape {:?}",
            u.shape()
        )));
    }
    let out = rows::<1>(&arr.call_method1("reshape", ((-1, 1),))?, name)?;
    Ok(out.iter().map(|&[x]| x).collect())
}

/// Checks that every row is finite; directions (`unit`) must also have length 1 within 1e-3.
/// Runs on the rayon pool (call it with the GIL released); the error names the first bad row.
pub fn check_rows<const K: usize>(v: &[[f32; K]], name: &str, unit: bool) -> PyResult<()> {
    let length = |r: &[f32; K]| r.iter().map(|x| x * x).sum::<f32>().sqrt();
    let bad =
        |r: &[f32; K]| r.iter().any(|x| !x.is_finite()) || (unit && (length(r) - 1.0).abs() > 1e-3);
    // Whole chunks per rayon task: a per-row parallel search costs more than the test itself.
    const CHUNK: usize = 4096;
    let first = v
        .par_chunks(CHUNK)
        .enumerate()
        .filter_map(|(c, rows)| rows.iter().position(bad).map(|i| c * CHUNK + i))
        .min();
    let Some(i) = first else {
        return Ok(());
    };
    let r = &v[i];
    Err(invalid(if r.iter().any(|x| !x.is_finite()) {
        format!("{name}[{i}] = {r:?} is not finite")
    } else {
        format!(
            "{name}[{i}] = {r:?} is not a unit direction (length {})",
            length(r)
        )
    }))
}

/// Checks that every value lies in [0, 1] (uniform random numbers).
pub fn check_unit_interval<const K: usize>(v: &[[f32; K]], name: &str) -> PyResult<()> {
    for (i, r) in v.iter().enumerate() {
        if r.iter().any(|x| !(0.0..=1.0).contains(x)) {
            return Err(invalid(format!("{name}[{i}] = {r:?} is not in [0, 1]")));
        }
    }
    Ok(())
}

/// Checks that all arguments have the same N.
pub fn same_len(lens: &[(&str, usize)]) -> PyResult<usize> {
    let n = lens[0].1;
    for &(name, l) in &lens[1..] {
        if l != n {
            return Err(invalid(format!(
                "{name} has {l} rows but {} has {n}: every argument needs one row per query",
                lens[0].0
            )));
        }
    }
    Ok(n)
}

/// Rows as an (N, K) float32 numpy array.
pub fn to_numpy<'py, const K: usize>(
    py: Python<'py>,
    v: Vec<[f32; K]>,
) -> Bound<'py, PyArray2<f32>> {
    let n = v.len();
    let flat: Vec<f32> = v.into_iter().flatten().collect();
    let a = Array2::from_shape_vec((n, K), flat).expect("n × K values");
    PyArray2::from_owned_array(py, a)
}

/// Values as an (N,) float32 numpy array (the buffer is handed over, not copied).
pub fn to_numpy1<'py>(py: Python<'py>, v: Vec<f32>) -> Bound<'py, PyArray1<f32>> {
    PyArray1::from_owned_array(py, Array1::from_vec(v))
}
