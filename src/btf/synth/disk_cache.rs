//! Generated `synth:` materials kept between processes as `.btfc` files in the user's cache
//! folder, one per canonical source, so a scene (or `info`, `fit`, `eval`) pays the measurement
//! simulator once. Entries are written atomically (a render running at the same time reads the
//! old file or the new one, never half of one) and checked like any `.btfc` (every view's CRC, and
//! that the size and directions are the source's): a corrupt or mismatching entry is
//! regenerated and replaced, never trusted.

use super::SynthSpec;
use crate::btf::{BtfSource, RawBtf, cache};
use crate::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Environment variable naming the cache folder (overrides the default; tests set it).
pub const CACHE_DIR_ENV: &str = "BTFPT_CACHE_DIR";

/// Revision of the simulator's output: part of every entry's name, raised whenever a change to
/// `btf::synth` changes the values a source generates, so stale entries are never read.
const GENERATOR_REVISION: u32 = 1;

/// The folder for cached `synth:` materials: `$BTFPT_CACHE_DIR` if set, else
/// `$XDG_CACHE_HOME/btfpt`, else `~/.cache/btfpt`; None when none of these is known.
pub fn default_cache_dir() -> Option<PathBuf> {
    let var = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(d) = var(CACHE_DIR_ENV) {
        return Some(d);
    }
    if let Some(d) = var("XDG_CACHE_HOME").filter(|d| d.is_absolute()) {
        return Some(d.join("btfpt"));
    }
    var("HOME").map(|h| h.join(".cache").join("btfpt"))
}

/// The file holding `spec`'s material in the cache folder `dir`: every key in the name, so two
/// sources never share an entry.
pub fn entry_path(dir: &Path, spec: &SynthSpec) -> PathBuf {
    dir.join(format!(
        "synth-{}-{}x{}-seed{}-strata{}-subdiv{}-{}-r{GENERATOR_REVISION}.btfc",
        spec.material.name(),
        spec.width,
        spec.height,
        spec.seed,
        spec.strata,
        spec.subdiv,
        spec.directions
    ))
}

/// Where a `synth:` material came from, for the summaries that print it.
#[derive(Clone, Debug, PartialEq)]
pub enum SynthOrigin {
    /// Read from this cache entry.
    Cached(PathBuf),
    /// Generated in `seconds` and written to this cache entry (`replaced`: a corrupt or
    /// mismatching entry was there, the reason given).
    Generated {
        seconds: f64,
        entry: PathBuf,
        replaced: Option<String>,
    },
    /// Generated in `seconds` and kept in memory only: no cache folder, or it could not be
    /// written (the reason given).
    Uncached { seconds: f64, reason: String },
}

impl std::fmt::Display for SynthOrigin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SynthOrigin::Cached(p) => write!(f, "read from the cache {}", p.display()),
            SynthOrigin::Generated {
                seconds,
                entry,
                replaced,
            } => {
                write!(
                    f,
                    "generated in {seconds:.1} s, cached as {}",
                    entry.display()
                )?;
                if let Some(r) = replaced {
                    write!(f, " (replacing an entry that {r})")?;
                }
                Ok(())
            }
            SynthOrigin::Uncached { seconds, reason } => {
                write!(f, "generated in {seconds:.1} s, not cached ({reason})")
            }
        }
    }
}

/// Checks that a cache entry holds `spec`'s material (size and direction sets).
fn matches(btf: &RawBtf, spec: &SynthSpec) -> std::result::Result<(), String> {
    let dirs = spec.settings().views;
    let same = |a: &crate::btf::DirectionSet| {
        a.len() == dirs.len()
            && a.angles_deg
                .iter()
                .zip(&dirs.angles_deg)
                .all(|(x, y)| (x.0 - y.0).abs() < 1e-3 && (x.1 - y.1).abs() < 1e-3)
    };
    if (btf.width(), btf.height()) != (spec.width, spec.height)
        || !same(btf.views())
        || !same(btf.lights())
    {
        return Err(format!(
            "holds {}×{} texels, {} × {} directions instead",
            btf.width(),
            btf.height(),
            btf.views().len(),
            btf.lights().len()
        ));
    }
    Ok(())
}

/// `spec`'s material: read from the cache folder `dir` when a valid entry is there, else
/// generated (on the current rayon pool) and written there atomically. `dir` None generates
/// in memory only. The folder is created if missing (it is the user's cache, not an output).
pub fn load_or_generate(spec: &SynthSpec, dir: Option<&Path>) -> Result<(RawBtf, SynthOrigin)> {
    let Some(dir) = dir else {
        let t0 = Instant::now();
        let raw = spec.generate()?;
        let seconds = t0.elapsed().as_secs_f64();
        let reason = format!("no cache folder: set {CACHE_DIR_ENV}, XDG_CACHE_HOME or HOME");
        return Ok((raw, SynthOrigin::Uncached { seconds, reason }));
    };
    let entry = entry_path(dir, spec);
    let mut replaced = None;
    if entry.exists() {
        match cache::load_cache(&entry)
            .map_err(|e| format!("is corrupt: {e}"))
            .and_then(|b| {
                matches(&b, spec)?;
                Ok(b)
            }) {
            Ok(b) => return Ok((b, SynthOrigin::Cached(entry))),
            Err(e) => replaced = Some(e),
        }
    }
    let t0 = Instant::now();
    let raw = spec.generate()?;
    let seconds = t0.elapsed().as_secs_f64();
    let written = std::fs::create_dir_all(dir)
        .map_err(|e| Error::io(dir, e))
        .and_then(|()| cache::write_raw(&raw, &entry));
    Ok(match written {
        Ok(()) => (
            raw,
            SynthOrigin::Generated {
                seconds,
                entry,
                replaced,
            },
        ),
        Err(e) => (
            raw,
            SynthOrigin::Uncached {
                seconds,
                reason: format!("cannot write the cache: {e}"),
            },
        ),
    })
}

