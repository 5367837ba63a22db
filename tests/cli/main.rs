//! The `btfpt` binary's commands end to end (fit, eval, info, convert, synth, tiling, check,
//! compare, render, merge): success paths, the files they write, and clear errors.

#[path = "../common/mod.rs"]
mod common;

mod check;
mod compare;
mod fit;
mod fit_split_by_views;
mod fit_ubo2014_directions;
mod info_and_convert;
mod outputs;
mod pipes_outputs_and_figures;
mod render_and_merge;
mod synth;
mod tiling;
