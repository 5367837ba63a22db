//! The fitted BTF models as data: LM (per-texel one-lobe Lafortune), PLM (LM plus a polynomial
//! per image) and PLM-C (PLM with clustered lobes), their evaluation building blocks and the
//! `.plmc` file codec.
//!
//! This layer sits between the raw measured data (`btf`) and its two users: `fit` writes models,
//! `bsdf` reads them, and neither knows the other (docs/architecture.md).

pub mod codec;
pub mod files;
pub mod kind;
pub mod lobe;
pub mod plmc;
pub mod polynomial;
pub mod value_space;

pub use files::{BtfFile, BtfModel, resolve_model_file};
pub use kind::ModelKind;
pub use lobe::{Lobe, PackedLobe};
pub use plmc::{PlmcModel, ViewParams};
pub use polynomial::Poly;
pub use value_space::ValueSpace;
