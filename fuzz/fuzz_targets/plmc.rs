//! `.plmc` model reader (whole file and per-view part file) on arbitrary bytes, both as given
//! (exercising the CRC checks) and with the section CRCs rewritten (exercising the parsers behind
//! them); a model that reads back is reconstructed for its first view, so inconsistent tables the
//! reader let through show up.
#![no_main]
mod crc_fixup;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fn check(data: &[u8]) {
    let p = Path::new("fuzz.plmc");
    if let Ok(m) = btfpt::model::codec::from_bytes(data, p) {
        let mut out = Vec::new();
        m.reconstruct_view(0, &mut out);
    }
    if data.len() >= 16 {
        let fp = u64::from_le_bytes(data[4..12].try_into().unwrap_or_default());
        let _ = btfpt::fit::parts::part_from_bytes(data, p, fp, 0);
    }
}

fuzz_target!(|data: &[u8]| {
    check(data);
    let mut fixed = data.to_vec();
    crc_fixup::plmc(&mut fixed);
    if fixed != data {
        check(&fixed);
    }
});
