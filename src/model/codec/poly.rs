//! The POLY section: PLM's per-(view, light, channel) mappings, packed as quantised Bernstein
//! coefficients where exact, f32 otherwise.

use super::{KIND, deflate};
use crate::Result;
use crate::io::bytes::{Reader, Writer};
use crate::model::polynomial::{self, PackedPoly, Poly};
use std::io::Read;
use std::path::Path;

/// Marker of a POLY record holding f32 coefficients (version 2).
const RAW_POLY: i8 = i8::MIN;

/// Bytes of the version-2 POLY payload of these polynomials (as [`poly_payload`] makes it).
pub fn poly_bytes(polys: &[Poly]) -> Result<usize> {
    Ok(poly_payload(polys)?.len())
}

/// The version-2 POLY payload: u8 coding (0 plain, 1 zlib) and the streams
/// headers ‖ q planes ‖ raw coefficients, deflated for coding 1. Headers: per polynomial i8 e and
/// i8 s (packed) or i8 −128 (raw); q planes: the low bytes of q_0 of every packed polynomial, then
/// of q_1 … q_4, then the high bytes likewise (similar bytes side by side deflate ~18 % better
/// than whole records); raw: 5 f32 per raw polynomial.
pub fn poly_payload(polys: &[Poly]) -> Result<Vec<u8>> {
    let mut head = Writer::new();
    let mut packed = Vec::with_capacity(polys.len());
    let mut raw = Writer::new();
    for a in polys {
        match polynomial::encode(a) {
            Some(q) => {
                head.i8(q.e).i8(q.s);
                packed.push(q.q);
            }
            None => {
                head.i8(RAW_POLY);
                a.iter().for_each(|&x| {
                    raw.f32(x);
                });
            }
        }
    }
    let mut plain = head.into_bytes();
    for byte in 0..2 {
        for k in 0..5 {
            plain.extend(packed.iter().map(|q| q[k].to_le_bytes()[byte]));
        }
    }
    plain.extend_from_slice(raw.as_bytes());
    let deflated = deflate(&plain, "polynomials")?;
    let (coding, data) = if deflated.len() < plain.len() {
        (1u8, deflated)
    } else {
        (0u8, plain)
    };
    let mut out = Writer::new();
    out.u8(coding).bytes(&data);
    Ok(out.into_bytes())
}

/// Five f32 coefficients, all finite.
fn read_raw_poly(r: &mut Reader) -> Result<Poly> {
    let mut a = [0f32; 5];
    for x in a.iter_mut() {
        *x = r.f32("polynomial coefficient")?;
        if !x.is_finite() {
            return Err(r.err("non-finite polynomial coefficient"));
        }
    }
    Ok(a)
}

/// Parses a POLY payload of `n` polynomials in format `version`.
pub(super) fn read(payload: &[u8], path: &Path, version: u32, n: usize) -> Result<Vec<Poly>> {
    let mut s = Reader::new(payload, path, KIND);
    s.set_part("POLY");
    if version == 1 {
        if payload.len() != n * 20 {
            return Err(s.err(format!(
                "POLY has {} bytes, expected {}",
                payload.len(),
                n * 20
            )));
        }
        let polys = (0..n)
            .map(|_| read_raw_poly(&mut s))
            .collect::<Result<Vec<_>>>()?;
        s.finish()?;
        return Ok(polys);
    }
    let coding = s.u8("polynomial coding")?;
    let rest = s.take(s.remaining(), "polynomial streams")?;
    let plain = match coding {
        0 => rest.to_vec(),
        1 => {
            // At most 21 bytes per polynomial (header + 5 raw f32); never inflate beyond that.
            let mut out = Vec::with_capacity(n * 12);
            flate2::read::ZlibDecoder::new(rest)
                .take(21 * n as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| s.err(format!("polynomials do not inflate: {e}")))?;
            out
        }
        _ => return Err(s.err(format!("unknown polynomial coding {coding}"))),
    };
    let mut s = Reader::new(&plain, path, KIND);
    s.set_part("POLY streams");
    let mut heads = Vec::with_capacity(n);
    for _ in 0..n {
        let e = s.i8("polynomial domain")?;
        heads.push(if e == RAW_POLY {
            None
        } else {
            Some((e, s.i8("polynomial step")?))
        });
    }
    let m = heads.iter().filter(|h| h.is_some()).count();
    let planes = s.take(10 * m, "packed coefficients")?;
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for h in heads {
        out.push(match h {
            Some((e, sx)) => {
                let q = std::array::from_fn(|k| {
                    i16::from_le_bytes([planes[k * m + j], planes[(5 + k) * m + j]])
                });
                j += 1;
                polynomial::decode(&PackedPoly { e, s: sx, q })
                    .ok_or_else(|| s.err("packed polynomial overflows f32"))?
            }
            None => read_raw_poly(&mut s)?,
        });
    }
    s.finish()?;
    Ok(out)
}
