//! UBO2014 `.btf` reader: header parse, then the full payload decode into a RawBtf.
#![no_main]
mod common;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let p = common::scratch("m.btf", data);
    if let Ok(b) = btfpt::btf::ubo2014::open_btf(&p) {
        let _ = b.load();
    }
});
