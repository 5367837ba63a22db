//! Partial renders as EXR files (docs/formats.md, docs/farm.md): the image holds the per-pixel
//! *mean* of the samples [spp_begin, spp_end) of the pixels in a window of the full film. The
//! window is the EXR data window inside the display window (the full film), and one text
//! attribute `btfpt` records film size, window, sample range, seed, a fingerprint of the scene,
//! the files it reads and the options (so parts of different renders are never merged), and
//! the window of the whole render the part belongs to (so a merge can say what is missing). Merging weights each input by its sample
//! count, so crop tiles and sample-range splits recombine into the single-machine image (bit
//! for bit for crop tiles, to float rounding for sample ranges).

use crate::io::{RgbImage, write_atomic};
use crate::{Error, Result};

type E = crate::Error;
use std::path::Path;

/// Which part of which render an image is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PartialMeta {
    /// Full film size in pixels.
    pub width: u32,
    pub height: u32,
    /// Window (x, y, w, h) the image covers.
    pub crop: [u32; 4],
    pub spp_begin: u32,
    pub spp_end: u32,
    pub seed: u64,
    /// [`scene_fingerprint`] of the scene file and the options that change the image.
    pub scene: u64,
    /// The window (x, y, w, h) of the whole render this part was split from (`--band` splits
    /// it); None in files written before it was recorded.
    pub whole: Option<[u32; 4]>,
}

/// Largest prefix of a file read for its fingerprint: its header and the start of its data.
const FINGERPRINT_PREFIX: u64 = 1 << 20;

/// Identifies the content of a file the scene reads (mesh, texture, BTF data or model) cheaply
/// and independently of where it lies: its size and the CRC-32 of its first MiB. A folder (a
/// UBO2003 BTF) is identified by the names and sizes of its files, one sub-folder level deep. A
/// name that is no file (a `synth:` source) stands for itself.
pub fn input_fingerprint(path: &Path) -> Result<u32> {
    use std::io::Read;
    let mut h = crc32fast::Hasher::new();
    if path.is_dir() {
        let mut entries: Vec<(String, u64)> = Vec::new();
        let list = |dir: &Path, prefix: &str, out: &mut Vec<(String, u64)>| -> Result<()> {
            for e in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
                let e = e.map_err(|e| Error::io(dir, e))?;
                let meta = e.metadata().map_err(|err| Error::io(e.path(), err))?;
                let name = format!("{prefix}{}", e.file_name().to_string_lossy());
                out.push((name, if meta.is_dir() { u64::MAX } else { meta.len() }));
            }
            Ok(())
        };
        list(path, "", &mut entries)?;
        let subdirs: Vec<String> = entries
            .iter()
            .filter(|e| e.1 == u64::MAX)
            .map(|e| e.0.clone())
            .collect();
        for d in subdirs {
            list(&path.join(&d), &format!("{d}/"), &mut entries)?;
        }
        entries.sort();
        h.update(b"folder");
        for (name, len) in entries {
            h.update(name.as_bytes());
            h.update(&len.to_le_bytes());
        }
    } else if path.is_file() {
        let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let len = f.metadata().map_err(|e| Error::io(path, e))?.len();
        let mut prefix = Vec::new();
        f.take(FINGERPRINT_PREFIX)
            .read_to_end(&mut prefix)
            .map_err(|e| Error::io(path, e))?;
        h.update(b"file");
        h.update(&len.to_le_bytes());
        h.update(&prefix);
    } else {
        h.update(b"name");
        h.update(path.to_string_lossy().as_bytes());
    }
    Ok(h.finalize())
}

/// [`input_fingerprint`] of every file in order, as text for [`scene_fingerprint`]'s options.
pub fn inputs_fingerprint(paths: &[std::path::PathBuf]) -> Result<String> {
    let mut s = String::from("inputs");
    for p in paths {
        s.push_str(&format!(" {:08x}", input_fingerprint(p)?));
    }
    Ok(s)
}

