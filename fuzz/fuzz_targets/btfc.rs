//! `.btfc` cache reader: header parse and the full memory-mapped load with CRC checks, on the
//! input as given and with its CRCs rewritten (so the checks do not hide the parser behind them).
#![no_main]
mod common;
mod crc_fixup;
use btfpt::btf::BtfSource;
use libfuzzer_sys::fuzz_target;

fn check(data: &[u8]) {
    let p = common::scratch("m.btfc", data);
    if let Ok(b) = btfpt::btf::cache::load_cache(&p) {
        // Touch the first and last value so a header/length mismatch would fault.
        let (w, h) = (b.width(), b.height());
        let (nv, nl) = (b.views().len(), b.lights().len());
        if w > 0 && h > 0 && nv > 0 && nl > 0 {
            let _ = b.texel(0, 0, 0, 0);
            let _ = b.texel(nv - 1, nl - 1, w - 1, h - 1);
        }
    }
}

fuzz_target!(|data: &[u8]| {
    check(data);
    let mut fixed = data.to_vec();
    crc_fixup::btfc(&mut fixed);
    if fixed != data {
        check(&fixed);
    }
});
