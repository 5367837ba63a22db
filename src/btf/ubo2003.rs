//! Bonn UBO2003 folder layout: 81 × 81 images named `NNNNN tlTTT plPPP tvTTT pvPPP.ext`
//! (docs/formats.md), flat or with one sub-folder `tvTTT_pvPPP/` per view.
//!
//! Encodings: JPEG and PNG (8- or 16-bit) are sRGB-encoded integer images and are reported as
//! [`StoredEncoding::Srgb8`] (the paper's MAE is taken on the sRGB code normalised to [0, 1]; for
//! 16-bit PNG that is code/65535, the same quantity at finer resolution); EXR is
//! [`StoredEncoding::Linear`]. All images are decoded to linear RGB by [`crate::io::read_image`].

use super::{BtfSource, DirectionSet, RawBtf, StoredEncoding};
use crate::io::{RgbImage, read_image};
use crate::math::color::linear_to_srgb;
use crate::{Error, Result};
use half::f16;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Number of directions (views and lights alike) of a UBO2003 measurement.
pub const DIRECTIONS: usize = 81;

/// Image encoding used when writing a UBO2003 folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    /// 8-bit sRGB PNG, what other UBO2003 tools expect.
    Png8,
    /// 16-bit sRGB PNG (more headroom for synthetic data).
    Png16,
    /// Linear 32-bit float EXR.
    Exr,
}

impl ImageKind {
    /// File extension without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            ImageKind::Png8 | ImageKind::Png16 => "png",
            ImageKind::Exr => "exr",
        }
    }
}

/// The fields of one strictly parsed image name.
#[derive(Clone, Debug, PartialEq, Eq)]
struct ImageName {
    index: usize,
    tl: u32,
    pl: u32,
    tv: u32,
    pv: u32,
    /// Lower-case extension, `jpeg` normalised to `jpg`.
    ext: String,
}

fn digits(s: &str) -> Option<u32> {
    if s.bytes().all(|b| b.is_ascii_digit()) {
        s.parse().ok()
    } else {
        None
    }
}

/// Parses `NNNNN tlTTT plPPP tvTTT pvPPP.ext` exactly (single spaces, fixed widths).
fn parse_name(name: &str) -> Option<ImageName> {
    let (stem, ext) = name.rsplit_once('.')?;
    let ext = ext.to_ascii_lowercase();
    let ext = match ext.as_str() {
        "jpg" | "jpeg" => "jpg".to_string(),
        "png" | "exr" => ext,
        _ => return None,
    };
    if stem.len() != 29 || !stem.is_ascii() {
        return None;
    }
    let b = stem.as_bytes();
    if b[5] != b' ' || b[11] != b' ' || b[17] != b' ' || b[23] != b' ' {
        return None;
    }
    if &stem[6..8] != "tl"
        || &stem[12..14] != "pl"
        || &stem[18..20] != "tv"
        || &stem[24..26] != "pv"
    {
        return None;
    }
    Some(ImageName {
        index: digits(&stem[0..5])? as usize,
        tl: digits(&stem[8..11])?,
        pl: digits(&stem[14..17])?,
        tv: digits(&stem[20..23])?,
        pv: digits(&stem[26..29])?,
        ext,
    })
}

/// Deletes the UBO2003 images (any of the accepted encodings) directly in `dir`, keeping every
/// other file; returns how many were removed. Used before rewriting a folder in place, so it
/// never holds images of two encodings.
pub fn remove_images(dir: &Path) -> Result<usize> {
    let mut n = 0;
    for e in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let e = e.map_err(|e| Error::io(dir, e))?;
        let name = e.file_name();
        if name.to_str().and_then(parse_name).is_some() && e.path().is_file() {
            std::fs::remove_file(e.path()).map_err(|err| Error::io(e.path(), err))?;
            n += 1;
        }
    }
    Ok(n)
}

/// Parses a per-view sub-folder name `tvTTT_pvPPP`.
fn parse_view_folder(name: &str) -> Option<(u32, u32)> {
    if name.len() != 11 || !name.is_ascii() || &name[0..2] != "tv" || &name[5..8] != "_pv" {
        return None;
    }
    Some((digits(&name[2..5])?, digits(&name[8..11])?))
}