/// Identifies what a partial render is a part of: the scene file's bytes and the options that
/// change the image other than window and sample range (`-D` defines, BTF model override).
/// Stable across machines and builds (two CRC-32s with different salts).
pub fn scene_fingerprint(scene_bytes: &[u8], options: &str) -> u64 {
    let half = |salt: &[u8]| {
        let mut h = crc32fast::Hasher::new();
        h.update(salt);
        h.update(&(scene_bytes.len() as u64).to_le_bytes());
        h.update(scene_bytes);
        h.update(options.as_bytes());
        h.finalize() as u64
    };
    (half(b"btfpt scene") << 32) | half(b"options")
}

const ATTR: &str = "btfpt";

impl PartialMeta {
    fn to_text(self) -> String {
        let [x, y, w, h] = self.crop;
        let whole = self.whole.map_or(String::new(), |[x, y, w, h]| {
            format!(" whole={x},{y},{w},{h}")
        });
        format!(
            "v2 film={}x{} window={x},{y},{w},{h} spp={}..{} seed={} scene={:016x}{whole}",
            self.width, self.height, self.spp_begin, self.spp_end, self.seed, self.scene
        )
    }

    fn parse(s: &str, path: &Path) -> Result<PartialMeta> {
        let bad = || Error::format(path, format!("malformed '{ATTR}' attribute: {s:?}"));
        let mut it = s.split_whitespace();
        match it.next() {
            Some("v2") => {}
            Some("v1") => {
                return Err(Error::format(
                    path,
                    "written by an older btfpt without a fingerprint of its scene and options; \
                     render it again to merge it safely",
                ));
            }
            _ => return Err(bad()),
        }
        let mut field = |key: &str| -> Result<String> {
            let kv = it.next().ok_or_else(bad)?;
            kv.strip_prefix(key)
                .and_then(|v| v.strip_prefix('='))
                .map(str::to_string)
                .ok_or_else(bad)
        };
        let film = field("film")?;
        let window = field("window")?;
        let spp = field("spp")?;
        let seed = field("seed")?;
        let scene = field("scene")?;
        // Optional trailing fields (older readers ignore them).
        let whole = match it.next() {
            None => None,
            Some(kv) => Some(kv.strip_prefix("whole=").ok_or_else(bad)?),
        };
        let (fw, fh) = film.split_once('x').ok_or_else(bad)?;
        let window4 = |text: &str| -> Result<[u32; 4]> {
            let v: Vec<u32> = text
                .split(',')
                .map(|v| v.parse().map_err(|_| bad()))
                .collect::<Result<_>>()?;
            v.try_into().map_err(|_| bad())
        };
        let win = window4(&window)?;
        let whole = whole.map(window4).transpose()?;
        let (a, b) = spp.split_once("..").ok_or_else(bad)?;
        let m = PartialMeta {
            width: fw.parse().map_err(|_| bad())?,
            height: fh.parse().map_err(|_| bad())?,
            crop: [win[0], win[1], win[2], win[3]],
            spp_begin: a.parse().map_err(|_| bad())?,
            spp_end: b.parse().map_err(|_| bad())?,
            seed: seed.parse().map_err(|_| bad())?,
            scene: u64::from_str_radix(&scene, 16).map_err(|_| bad())?,
            whole,
        };
        let [x, y, w, h] = m.crop;
        if m.spp_begin >= m.spp_end
            || w == 0
            || h == 0
            || x as u64 + w as u64 > m.width as u64
            || y as u64 + h as u64 > m.height as u64
        {
            return Err(Error::format(
                path,
                format!("inconsistent '{ATTR}' attribute: {s:?}"),
            ));
        }
        Ok(m)
    }
}

/// A partial render's channels beside R, G, B (Mitsuba's `aov` and `moment` outputs): name
/// and the window's values, row-major.
pub type ExtraChannels = Vec<(String, Vec<f32>)>;

/// Writes the window image `img` (size crop w × h) with its metadata, atomically.
pub fn write_partial_exr(path: &Path, img: &RgbImage, meta: &PartialMeta) -> crate::Result<()> {
    write_partial_exr_with(path, img, &[], meta)
}

