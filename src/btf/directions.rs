//! Measurement direction sets (UBO2003, UBO2014, arbitrary lists) in the local shading frame.

use crate::math::Vec3;
use crate::math::frame::from_spherical;

/// An ordered list of measured directions on the upper hemisphere (index order = file order).
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionSet {
    /// (θ, φ) in degrees, as named in the data files.
    pub angles_deg: Vec<(f32, f32)>,
    /// Unit vectors of `angles_deg` (z = normal, φ from s toward t).
    pub dirs: Vec<Vec3>,
}

impl DirectionSet {
    /// A set from (θ, φ) pairs in degrees.
    pub fn from_angles_deg(angles_deg: Vec<(f32, f32)>) -> Self {
        let dirs = angles_deg
            .iter()
            .map(|&(t, p)| from_spherical(t.to_radians(), p.to_radians()))
            .collect();
        DirectionSet { angles_deg, dirs }
    }

    /// Rings of constant θ with evenly spaced azimuths: (θ°, count, φ offset°) per ring.
    pub fn from_rings(rings: &[(f32, usize, f32)]) -> Self {
        let mut angles = Vec::new();
        for &(theta, n, offset) in rings {
            for k in 0..n {
                angles.push((theta, offset + 360.0 * k as f32 / n as f32));
            }
        }
        Self::from_angles_deg(angles)
    }

    /// The 81 directions of the Bonn UBO2003 database, in index order (DESIGN §3).
    pub fn ubo2003() -> Self {
        Self::from_rings(&[
            (0.0, 1, 0.0),
            (15.0, 6, 0.0),
            (30.0, 12, 0.0),
            (45.0, 18, 0.0),
            (60.0, 20, 0.0),
            (75.0, 24, 0.0),
        ])
    }

    /// The 151 directions of the Bonn UBO2014 database.
    pub fn ubo2014() -> Self {
        Self::from_rings(&[
            (0.0, 1, 0.0),
            (11.0, 6, 15.0),
            (23.5, 12, 0.0),
            (30.0, 12, 15.0),
            (37.5, 12, 0.0),
            (45.0, 18, 0.0),
            (52.5, 18, 7.5),
            (60.0, 24, 0.0),
            (67.5, 24, 7.5),
            (75.0, 24, 0.0),
        ])
    }

    /// Number of directions.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// True if the set has no directions.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_sets_have_the_documented_sizes_and_order() {
        let s = DirectionSet::ubo2003();
        assert_eq!(s.len(), 81);
        assert_eq!(s.angles_deg[0], (0.0, 0.0));
        assert_eq!(s.angles_deg[2], (15.0, 60.0));
        assert_eq!(s.angles_deg[80], (75.0, 345.0));
        assert_eq!(DirectionSet::ubo2014().len(), 151);
        assert_eq!(DirectionSet::ubo2014().angles_deg[1], (11.0, 15.0));
    }
}
