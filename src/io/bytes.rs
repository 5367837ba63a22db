//! The one little-endian byte codec under every binary format of btfpt (`.plmc` models and fit
//! parts, `.btfc` caches, UBO2014 `.btf` headers, tiling stitches, render checkpoints).
//!
//! [`Reader`] is bounds-checked: every read that the buffer cannot satisfy is an error naming the
//! file, the byte offset and the field being read, never a panic or an allocation sized by a
//! corrupt count. [`Writer`] appends to a `Vec<u8>`; files are then written whole and atomically
//! (`io::write_atomic`).

use crate::{Error, Result};
use half::f16;
use std::path::Path;

/// A bounds-checked little-endian cursor over a file's bytes.
#[derive(Clone, Debug)]
pub struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    path: &'a Path,
    /// What kind of data this is, for messages (e.g. "corrupt .plmc file").
    kind: &'static str,
    /// The part of the format being read, for messages (e.g. "VIEW section").
    part: &'static str,
}

impl<'a> Reader<'a> {
    /// A reader at offset 0; `path` and `kind` only name the data in errors.
    pub fn new(buf: &'a [u8], path: &'a Path, kind: &'static str) -> Self {
        Reader {
            buf,
            pos: 0,
            path,
            kind,
            part: "",
        }
    }

    /// Names the part of the format read next (appears in errors).
    pub fn set_part(&mut self, part: &'static str) {
        self.part = part;
    }

    /// An error at the current offset: "`kind` (in `part` at byte `pos`): `msg`".
    pub fn err(&self, msg: impl std::fmt::Display) -> Error {
        let at = if self.part.is_empty() {
            format!("at byte {}", self.pos)
        } else {
            format!("in {} at byte {}", self.part, self.pos)
        };
        Error::format(self.path, format!("{} ({at}): {msg}", self.kind))
    }

    /// The file the bytes came from.
    pub fn path(&self) -> &'a Path {
        self.path
    }

    /// Current offset from the start of the buffer.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Moves to an absolute offset (an error past the end).
    pub fn seek(&mut self, pos: usize) -> Result<()> {
        if pos > self.buf.len() {
            return Err(self.err(format!(
                "offset {pos} is past the end ({} bytes)",
                self.buf.len()
            )));
        }
        self.pos = pos;
        Ok(())
    }

    /// Bytes not yet read.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    /// The next `count · size` bytes of `field`; refuses (without allocating) anything the buffer
    /// cannot hold, including products that overflow.
    pub fn take_n(&mut self, count: u64, size: u64, field: &str) -> Result<&'a [u8]> {
        let n = count
            .checked_mul(size)
            .filter(|&n| n <= self.remaining() as u64);
        let Some(n) = n else {
            return Err(self.err(format!(
                "truncated or corrupt: {field} needs {count} × {size} bytes, {} left",
                self.remaining()
            )));
        };
        let s = &self.buf[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(s)
    }

    /// The next `n` bytes of `field`.
    pub fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8]> {
        self.take_n(n as u64, 1, field)
    }

    /// The next `N` bytes as an array.
    pub fn array<const N: usize>(&mut self, field: &str) -> Result<[u8; N]> {
        let s = self.take(N, field)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    /// One byte.
    pub fn u8(&mut self, field: &str) -> Result<u8> {
        Ok(self.array::<1>(field)?[0])
    }
    /// A signed byte.
    pub fn i8(&mut self, field: &str) -> Result<i8> {
        Ok(self.u8(field)? as i8)
    }
    /// A little-endian u16.
    pub fn u16(&mut self, field: &str) -> Result<u16> {
        Ok(u16::from_le_bytes(self.array(field)?))
    }
    /// A little-endian i16.
    pub fn i16(&mut self, field: &str) -> Result<i16> {
        Ok(i16::from_le_bytes(self.array(field)?))
    }
    /// A little-endian u32.
    pub fn u32(&mut self, field: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.array(field)?))
    }
    /// A little-endian u64.
    pub fn u64(&mut self, field: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.array(field)?))
    }
    /// A little-endian IEEE f32 (any bit pattern, NaN included: callers validate).
    pub fn f32(&mut self, field: &str) -> Result<f32> {
        Ok(f32::from_le_bytes(self.array(field)?))
    }
    /// A little-endian IEEE f64.
    pub fn f64(&mut self, field: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.array(field)?))
    }
    /// A u32 count or size, as usize.
    pub fn len32(&mut self, field: &str) -> Result<usize> {
        Ok(self.u32(field)? as usize)
    }

    /// `count` scalars of `size` bytes each (2 = f16, 4 = f32, 8 = f64), converted to f32.
    pub fn scalars(&mut self, count: u64, size: u8, field: &str) -> Result<Vec<f32>> {
        if !matches!(size, 2 | 4 | 8) {
            return Err(self.err(format!("{field}: unsupported scalar size {size}")));
        }
        let b = self.take_n(count, size as u64, field)?;
        Ok(match size {
            2 => b
                .chunks_exact(2)
                .map(|c| f16::from_le_bytes([c[0], c[1]]).to_f32())
                .collect(),
            4 => b
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
            _ => b
                .chunks_exact(8)
                .map(|c| {
                    f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]) as f32
                })
                .collect(),
        })
    }

    /// Errors unless every byte was read.
    pub fn finish(&self) -> Result<()> {
        if self.pos != self.buf.len() {
            return Err(self.err(format!(
                "{} unexpected trailing bytes",
                self.buf.len() - self.pos
            )));
        }
        Ok(())
    }
}

