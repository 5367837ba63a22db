//! A deterministic synthetic BTF source, `synth:MATERIAL?key=value&...`: a material of the
//! measurement simulator named like a file, so scenes and every command that reads a BTF can use
//! one without measured data. Keys (all optional, defaults equal to `btfpt synth`'s): `size` (N or
//! WxH texels, 64), `seed` (1), `strata` (sub-texel samples per axis, 2), `subdiv` (height-field
//! cells per texel axis, 4), `directions` (ubo2003 | ubo2014, ubo2003).
//! `synth:corduroy?size=32&seed=1` holds exactly the values that
//! `btfpt synth corduroy --size 32 --seed 1 --format exr -o DIR` writes.

use super::{MaterialKind, SynthSettings, measure};
use crate::btf::{DirectionSet, RawBtf};
use crate::{Error, Result};

/// A deterministic synthetic BTF source, `synth:MATERIAL?key=value&...` (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct SynthSpec {
    /// Procedural material.
    pub material: MaterialKind,
    /// Texels per row.
    pub width: usize,
    /// Rows of texels.
    pub height: usize,
    /// Seed of the material's noise and of the simulator's sampling.
    pub seed: u64,
    /// Stratified sub-texel samples per axis.
    pub strata: usize,
    /// Height-field cells per texel axis.
    pub subdiv: usize,
    /// Direction set name for views and lights: "ubo2003" or "ubo2014".
    pub directions: &'static str,
}

/// Largest texel count per axis of a `synth:` source (a 256² material is 2.6 GB in memory).
const SYNTH_MAX_SIZE: usize = 256;

impl SynthSpec {
    /// The prefix that marks a synthetic source in a `filename`.
    pub const PREFIX: &'static str = "synth:";

    /// `None` if `value` is not a `synth:` source; otherwise the parsed spec or an error naming
    /// the source and the problem.
    pub fn parse(value: &str) -> Option<Result<Self>> {
        let body = value.trim().strip_prefix(Self::PREFIX)?;
        Some(Self::parse_body(value, body))
    }

    fn parse_body(value: &str, body: &str) -> Result<Self> {
        let err = |msg: String| Error::Invalid(format!("\"{value}\": {msg}"));
        let (name, query) = body.split_once('?').unwrap_or((body, ""));
        let material = MaterialKind::from_name(name.trim()).map_err(|e| err(e.to_string()))?;
        let mut spec = SynthSpec {
            material,
            width: 64,
            height: 64,
            seed: 1,
            strata: 2,
            subdiv: 4,
            directions: "ubo2003",
        };
        for pair in query.split('&').filter(|p| !p.trim().is_empty()) {
            let Some((k, v)) = pair.split_once('=') else {
                return Err(err(format!("\"{pair}\" is not key=value")));
            };
            let (k, v) = (k.trim(), v.trim());
            let int = |lo: usize, hi: usize| -> Result<usize> {
                v.parse::<usize>()
                    .ok()
                    .filter(|n| (lo..=hi).contains(n))
                    .ok_or_else(|| err(format!("{k}={v} is not an integer in {lo}..={hi}")))
            };
            match k {
                "size" => {
                    let (w, h) = match v.split_once(['x', 'X']) {
                        Some((w, h)) => (w.trim(), h.trim()),
                        None => (v, v),
                    };
                    let dim = |s: &str| {
                        s.parse::<usize>()
                            .ok()
                            .filter(|n| (1..=SYNTH_MAX_SIZE).contains(n))
                            .ok_or_else(|| {
                                err(format!(
                                    "size={v} is not N or WxH with 1 ≤ N ≤ {SYNTH_MAX_SIZE}"
                                ))
                            })
                    };
                    spec.width = dim(w)?;
                    spec.height = dim(h)?;
                }
                "seed" => {
                    spec.seed = v
                        .parse()
                        .map_err(|_| err(format!("seed={v} is not an unsigned integer")))?;
                }
                "strata" => spec.strata = int(1, 16)?,
                "subdiv" => spec.subdiv = int(1, 16)?,
                "directions" => {
                    spec.directions = match v.to_ascii_lowercase().as_str() {
                        "ubo2003" => "ubo2003",
                        "ubo2014" => "ubo2014",
                        _ => {
                            return Err(err(format!(
                                "directions={v} is unknown (expected ubo2003 or ubo2014)"
                            )));
                        }
                    }
                }
                _ => {
                    return Err(err(format!(
                        "unknown key \"{k}\" (known: size, seed, strata, subdiv, directions)"
                    )));
                }
            }
        }
        Ok(spec)
    }

    /// A canonical form of the source (all keys, fixed order): the cache key.
    pub fn canonical(&self) -> String {
        format!(
            "synth:{}?size={}x{}&seed={}&strata={}&subdiv={}&directions={}",
            self.material.name(),
            self.width,
            self.height,
            self.seed,
            self.strata,
            self.subdiv,
            self.directions
        )
    }

    /// The measurement settings `btfpt synth` uses for this spec (one clamped bounce).
    pub fn settings(&self) -> SynthSettings {
        let dirs = if self.directions == "ubo2014" {
            DirectionSet::ubo2014()
        } else {
            DirectionSet::ubo2003()
        };
        SynthSettings {
            views: dirs.clone(),
            lights: dirs,
            strata: self.strata,
            seed: self.seed,
            interreflection: true,
            indirect_clamp: 1.0,
            progress: false,
        }
    }

    /// Builds the micro-surface and measures it (on the current rayon pool; deterministic).
    pub fn generate(&self) -> Result<RawBtf> {
        let surface = self
            .material
            .build(self.width, self.height, self.subdiv, self.seed)
            .map_err(|e| Error::Invalid(format!("{}: {e}", self.canonical())))?;
        measure(&surface, &self.settings())
            .map_err(|e| Error::Invalid(format!("{}: {e}", self.canonical())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synth_specs_parse_with_cli_defaults_and_reject_bad_keys() {
        assert!(SynthSpec::parse("data/corduroy").is_none());
        let s = SynthSpec::parse("synth:corduroy").unwrap().unwrap();
        assert_eq!(
            (s.material, s.width, s.height, s.seed, s.strata, s.subdiv),
            (MaterialKind::Corduroy, 64, 64, 1, 2, 4)
        );
        let s =
            SynthSpec::parse("synth:Wool?size=16x8&seed=7&strata=1&subdiv=2&directions=UBO2014")
                .unwrap()
                .unwrap();
        assert_eq!(
            (s.material, s.width, s.height, s.seed, s.strata, s.subdiv),
            (MaterialKind::Wool, 16, 8, 7, 1, 2)
        );
        assert_eq!(s.settings().lights.len(), 151);
        assert_eq!(
            s.canonical(),
            "synth:wool?size=16x8&seed=7&strata=1&subdiv=2&directions=ubo2014"
        );
        assert_eq!(
            SynthSpec::parse(&s.canonical()).unwrap().unwrap(),
            s,
            "the canonical form parses back"
        );
        for (bad, what) in [
            ("synth:velvet", "velvet"),
            ("synth:wool?size=0", "size=0"),
            ("synth:wool?size=300", "size=300"),
            ("synth:wool?size=8y8", "size=8y8"),
            ("synth:wool?seed=-1", "seed=-1"),
            ("synth:wool?strata=0", "strata=0"),
            ("synth:wool?colour=red", "colour"),
            ("synth:wool?size", "\"size\""),
            ("synth:wool?directions=ubo1999", "ubo1999"),
        ] {
            let e = SynthSpec::parse(bad).unwrap().unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains(what), "{bad}: {e}");
        }
    }
}