/// [`write_partial_exr`] with extra channels, each of the window's size.
pub fn write_partial_exr_with(
    path: &Path,
    img: &RgbImage,
    extra: &[(String, Vec<f32>)],
    meta: &PartialMeta,
) -> crate::Result<()> {
    use exr::prelude::*;
    let [x, y, w, h] = meta.crop;
    if img.width != w as usize || img.height != h as usize {
        return Err(E::Invalid(format!(
            "image {}×{} does not match its window {w}×{h}",
            img.width, img.height
        )));
    }
    let npix = img.width * img.height;
    let mut list = SmallVec::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let v: Vec<f32> = (0..npix).map(|i| img.data[i * 3 + c]).collect();
        list.push(AnyChannel::new(*name, FlatSamples::F32(v)));
    }
    for (name, v) in extra {
        if v.len() != npix || ["R", "G", "B"].contains(&name.as_str()) {
            return Err(E::Invalid(format!(
                "extra channel \"{name}\" has {} values or clashes with R, G, B (window of {npix} pixels)",
                v.len()
            )));
        }
        list.push(AnyChannel::new(name.as_str(), FlatSamples::F32(v.clone())));
    }
    write_atomic(path, |out| {
        let channels = AnyChannels::sort(list);
        let attrs = LayerAttributes {
            layer_position: Vec2(x as i32, y as i32),
            ..LayerAttributes::default()
        };
        let layer = Layer::new(
            (w as usize, h as usize),
            attrs,
            Encoding::SMALL_LOSSLESS,
            channels,
        );
        let mut image = Image::from_layer(layer);
        image.attributes.display_window =
            IntegerBounds::new(Vec2(0, 0), Vec2(meta.width as usize, meta.height as usize));
        // A single custom attribute keeps the header byte-identical from run to run.
        image.attributes.other.insert(
            Text::from(ATTR),
            AttributeValue::Text(Text::from(meta.to_text().as_str())),
        );
        let mut buf = std::io::Cursor::new(Vec::new());
        image
            .write()
            .non_parallel()
            .to_buffered(&mut buf)
            .map_err(|e| E::format(path, format!("cannot encode EXR: {e}")))?;
        out.write_all(buf.get_ref()).map_err(|e| E::io(path, e))
    })
}

/// Reads a partial render written by [`write_partial_exr`].
pub fn read_partial_exr(path: &Path) -> crate::Result<(RgbImage, PartialMeta)> {
    let (img, _, meta) = read_partial_exr_with(path)?;
    Ok((img, meta))
}

/// Reads a partial render with its extra channels (sorted by name, as the EXR holds them).
pub fn read_partial_exr_with(path: &Path) -> crate::Result<(RgbImage, ExtraChannels, PartialMeta)> {
    use exr::prelude::*;
    if !path.exists() {
        return Err(E::format(path, "file not found"));
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| E::format(path, format!("cannot read EXR: {e}")))?;
    let key = Text::from(ATTR);
    let found = image
        .attributes
        .other
        .get(&key)
        .or_else(|| image.layer_data.attributes.other.get(&key));
    let text = match found {
        Some(AttributeValue::Text(t)) => t.to_string(),
        _ => {
            return Err(E::format(
                path,
                format!("not a btfpt partial render (no '{ATTR}' header attribute)"),
            ));
        }
    };
    let meta = PartialMeta::parse(&text, path)?;
    let pos = image.layer_data.attributes.layer_position;
    let size = image.layer_data.size;
    if [
        pos.x() as i64,
        pos.y() as i64,
        size.width() as i64,
        size.height() as i64,
    ] != meta.crop.map(|v| v as i64)
    {
        return Err(E::format(
            path,
            "EXR data window does not match the recorded render window",
        ));
    }
    let mut img = RgbImage::new(size.width(), size.height());
    let mut extra = ExtraChannels::new();
    let mut found_rgb = [false; 3];
    for ch in &image.layer_data.channel_data.list {
        let name = ch.name.to_string();
        let values: Vec<f32> = ch.sample_data.values_as_f32().collect();
        match ["R", "G", "B"].iter().position(|c| *c == name) {
            Some(c) => {
                found_rgb[c] = true;
                for (i, v) in values.into_iter().enumerate() {
                    img.data[i * 3 + c] = v;
                }
            }
            None if name == "A" => {}
            None => extra.push((name, values)),
        }
    }
    if found_rgb.contains(&false) {
        return Err(E::format(path, "the EXR has no R, G and B channels"));
    }
    Ok((img, extra, meta))
}