/// The file name of image (view, light) in a UBO2003 folder.
pub fn image_name(view: usize, light: usize, ext: &str) -> String {
    let d = DirectionSet::ubo2003();
    let (tl, pl) = d.angles_deg[light];
    let (tv, pv) = d.angles_deg[view];
    format!(
        "{:05} tl{:03} pl{:03} tv{:03} pv{:03}.{ext}",
        DIRECTIONS * light + view,
        tl.round() as u32,
        pl.round() as u32,
        tv.round() as u32,
        pv.round() as u32
    )
}

fn is_hidden(name: &str) -> bool {
    name.starts_with('.')
}

fn sorted_entries(dir: &Path) -> Result<Vec<(String, PathBuf, bool)>> {
    let rd = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut out = Vec::new();
    for entry in rd {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let path = entry.path();
        let Some(name) = entry.file_name().to_str().map(str::to_string) else {
            return Err(Error::format(&path, "file name is not valid UTF-8"));
        };
        if is_hidden(&name) {
            continue;
        }
        let is_dir = path.is_dir();
        out.push((name, path, is_dir));
    }
    out.sort();
    Ok(out)
}

/// Reads the pixel size of an image from its header only.
fn image_dims(path: &Path) -> Result<(usize, usize)> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext == "exr" {
        let meta = exr::meta::MetaData::read_from_file(path, false)
            .map_err(|e| Error::format(path, format!("cannot read EXR header: {e}")))?;
        let h = meta
            .headers
            .first()
            .ok_or_else(|| Error::format(path, "EXR file has no layer"))?;
        Ok((h.layer_size.width(), h.layer_size.height()))
    } else {
        let (w, h) = image::image_dimensions(path)
            .map_err(|e| Error::format(path, format!("cannot read image header: {e}")))?;
        Ok((w as usize, h as usize))
    }
}

/// A UBO2003 folder validated on open; images are decoded on demand, one view at a time.
#[derive(Clone, Debug)]
pub struct Ubo2003Folder {
    dir: PathBuf,
    dirs: DirectionSet,
    /// Image paths in `[view][light]` order.
    files: Vec<PathBuf>,
    width: usize,
    height: usize,
    encoding: StoredEncoding,
}