/// A little-endian byte sink (the mirror of [`Reader`]).
#[derive(Clone, Debug, Default)]
pub struct Writer {
    buf: Vec<u8>,
}

impl Writer {
    /// An empty writer.
    pub fn new() -> Self {
        Self::default()
    }
    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.buf.len()
    }
    /// True if nothing was written.
    pub fn is_empty(&self) -> bool {
        self.buf.is_empty()
    }
    /// The written bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf
    }
    /// The written bytes, by value.
    pub fn into_bytes(self) -> Vec<u8> {
        self.buf
    }
    /// Raw bytes.
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        self.buf.extend_from_slice(b);
        self
    }
    /// One byte.
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.bytes(&[v])
    }
    /// A signed byte.
    pub fn i8(&mut self, v: i8) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// A little-endian u16.
    pub fn u16(&mut self, v: u16) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// A little-endian i16.
    pub fn i16(&mut self, v: i16) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// A little-endian u32.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// A little-endian u64.
    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// A little-endian f32.
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// A little-endian f64.
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }
    /// A count or size that must fit in a u32 (an error naming `field` otherwise).
    pub fn len32(&mut self, v: usize, field: &str) -> Result<&mut Self> {
        let v = u32::try_from(v)
            .map_err(|_| Error::Invalid(format!("{field} = {v} does not fit in 32 bits")))?;
        Ok(self.u32(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_every_type() {
        let mut w = Writer::new();
        w.u8(7)
            .i8(-3)
            .u16(0xBEEF)
            .i16(-2)
            .u32(0xDEAD_BEEF)
            .u64(u64::MAX - 1);
        w.f32(-1.5).f64(std::f64::consts::PI);
        w.len32(42, "n").unwrap();
        w.bytes(b"tail");
        let b = w.into_bytes();
        let p = Path::new("x.bin");
        let mut r = Reader::new(&b, p, "test data");
        assert_eq!(r.u8("a").unwrap(), 7);
        assert_eq!(r.i8("b").unwrap(), -3);
        assert_eq!(r.u16("c").unwrap(), 0xBEEF);
        assert_eq!(r.i16("d").unwrap(), -2);
        assert_eq!(r.u32("e").unwrap(), 0xDEAD_BEEF);
        assert_eq!(r.u64("f").unwrap(), u64::MAX - 1);
        assert_eq!(r.f32("g").unwrap(), -1.5);
        assert_eq!(r.f64("h").unwrap(), std::f64::consts::PI);
        assert_eq!(r.len32("n").unwrap(), 42);
        assert_eq!(r.take(4, "tail").unwrap(), b"tail");
        r.finish().unwrap();
    }

    #[test]
    fn errors_name_file_offset_part_and_field() {
        let b = [1u8, 2, 3];
        let p = Path::new("m.plmc");
        let mut r = Reader::new(&b, p, "corrupt .plmc file");
        r.set_part("HEAD section");
        r.u16("kind").unwrap();
        let e = r.u32("width").unwrap_err().to_string();
        assert!(
            e.contains("m.plmc") && e.contains("HEAD section at byte 2") && e.contains("width"),
            "{e}"
        );
        assert!(e.contains("truncated"), "{e}");
        let e = r.finish().unwrap_err().to_string();
        assert!(e.contains("1 unexpected trailing bytes"), "{e}");
        // Overflowing and huge counts fail without allocating.
        assert!(r.take_n(u64::MAX, 8, "table").is_err());
        assert!(r.scalars(1 << 40, 4, "payload").is_err());
        assert!(r.scalars(1, 3, "payload").is_err());
    }

    #[test]
    fn scalars_decode_half_single_double() {
        let mut w = Writer::new();
        w.bytes(&f16::from_f32(0.5).to_le_bytes())
            .f32(2.0)
            .f64(-4.0);
        let b = w.into_bytes();
        let mut r = Reader::new(&b, Path::new("s"), "x");
        assert_eq!(r.scalars(1, 2, "h").unwrap(), vec![0.5]);
        assert_eq!(r.scalars(1, 4, "f").unwrap(), vec![2.0]);
        assert_eq!(r.scalars(1, 8, "d").unwrap(), vec![-4.0]);
        assert!(r.seek(99).is_err());
        r.seek(0).unwrap();
        assert_eq!(r.pos(), 0);
    }
}
