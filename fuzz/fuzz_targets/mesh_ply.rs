//! PLY mesh loader (ascii and binary) on arbitrary bytes, with and without the uv flip.
#![no_main]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let p = common::scratch("mesh.ply", data);
    let _ = btfpt::scene::ply::load(&p, data.first().is_some_and(|b| b & 1 == 1));
});