/// The file to read for a BTF that a command or a Python call names (`info`, `fit`, `eval
/// --against`, `btfpt.fit`, `btfpt.Btf.open`, ...): `input` itself, or for a `synth:` source its
/// entry in the cache folder `dir` (generated and written first when missing or corrupt) with a
/// note saying where the material came from. A source that cannot be cached is an error naming
/// `input`, since these callers read files.
pub fn resolve_input(input: &Path, dir: Option<&Path>) -> Result<(PathBuf, Option<String>)> {
    let Some(spec) = input.to_str().and_then(SynthSpec::parse) else {
        return Ok((input.to_path_buf(), None));
    };
    let spec = spec?;
    let Some(dir) = dir else {
        return Err(Error::Invalid(format!(
            "{}: a synth: source is read through the cache folder, and none is known: set \
             {CACHE_DIR_ENV} (or XDG_CACHE_HOME or HOME)",
            input.display()
        )));
    };
    let (_, origin) = load_or_generate(&spec, Some(dir))
        .map_err(|e| Error::Invalid(format!("generating {}: {e}", input.display())))?;
    let note = format!("{}: {origin}", spec.canonical());
    match origin {
        SynthOrigin::Cached(p) | SynthOrigin::Generated { entry: p, .. } => Ok((p, Some(note))),
        SynthOrigin::Uncached { reason, .. } => {
            Err(Error::Invalid(format!("{}: {reason}", input.display())))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> SynthSpec {
        SynthSpec::parse("synth:leather?size=2&seed=3&strata=1&subdiv=1")
            .unwrap()
            .unwrap()
    }

    #[test]
    fn entries_are_written_once_read_back_and_corrupt_ones_regenerated() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("cache");
        let (a, origin) = load_or_generate(&spec(), Some(&d)).unwrap();
        let SynthOrigin::Generated {
            entry,
            replaced: None,
            ..
        } = origin
        else {
            panic!("{origin}");
        };
        assert_eq!(entry, entry_path(&d, &spec()));
        let (b, origin) = load_or_generate(&spec(), Some(&d)).unwrap();
        assert_eq!(origin, SynthOrigin::Cached(entry.clone()));
        assert_eq!(a.data(), b.data());
        drop(b);
        // One flipped payload byte: regenerated, replaced, and the same values again.
        let mut bytes = std::fs::read(&entry).unwrap();
        let n = bytes.len();
        bytes[n - 200] ^= 0x40;
        std::fs::write(&entry, &bytes).unwrap();
        let (c, origin) = load_or_generate(&spec(), Some(&d)).unwrap();
        assert!(
            matches!(&origin, SynthOrigin::Generated { replaced: Some(r), .. } if r.contains("checksum")),
            "{origin}"
        );
        assert_eq!(a.data(), c.data());
        drop(c);
        // An entry of another size under this name is not trusted either.
        let other = SynthSpec::parse("synth:leather?size=3&seed=3&strata=1&subdiv=1")
            .unwrap()
            .unwrap();
        std::fs::copy(entry_path(&d, &spec()), entry_path(&d, &other)).unwrap();
        let (e, origin) = load_or_generate(&other, Some(&d)).unwrap();
        assert_eq!(e.width(), 3);
        assert!(origin.to_string().contains("replacing"), "{origin}");
        // Nothing but the entries is left in the folder (no temporary files).
        let names: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
    }

    #[test]
    fn inputs_resolve_to_their_cache_entry_or_themselves() {
        let dir = tempfile::tempdir().unwrap();
        let src = "synth:leather?size=2&seed=3&strata=1&subdiv=1";
        let (p, note) = resolve_input(Path::new(src), Some(dir.path())).unwrap();
        assert_eq!(p, entry_path(dir.path(), &spec()));
        assert!(note.unwrap().contains("generated"));
        let (_, note) = resolve_input(Path::new(src), Some(dir.path())).unwrap();
        assert!(note.unwrap().contains("read from the cache"));
        let (p, note) = resolve_input(Path::new("some/folder"), None).unwrap();
        assert_eq!((p, note), (PathBuf::from("some/folder"), None));
        let e = resolve_input(Path::new(src), None).unwrap_err().to_string();
        assert!(e.contains("none is known"), "{e}");
        let e = resolve_input(Path::new("synth:velvet"), Some(dir.path()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("velvet"), "{e}");
        let e = resolve_input(Path::new(src), Some(Path::new("/proc/btfpt-cache")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("cannot write the cache"), "{e}");
    }

    #[test]
    fn an_unwritable_cache_folder_still_gives_the_material() {
        let (raw, origin) =
            load_or_generate(&spec(), Some(Path::new("/proc/btfpt-cache"))).unwrap();
        assert_eq!(raw.width(), 2);
        assert!(matches!(origin, SynthOrigin::Uncached { .. }), "{origin}");
        let (_, origin) = load_or_generate(&spec(), None).unwrap();
        assert!(origin.to_string().contains("not cached"), "{origin}");
    }
}
