//! EXR input (`io::read_image`) on arbitrary bytes.
#![no_main]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let p = common::scratch("img.exr", data);
    let _ = btfpt::io::read_image(&p);
});
