//! Rendering and fitting as a farm runs them: jobs interrupted or killed and resumed, and parts
//! rendered apart merged into the one-machine image.

#[path = "../common/mod.rs"]
mod common;

mod interrupt_and_resume;
mod merge_parts;