impl Ubo2003Folder {
    /// Scans and validates `dir`: exactly 81 × 81 strictly named images (flat or in per-view
    /// sub-folders), angles matching [`DirectionSet::ubo2003`], one format, one size (from headers).
    pub fn open(dir: &Path) -> Result<Self> {
        if !dir.is_dir() {
            return Err(Error::format(dir, "not a directory"));
        }
        let dirs = DirectionSet::ubo2003();
        let angle = |i: usize| {
            let (t, p) = dirs.angles_deg[i];
            (t.round() as u32, p.round() as u32)
        };
        // Gather (path, parsed name) from the flat layout or from per-view sub-folders.
        let mut found: Vec<(PathBuf, ImageName)> = Vec::new();
        let mut flat = false;
        let mut nested = false;
        for (name, path, is_dir) in sorted_entries(dir)? {
            if is_dir {
                let Some((tv, pv)) = parse_view_folder(&name) else {
                    return Err(Error::format(
                        &path,
                        "unexpected sub-folder (per-view folders are named tvTTT_pvPPP)",
                    ));
                };
                nested = true;
                for (sub, sub_path, sub_is_dir) in sorted_entries(&path)? {
                    let parsed = (!sub_is_dir).then(|| parse_name(&sub)).flatten();
                    let Some(parsed) = parsed else {
                        return Err(Error::format(
                            &sub_path,
                            "not a UBO2003 image name 'NNNNN tlTTT plPPP tvTTT pvPPP.ext'",
                        ));
                    };
                    if (parsed.tv, parsed.pv) != (tv, pv) {
                        return Err(Error::format(
                            &sub_path,
                            format!(
                                "view angles in the name differ from the folder tv{tv:03}_pv{pv:03}"
                            ),
                        ));
                    }
                    found.push((sub_path, parsed));
                }
            } else {
                let Some(parsed) = parse_name(&name) else {
                    return Err(Error::format(
                        &path,
                        "not a UBO2003 image name 'NNNNN tlTTT plPPP tvTTT pvPPP.ext' (.jpg/.png/.exr)",
                    ));
                };
                flat = true;
                found.push((path, parsed));
            }
        }
        if found.is_empty() {
            return Err(Error::format(
                dir,
                "not a UBO2003 BTF folder: it holds no image named like \
                 'NNNNN tlTTT plPPP tvTTT pvPPP.png' (.jpg, .png or .exr), directly or in \
                 tvTTT_pvPPP/ sub-folders",
            ));
        }
        if flat && nested {
            return Err(Error::format(
                dir,
                "mixes images at the top level with per-view sub-folders",
            ));
        }
        let n = DIRECTIONS * DIRECTIONS;
        let mut slots: Vec<Option<PathBuf>> = vec![None; n];
        let mut ext: Option<(String, PathBuf)> = None;
        for (path, p) in found {
            if p.index >= n {
                return Err(Error::format(
                    &path,
                    format!("image index {} out of range (0..{n})", p.index),
                ));
            }
            let (light, view) = (p.index / DIRECTIONS, p.index % DIRECTIONS);
            if (p.tl, p.pl) != angle(light) || (p.tv, p.pv) != angle(view) {
                return Err(Error::format(
                    &path,
                    format!(
                        "angles in the name do not match index {} (light {light} = θ{} φ{}, view {view} = θ{} φ{})",
                        p.index,
                        angle(light).0,
                        angle(light).1,
                        angle(view).0,
                        angle(view).1
                    ),
                ));
            }
            match &ext {
                None => ext = Some((p.ext.clone(), path.clone())),
                Some((e, first)) if *e != p.ext => {
                    return Err(Error::format(
                        &path,
                        format!("image format .{} differs from {}", p.ext, first.display()),
                    ));
                }
                _ => {}
            }
            let slot = &mut slots[view * DIRECTIONS + light];
            if let Some(prev) = slot {
                return Err(Error::format(
                    &path,
                    format!(
                        "duplicate image index {} (also {})",
                        p.index,
                        prev.display()
                    ),
                ));
            }
            *slot = Some(path);
        }
        let mut files = Vec::with_capacity(n);
        let mut missing = 0;
        let mut first_missing = None;
        for (i, s) in slots.into_iter().enumerate() {
            match s {
                Some(p) => files.push(p),
                None => {
                    missing += 1;
                    first_missing.get_or_insert(i);
                }
            }
        }
        if let Some(i) = first_missing {
            let (view, light) = (i / DIRECTIONS, i % DIRECTIONS);
            return Err(Error::format(
                dir.join(image_name(view, light, "*")),
                format!("missing ({missing} of {n} images are missing)"),
            ));
        }
        let Some((ext, _)) = ext else {
            return Err(Error::format(dir, "no images"));
        };
        let encoding = if ext == "exr" {
            StoredEncoding::Linear
        } else {
            StoredEncoding::Srgb8
        };
        let dims: Vec<(usize, usize)> = files
            .par_iter()
            .map(|p| image_dims(p))
            .collect::<Result<_>>()?;
        let (width, height) = dims[0];
        if width == 0 || height == 0 {
            return Err(Error::format(&files[0], "image is empty"));
        }
        for (p, d) in files.iter().zip(&dims) {
            if *d != (width, height) {
                return Err(Error::format(
                    p,
                    format!(
                        "image is {}×{}, but {} is {width}×{height}",
                        d.0,
                        d.1,
                        files[0].display()
                    ),
                ));
            }
        }
        Ok(Ubo2003Folder {
            dir: dir.to_path_buf(),
            dirs,
            files,
            width,
            height,
            encoding,
        })
    }

    /// The folder this reads from.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Path of image (view, light).
    pub fn file(&self, view: usize, light: usize) -> &Path {
        &self.files[view * DIRECTIONS + light]
    }

    fn read_checked(&self, path: &Path) -> Result<RgbImage> {
        let img = read_image(path)?;
        if (img.width, img.height) != (self.width, self.height) {
            return Err(Error::format(
                path,
                format!(
                    "image is {}×{}, expected {}×{}",
                    img.width, img.height, self.width, self.height
                ),
            ));
        }
        Ok(img)
    }

