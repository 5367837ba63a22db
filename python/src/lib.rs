//! The `btfpt` Python module (`btfpt._btfpt`, wrapped by `python/btfpt/__init__.py`): measured
//! BTFs and fitted models evaluated on numpy arrays through the renderer's batched kernels,
//! rendering, fitting, evaluation and comparison with the figures the CLI prints.

// The query kernels index several fixed-size lane arrays with one loop counter, and the
// Python-facing functions take the CLI's options as keyword arguments.
#![allow(clippy::needless_range_loop, clippy::too_many_arguments)]

mod arrays;
mod btf;
mod errors;
mod interrupt;
mod query;
mod render;
mod tools;

use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _btfpt(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<btf::Btf>()?;
    m.add_class::<render::Scene>()?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(tools::synth, m)?)?;
    m.add_function(wrap_pyfunction!(tools::fit, m)?)?;
    m.add_function(wrap_pyfunction!(tools::eval_model, m)?)?;
    m.add_function(wrap_pyfunction!(tools::compare, m)?)?;
    Ok(())
}
