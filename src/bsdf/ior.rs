//! Indices of refraction as a scene gives them: a number or one of Mitsuba's named materials.

use crate::Result;
use crate::plugin::Properties;

/// Mitsuba's named IOR table (`ior.h`).
pub const IOR_TABLE: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.00028),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// The IOR property `name`, a float or one of Mitsuba's named materials (`default` if absent).
pub fn ior(p: &dyn Properties, name: &str, default: &str) -> Result<f32> {
    let lookup = |s: &str| {
        let l = s.to_ascii_lowercase();
        IOR_TABLE
            .iter()
            .find(|(n, _)| *n == l)
            .map(|(_, v)| *v)
            .ok_or_else(|| p.err(&format!("unknown IOR material \"{s}\" for \"{name}\"")))
    };
    match p.float_or_string(name)? {
        None => lookup(default),
        Some(Ok(v)) => Ok(v),
        Some(Err(s)) => lookup(&s),
    }
}