/// [`merge`] of parts with extra channels: each channel is merged as R, G and B are (by sample
/// count), and every part must hold the same channel names.
pub fn merge_with(
    parts: &[(RgbImage, ExtraChannels, PartialMeta)],
    names: &[String],
) -> Result<(RgbImage, ExtraChannels, PartialMeta)> {
    let label = |i: usize| {
        names
            .get(i)
            .cloned()
            .unwrap_or_else(|| format!("input {i}"))
    };
    let channel_names = |p: &ExtraChannels| p.iter().map(|c| c.0.clone()).collect::<Vec<_>>();
    let first: Vec<String> = parts
        .first()
        .map(|p| channel_names(&p.1))
        .unwrap_or_default();
    for (i, p) in parts.iter().enumerate() {
        if channel_names(&p.1) != first {
            return Err(Error::Invalid(format!(
                "{}: extra channels {:?} differ from {}'s {:?}; parts of one render hold the same channels",
                label(i),
                channel_names(&p.1),
                label(0),
                first
            )));
        }
    }
    let rgb: Vec<(RgbImage, PartialMeta)> = parts.iter().map(|p| (p.0.clone(), p.2)).collect();
    let (img, meta) = merge(&rgb, names)?;
    // The extra channels three at a time, through the same merge as the image.
    let mut extra: ExtraChannels = first.iter().map(|n| (n.clone(), Vec::new())).collect();
    for group in (0..first.len()).collect::<Vec<_>>().chunks(3) {
        let packed: Vec<(RgbImage, PartialMeta)> = parts
            .iter()
            .map(|(im, ch, m)| {
                let mut g = RgbImage::new(im.width, im.height);
                for (c, &k) in group.iter().enumerate() {
                    for (i, &v) in ch[k].1.iter().enumerate() {
                        g.data[i * 3 + c] = v;
                    }
                }
                (g, *m)
            })
            .collect();
        let (g, _) = merge(&packed, names)?;
        for (c, &k) in group.iter().enumerate() {
            extra[k].1 = (0..g.width * g.height).map(|i| g.data[i * 3 + c]).collect();
        }
    }
    Ok((img, extra, meta))
}

