//! Order-preserving maps between f32 and u32 (radix sorts and packed sort keys).

/// Order-preserving map of f32 bits to u32 (the IEEE total order, as `f32::total_cmp`).
#[inline]
pub fn key(v: f32) -> u32 {
    let b = v.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// The inverse of [`key`].
#[inline]
pub fn unkey(k: u32) -> f32 {
    f32::from_bits(if k & 0x8000_0000 != 0 {
        k & 0x7fff_ffff
    } else {
        !k
    })
}