    /// Decodes every image (in parallel) into an in-memory [`RawBtf`].
    pub fn load(&self) -> Result<RawBtf> {
        let per_image = 3 * self.width * self.height;
        let total = per_image * self.files.len();
        let mut data: Vec<f16> = Vec::new();
        data.try_reserve_exact(total).map_err(|_| {
            Error::format(
                &self.dir,
                format!(
                    "not enough memory to load the BTF ({:.2} GB as f16)",
                    total as f64 * 2e-9
                ),
            )
        })?;
        data.resize(total, f16::ZERO);
        data.par_chunks_mut(per_image)
            .zip(self.files.par_iter())
            .try_for_each(|(out, path)| {
                let img = self.read_checked(path)?;
                for (o, v) in out.iter_mut().zip(&img.data) {
                    *o = f16::from_f32(*v);
                }
                Ok::<(), Error>(())
            })?;
        RawBtf::from_f16(
            self.dirs.clone(),
            self.dirs.clone(),
            self.width,
            self.height,
            self.encoding,
            data,
        )
    }
}

impl BtfSource for Ubo2003Folder {
    fn views(&self) -> &DirectionSet {
        &self.dirs
    }
    fn lights(&self) -> &DirectionSet {
        &self.dirs
    }
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn encoding(&self) -> StoredEncoding {
        self.encoding
    }
    fn load_view(&self, view: usize) -> Result<Vec<f32>> {
        if view >= DIRECTIONS {
            return Err(Error::Invalid(format!(
                "{}: view {view} out of range ({DIRECTIONS} views)",
                self.dir.display()
            )));
        }
        let per_image = 3 * self.width * self.height;
        let mut out = vec![0.0f32; per_image * DIRECTIONS];
        out.par_chunks_mut(per_image)
            .zip(self.files[view * DIRECTIONS..(view + 1) * DIRECTIONS].par_iter())
            .try_for_each(|(o, path)| {
                let img = self.read_checked(path)?;
                o.copy_from_slice(&img.data);
                Ok::<(), Error>(())
            })?;
        Ok(out)
    }
}

/// Opens a UBO2003 folder for per-view streaming (validates names and sizes up front).
pub fn open_folder(dir: &Path) -> Result<Ubo2003Folder> {
    Ubo2003Folder::open(dir)
}

/// Loads a whole UBO2003 folder into memory.
pub fn load_folder(dir: &Path) -> Result<RawBtf> {
    Ubo2003Folder::open(dir)?.load()
}

fn same_directions(a: &DirectionSet, b: &DirectionSet) -> bool {
    a.len() == b.len()
        && a.angles_deg
            .iter()
            .zip(&b.angles_deg)
            .all(|(x, y)| (x.0 - y.0).abs() < 1e-3 && (x.1 - y.1).abs() < 1e-3)
}

/// sRGB-encodes a linear value clamped to [0, 1] (non-finite → 0) at `max` code steps.
fn srgb_code(v: f32, max: f32) -> f32 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    linear_to_srgb(v) * max + 0.5
}

/// Encodes one image in memory (PNG8/PNG16 sRGB, or 32-bit float EXR).
fn encode(path: &Path, img: &RgbImage, kind: ImageKind) -> Result<Vec<u8>> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    let (w, h) = (img.width as u32, img.height as u32);
    let size_err = || Error::format(path, "image buffer size mismatch");
    match kind {
        ImageKind::Png8 => {
            let v: Vec<u8> = img
                .data
                .iter()
                .map(|&x| srgb_code(x, 255.0) as u8)
                .collect();
            image::RgbImage::from_raw(w, h, v)
                .ok_or_else(size_err)?
                .write_to(&mut bytes, image::ImageFormat::Png)
        }
        ImageKind::Png16 => {
            let v: Vec<u16> = img
                .data
                .iter()
                .map(|&x| srgb_code(x, 65535.0) as u16)
                .collect();
            image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(w, h, v)
                .ok_or_else(size_err)?
                .write_to(&mut bytes, image::ImageFormat::Png)
        }
        ImageKind::Exr => {
            use exr::prelude::*;
            let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
                let p = img.get(pos.x(), pos.y());
                (p[0], p[1], p[2])
            });
            return Image::from_channels((img.width, img.height), channels)
                .write()
                .to_buffered(&mut bytes)
                .map(|_| bytes.into_inner())
                .map_err(|e| crate::Error::format(path, format!("cannot encode EXR: {e}")));
        }
    }
    .map_err(|e| Error::format(path, format!("cannot encode PNG: {e}")))?;
    Ok(bytes.into_inner())
}

