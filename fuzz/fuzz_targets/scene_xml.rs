//! Mitsuba XML scene loader (`scene::load`) on arbitrary bytes.
#![no_main]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let p = common::scratch("scene.xml", data);
    let _ = btfpt::scene::load(&p, &btfpt::scene::LoadOptions::default());
});
