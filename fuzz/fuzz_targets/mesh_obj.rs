//! OBJ mesh loader on arbitrary bytes.
#![no_main]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let p = common::scratch("mesh.obj", data);
    let _ = btfpt::scene::obj::load(&p, true);
});
