//! Mutated inputs almost never carry valid CRC32s, so without help the fuzzer only ever exercises
//! the CRC rejection of `.plmc` and `.btfc`. These functions rewrite the checksums of a mutated
//! input in place (as far as its own length fields allow), so the parsers behind the checks are
//! fuzzed too. Arithmetic is checked: the harness itself must never panic.

fn crc(parts: &[&[u8]]) -> [u8; 4] {
    let mut h = crc32fast::Hasher::new();
    for p in parts {
        h.update(p);
    }
    h.finalize().to_le_bytes()
}

fn u32_at(d: &[u8], at: usize) -> Option<usize> {
    Some(u32::from_le_bytes(d.get(at..at + 4)?.try_into().ok()?) as usize)
}

fn u64_at(d: &[u8], at: usize) -> Option<usize> {
    usize::try_from(u64::from_le_bytes(d.get(at..at + 8)?.try_into().ok()?)).ok()
}

/// `.plmc`: "PLMC" u32 version, then sections `tag[4] u64 len payload u32 crc32(tag ‖ payload)`.
pub fn plmc(d: &mut [u8]) {
    let mut pos = 8;
    while let Some(len) = u64_at(d, pos + 4) {
        let start = pos + 12;
        let Some(end) = start.checked_add(len) else { return };
        if end.checked_add(4).is_none_or(|e| e > d.len()) {
            return;
        }
        let c = crc(&[&d[pos..pos + 4], &d[start..end]]);
        d[end..end + 4].copy_from_slice(&c);
        pos = end + 4;
    }
}

/// `.btfc`: header CRC after the direction table, then per-view payload CRCs and a table CRC.
pub fn btfc(d: &mut [u8]) {
    let (Some(w), Some(h), Some(nv), Some(nl), Some(off)) = (
        u32_at(d, 12),
        u32_at(d, 16),
        u32_at(d, 20),
        u32_at(d, 24),
        u64_at(d, 32),
    ) else {
        return;
    };
    let Some(hl) = nv.checked_add(nl).and_then(|n| n.checked_mul(8)).and_then(|n| n.checked_add(40))
    else {
        return;
    };
    if hl.checked_add(4).is_none_or(|e| e > d.len()) {
        return;
    }
    let c = crc(&[&d[..hl]]);
    d[hl..hl + 4].copy_from_slice(&c);
    let Some(view_bytes) = [nl, h, w, 6].iter().try_fold(1usize, |a, &b| a.checked_mul(b)) else {
        return;
    };
    let Some(trailer) = view_bytes.checked_mul(nv).and_then(|n| n.checked_add(off)) else {
        return;
    };
    let Some(end) = nv.checked_mul(4).and_then(|n| n.checked_add(trailer)) else { return };
    if end.checked_add(4).is_none_or(|e| e > d.len()) {
        return;
    }
    for v in 0..nv {
        let s = off + v * view_bytes;
        let c = crc(&[&d[s..s + view_bytes]]);
        d[trailer + 4 * v..trailer + 4 * v + 4].copy_from_slice(&c);
    }
    let c = crc(&[&d[trailer..end]]);
    d[end..end + 4].copy_from_slice(&c);
}