/// Writes `btf` as a flat UBO2003 folder (created if missing). The BTF must use the UBO2003
/// direction set for both views and lights. PNG output is sRGB-encoded and clamped to [0, 1].
pub fn write_folder(btf: &RawBtf, dir: &Path, kind: ImageKind) -> Result<()> {
    let ubo = DirectionSet::ubo2003();
    if !same_directions(btf.views(), &ubo) || !same_directions(btf.lights(), &ubo) {
        return Err(Error::format(
            dir,
            format!(
                "a UBO2003 folder needs the 81 UBO2003 directions, this BTF has {} views × {} lights",
                btf.views().len(),
                btf.lights().len()
            ),
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let (w, h) = (btf.width(), btf.height());
    let per_image = 3 * w * h;
    let ext = kind.extension();
    (0..DIRECTIONS * DIRECTIONS)
        .into_par_iter()
        .try_for_each(|i| {
            let (view, light) = (i / DIRECTIONS, i % DIRECTIONS);
            let src = &btf.view_data(view)[light * per_image..(light + 1) * per_image];
            let img = RgbImage {
                width: w,
                height: h,
                data: src.iter().map(|v| v.to_f32()).collect(),
            };
            let path = dir.join(image_name(view, light, ext));
            // Plain writes: a folder of 6561 files cannot be replaced atomically anyway, and a
            // per-file fsync would dominate; an interrupted write leaves a file the reader rejects.
            let bytes = encode(&path, &img, kind)?;
            std::fs::write(&path, bytes).map_err(|e| Error::io(&path, e))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic UBO2003 BTF with values in [0, 1] that vary with every index.
    pub(crate) fn small_btf(w: usize, h: usize) -> RawBtf {
        let d = DirectionSet::ubo2003();
        let n = DIRECTIONS * DIRECTIONS * w * h * 3;
        let data: Vec<f32> = (0..n)
            .map(|i| ((i as u64 * 2654435761u64) % 1000) as f32 / 999.0)
            .collect();
        RawBtf::from_f32(d.clone(), d, w, h, StoredEncoding::Linear, &data).unwrap()
    }

    #[test]
    fn names_parse_strictly() {
        let p = parse_name("06560 tl075 pl345 tv075 pv345.JPG").unwrap();
        assert_eq!((p.index, p.tl, p.pl, p.tv, p.pv), (6560, 75, 345, 75, 345));
        assert_eq!(p.ext, "jpg");
        for bad in [
            "6560 tl075 pl345 tv075 pv345.jpg",
            "06560  tl075 pl345 tv075 pv345.jpg",
            "06560 tl075 pl345 tv075 pv345.bmp",
            "06560 tl075 pl345 tv075 pv34x.jpg",
            "06560 tl075 pl345 tv075 pv345",
            "06560_tl075_pl345_tv075_pv345.jpg",
            "06560 tl+75 pl345 tv075 pv345.jpg",
        ] {
            assert!(parse_name(bad).is_none(), "{bad}");
        }
        assert_eq!(image_name(1, 0, "png"), "00001 tl000 pl000 tv015 pv000.png");
        assert_eq!(parse_view_folder("tv015_pv060"), Some((15, 60)));
        assert_eq!(parse_view_folder("tv015-pv060"), None);
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let btf = small_btf(3, 2);
        write_folder(&btf, dir.path(), ImageKind::Exr).unwrap();
        let back = load_folder(dir.path()).unwrap();
        assert_eq!(back.encoding(), StoredEncoding::Linear);
        assert_eq!((back.width(), back.height()), (3, 2));
        assert_eq!(back.data(), btf.data());
        // The lazy source returns the same view.
        let src = open_folder(dir.path()).unwrap();
        let v = src.load_view(40).unwrap();
        let expect: Vec<f32> = btf.view_data(40).iter().map(|x| x.to_f32()).collect();
        assert_eq!(v, expect);
        assert!(src.load_view(81).is_err());
        // The same images moved into per-view sub-folders read back identically.
        let d = DirectionSet::ubo2003();
        for view in 0..DIRECTIONS {
            let (t, p) = d.angles_deg[view];
            let sub = dir
                .path()
                .join(format!("tv{:03}_pv{:03}", t as u32, p as u32));
            std::fs::create_dir(&sub).unwrap();
            for light in 0..DIRECTIONS {
                let name = image_name(view, light, "exr");
                std::fs::rename(dir.path().join(&name), sub.join(&name)).unwrap();
            }
        }
        assert_eq!(load_folder(dir.path()).unwrap().data(), btf.data());
        // An image whose view angles disagree with its sub-folder is rejected.
        let sub = dir.path().join("tv000_pv000");
        let moved = image_name(1, 0, "exr");
        std::fs::rename(
            dir.path().join("tv015_pv000").join(&moved),
            sub.join(&moved),
        )
        .unwrap();
        assert!(err_of(dir.path()).contains("differ from the folder"));
    }

    #[test]
    fn png_round_trips_within_quantisation() {
        for (kind, step) in [(ImageKind::Png8, 255.0), (ImageKind::Png16, 65535.0)] {
            let dir = tempfile::tempdir().unwrap();
            let btf = small_btf(2, 2);
            write_folder(&btf, dir.path(), kind).unwrap();
            let back = load_folder(dir.path()).unwrap();
            assert_eq!(back.encoding(), StoredEncoding::Srgb8);
            // Half a code step in sRGB, plus the f16 rounding of the stored value (≤ 2^-11 relative).
            let mut worst = 0.0f32;
            for (a, b) in btf.data().iter().zip(back.data()) {
                let (a, b) = (a.to_f32(), b.to_f32());
                let e = (linear_to_srgb(a) - linear_to_srgb(b)).abs();
                worst = worst.max(e);
            }
            assert!(worst <= 0.5 / step + 1e-3, "{kind:?}: {worst}");
            if kind == ImageKind::Png16 {
                assert!(worst < 1e-3, "16-bit should be much finer: {worst}");
            }
        }
    }

    fn err_of(dir: &Path) -> String {
        load_folder(dir).unwrap_err().to_string()
    }

    #[test]
    fn bad_folders_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let btf = small_btf(2, 1);
        write_folder(&btf, dir.path(), ImageKind::Png8).unwrap();
        let p = |v, l| dir.path().join(image_name(v, l, "png"));

        // Missing image.
        let bytes = std::fs::read(p(5, 7)).unwrap();
        std::fs::remove_file(p(5, 7)).unwrap();
        let e = err_of(dir.path());
        assert!(
            e.contains("00572 tl030 pl000 tv015 pv240") && e.contains("missing"),
            "{e}"
        );
        // Corrupt image.
        std::fs::write(p(5, 7), b"garbage").unwrap();
        let e = err_of(dir.path());
        assert!(e.contains(&image_name(5, 7, "png")), "{e}");
        std::fs::write(p(5, 7), &bytes).unwrap();
        assert!(load_folder(dir.path()).is_ok());
        // Extra file.
        let extra = dir.path().join("notes.txt");
        std::fs::write(&extra, b"x").unwrap();
        assert!(err_of(dir.path()).contains("notes.txt"));
        std::fs::remove_file(&extra).unwrap();
        // Misnamed: angles do not match the index.
        let wrong = dir.path().join("00000 tl000 pl000 tv015 pv000.png");
        std::fs::rename(p(0, 0), &wrong).unwrap();
        let e = err_of(dir.path());
        assert!(
            e.contains("00000 tl000 pl000 tv015 pv000.png") && e.contains("angles"),
            "{e}"
        );
        std::fs::rename(&wrong, p(0, 0)).unwrap();
        // Duplicate index in another format.
        let dup = dir.path().join(image_name(3, 3, "jpg"));
        std::fs::write(&dup, b"x").unwrap();
        assert!(err_of(dir.path()).contains(&image_name(3, 3, "jpg")));
        std::fs::remove_file(&dup).unwrap();
        // Wrong size.
        crate::io::write_png_srgb(&p(9, 9), &RgbImage::new(1, 1)).unwrap();
        let e = err_of(dir.path());
        assert!(
            e.contains(&image_name(9, 9, "png")) && e.contains("1×1"),
            "{e}"
        );
        // Not a directory.
        assert!(load_folder(&p(0, 0)).is_err());
    }

    #[test]
    fn writer_rejects_non_ubo2003_directions() {
        let d = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
        let b =
            RawBtf::from_f32(d.clone(), d, 1, 1, StoredEncoding::Linear, &[0.1, 0.2, 0.3]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        assert!(write_folder(&b, dir.path(), ImageKind::Exr).is_err());
    }
}