/// Combines partial renders of one film and seed into one (see the module docs). Every pixel of
/// the inputs' bounding window must be covered by disjoint sample ranges whose union is the
/// same contiguous range for all pixels. `names` label the inputs in error messages.
pub fn merge(
    parts: &[(RgbImage, PartialMeta)],
    names: &[String],
) -> Result<(RgbImage, PartialMeta)> {
    let first = parts
        .first()
        .ok_or_else(|| Error::Invalid("merge needs at least one input".into()))?
        .1;
    let name = |i: usize| {
        names
            .get(i)
            .cloned()
            .unwrap_or_else(|| format!("input {i}"))
    };
    for (i, (_, m)) in parts.iter().enumerate() {
        if m.scene != first.scene {
            return Err(Error::Invalid(format!(
                "{}: rendered from another scene or with other options than {} (scene \
                 fingerprint {:016x} vs {:016x}: the scene file, a file it reads (mesh, \
                 texture, BTF data or model), -D defines or --btf-model differ); merging them \
                 would mix two images",
                name(i),
                name(0),
                m.scene,
                first.scene
            )));
        }
        if (m.width, m.height, m.seed) != (first.width, first.height, first.seed) {
            return Err(Error::Invalid(format!(
                "{}: film {}×{} seed {} differs from {} (film {}×{} seed {})",
                name(i),
                m.width,
                m.height,
                m.seed,
                name(0),
                first.width,
                first.height,
                first.seed
            )));
        }
    }
    let x0 = parts.iter().map(|p| p.1.crop[0]).min().unwrap_or(0);
    let y0 = parts.iter().map(|p| p.1.crop[1]).min().unwrap_or(0);
    let x1 = parts
        .iter()
        .map(|p| p.1.crop[0] + p.1.crop[2])
        .max()
        .unwrap_or(0);
    let y1 = parts
        .iter()
        .map(|p| p.1.crop[1] + p.1.crop[3])
        .max()
        .unwrap_or(0);
    let (w, h) = (x1 - x0, y1 - y0);
    let mut out = RgbImage::new(w as usize, h as usize);
    let mut range: Option<(u32, u32)> = None;
    let mut cover: Vec<(u32, u32, usize)> = Vec::with_capacity(parts.len());
    for y in y0..y1 {
        for x in x0..x1 {
            cover.clear();
            for (i, (_, m)) in parts.iter().enumerate() {
                let [cx, cy, cw, ch] = m.crop;
                if x >= cx && x < cx + cw && y >= cy && y < cy + ch {
                    cover.push((m.spp_begin, m.spp_end, i));
                }
            }
            if cover.is_empty() {
                return Err(Error::Invalid(format!(
                    "pixel ({x}, {y}) lies in the merged window {x0},{y0},{w},{h} but no input covers it"
                )));
            }
            cover.sort_unstable();
            for pair in cover.windows(2) {
                if pair[1].0 < pair[0].1 {
                    return Err(Error::Invalid(format!(
                        "{} and {} both contain samples {}..{} of pixel ({x}, {y}); overlapping sample ranges would count samples twice",
                        name(pair[0].2),
                        name(pair[1].2),
                        pair[1].0,
                        pair[0].1.min(pair[1].1)
                    )));
                }
                if pair[1].0 > pair[0].1 {
                    return Err(Error::Invalid(format!(
                        "pixel ({x}, {y}) misses samples {}..{} between {} and {}",
                        pair[0].1,
                        pair[1].0,
                        name(pair[0].2),
                        name(pair[1].2)
                    )));
                }
            }
            let r = (cover[0].0, cover[cover.len() - 1].1);
            match range {
                None => range = Some(r),
                Some(q) if q != r => {
                    return Err(Error::Invalid(format!(
                        "pixel ({x}, {y}) has samples {}..{} but others have {}..{}; the merged image would mix sample counts",
                        r.0, r.1, q.0, q.1
                    )));
                }
                _ => {}
            }
            let mut acc = [0f64; 3];
            for &(b, e, i) in &cover {
                let (img, m) = &parts[i];
                let v = img.get((x - m.crop[0]) as usize, (y - m.crop[1]) as usize);
                let n = (e - b) as f64;
                for c in 0..3 {
                    acc[c] += v[c] as f64 * n;
                }
            }
            let n = (r.1 - r.0) as f64;
            out.set(
                (x - x0) as usize,
                (y - y0) as usize,
                acc.map(|a| (a / n) as f32),
            );
        }
    }
    let (spp_begin, spp_end) = range.unwrap_or((0, 1));
    Ok((
        out,
        PartialMeta {
            width: first.width,
            height: first.height,
            crop: [x0, y0, w, h],
            spp_begin,
            spp_end,
            seed: first.seed,
            scene: first.scene,
            whole: first.whole,
        },
    ))
}

/// What a merged part lacks of its whole render: None if it covers the whole window (or the
/// inputs did not record it), else a sentence naming the window covered and the whole one.
pub fn missing_parts(meta: &PartialMeta) -> Option<String> {
    let whole = meta.whole?;
    if whole == meta.crop {
        return None;
    }
    let [x, y, w, h] = meta.crop;
    let [wx, wy, ww, wh] = whole;
    Some(format!(
        "the merged image covers window {x},{y},{w}×{h} (rows {y}..{}) of the render's window \
         {wx},{wy},{ww}×{wh} (rows {wy}..{}): bands or tiles are missing, and the output holds \
         only the part given",
        y + h,
        wy + wh
    ))
}
