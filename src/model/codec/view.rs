//! The VIEW section: one view's lobes (per texel for LM/PLM; a cluster table and an index image
//! for PLM-C).

use super::head::Header;
use super::{KIND, VERSION, deflate, index_bytes, inflate_exact};
use crate::Result;
use crate::io::bytes::{Reader, Writer};
use crate::model::{ModelKind, PackedLobe, ViewParams};
use std::path::Path;

/// The payload of one VIEW section in the current format version.
pub fn view_payload(view: usize, params: &ViewParams, clusters: usize) -> Result<Vec<u8>> {
    payload_version(view, params, clusters, VERSION)
}

fn push_lobe(w: &mut Writer, l: &PackedLobe) {
    w.u16(l.rho).u16(l.oct[0]).u16(l.oct[1]).u16(l.n);
}

/// Reads one stored lobe, checking that ρ and n are finite and non-negative.
fn read_lobe(r: &mut Reader) -> Result<PackedLobe> {
    let l = PackedLobe {
        rho: r.u16("lobe ρ")?,
        oct: [r.u16("lobe direction")?, r.u16("lobe direction")?],
        n: r.u16("lobe exponent")?,
    };
    if !l.is_valid() {
        return Err(r.err("lobe parameter is not a finite non-negative number"));
    }
    Ok(l)
}

/// The VIEW payload in format `version` (1 or 2).
pub(super) fn payload_version(
    view: usize,
    params: &ViewParams,
    clusters: usize,
    version: u32,
) -> Result<Vec<u8>> {
    let mut p = Writer::new();
    p.len32(view, "view index")?;
    match params {
        ViewParams::Texel(lobes) => {
            p.u32(0);
            for l in lobes {
                push_lobe(&mut p, l);
            }
        }
        ViewParams::Clustered { k, table, index } => {
            p.len32(*k, "cluster count")?;
            let mut w = Writer::new();
            for l in table {
                push_lobe(&mut w, l);
            }
            let lobes = w.into_bytes();
            if version == 1 {
                p.bytes(&lobes);
            } else {
                // Version 2: u8 coding (0 raw, 1 deflated byte planes), u32 n, data[n]. The
                // planes (byte b of every lobe, b = 0..8) deflate ~13 % smaller than the lobes.
                let planes: Vec<u8> = (0..8)
                    .flat_map(|b| lobes.iter().skip(b).step_by(8).copied())
                    .collect();
                let deflated = deflate(&planes, "cluster table")?;
                let (coding, data) = if deflated.len() < lobes.len() {
                    (1u8, deflated)
                } else {
                    (0u8, lobes)
                };
                p.u8(coding)
                    .len32(data.len(), "cluster table size")?
                    .bytes(&data);
            }
            let wide = index_bytes(clusters) == 2;
            let texels = index.len() / 3;
            // Planes [channel][texel], raw and channel-delta filtered.
            let mut raw = Writer::new();
            let mut filtered = Writer::new();
            for c in 0..3 {
                for t in 0..texels {
                    let v = index[3 * t + c];
                    let d = if c == 0 {
                        v
                    } else {
                        v.wrapping_sub(index[3 * t + c - 1])
                    };
                    if wide {
                        raw.u16(v);
                        filtered.u16(d);
                    } else {
                        raw.u8(v as u8);
                        filtered.u8(d as u8);
                    }
                }
            }
            let deflated = deflate(filtered.as_bytes(), "index image")?;
            let (coding, data) = if deflated.len() < raw.len() {
                (1u8, deflated)
            } else {
                (0u8, raw.into_bytes())
            };
            p.u8(coding)
                .len32(data.len(), "index image size")?
                .bytes(&data);
        }
    }
    Ok(p.into_bytes())
}

/// Parses the VIEW payload of view `v` of a file with header `h` (`texels` = width · height).
pub(super) fn read(
    payload: &[u8],
    path: &Path,
    h: &Header,
    v: usize,
    texels: usize,
) -> Result<ViewParams> {
    let mut s = Reader::new(payload, path, KIND);
    s.set_part("VIEW");
    let idx = s.len32("view index")?;
    if idx != v {
        return Err(s.err(format!("view section {v} is labelled {idx}")));
    }
    let k = s.len32("cluster count")?;
    if h.kind != ModelKind::PlmC {
        if k != 0 {
            return Err(s.err(format!("view {v}: clusters in a {} model", h.kind.name())));
        }
        if payload.len() != 8 + texels * 3 * 8 {
            return Err(s.err(format!(
                "view {v}: {} bytes, expected {}",
                payload.len(),
                8 + texels * 24
            )));
        }
        let lobes = (0..3 * texels)
            .map(|_| read_lobe(&mut s))
            .collect::<Result<Vec<_>>>()?;
        s.finish()?;
        return Ok(ViewParams::Texel(lobes));
    }
    if k == 0 || k > h.clusters {
        return Err(s.err(format!(
            "view {v} has {k} clusters (1..={} allowed)",
            h.clusters
        )));
    }
    let table = if h.version == 1 {
        (0..3 * k)
            .map(|_| read_lobe(&mut s))
            .collect::<Result<Vec<_>>>()?
    } else {
        let coding = s.u8("cluster table coding")?;
        let n = s.len32("cluster table size")?;
        let data = s.take(n, "cluster table")?;
        let lobes = match coding {
            0 => data.to_vec(),
            1 => {
                let what = format!("view {v}: cluster table");
                let planes = inflate_exact(&s, data, 24 * k, &what)?;
                (0..24 * k)
                    .map(|i| planes[(i % 8) * 3 * k + i / 8])
                    .collect()
            }
            _ => return Err(s.err(format!("view {v}: unknown table coding {coding}"))),
        };
        if lobes.len() != 24 * k {
            return Err(s.err(format!(
                "view {v}: raw cluster table is {} bytes",
                lobes.len()
            )));
        }
        let mut t = Reader::new(&lobes, path, KIND);
        t.set_part("VIEW table");
        (0..3 * k)
            .map(|_| read_lobe(&mut t))
            .collect::<Result<Vec<_>>>()?
    };
    let coding = s.u8("index coding")?;
    let n = s.len32("index image size")?;
    let data = s.take(n, "index image")?;
    s.finish()?;
    let wide = h.index_bytes == 2;
    let plane_bytes = texels * 3 * if wide { 2 } else { 1 };
    let planes = match coding {
        0 => data.to_vec(),
        1 => inflate_exact(&s, data, plane_bytes, &format!("view {v}: index image"))?,
        _ => return Err(s.err(format!("view {v}: unknown index coding {coding}"))),
    };
    if planes.len() != plane_bytes {
        return Err(s.err(format!(
            "view {v}: index image has {} bytes, expected {plane_bytes}",
            planes.len()
        )));
    }
    let mut index = vec![0u16; texels * 3];
    for ch in 0..3 {
        for t in 0..texels {
            let o = ch * texels + t;
            let d = if wide {
                u16::from_le_bytes([planes[2 * o], planes[2 * o + 1]])
            } else {
                planes[o] as u16
            };
            index[3 * t + ch] = match (coding, ch) {
                (0, _) | (_, 0) => d,
                _ if wide => d.wrapping_add(index[3 * t + ch - 1]),
                _ => (d as u8).wrapping_add(index[3 * t + ch - 1] as u8) as u16,
            };
            if index[3 * t + ch] as usize >= k {
                return Err(s.err(format!(
                    "view {v}: cluster index {} ≥ {k}",
                    index[3 * t + ch]
                )));
            }
        }
    }
    Ok(ViewParams::Clustered { k, table, index })
}
