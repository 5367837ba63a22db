//! Which fitted model a `.plmc` file holds (and which one a scene asks for).

/// Which model a file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ModelKind {
    /// Per-texel one-lobe Lafortune, per view.
    Lm,
    /// LM plus a degree-4 polynomial per (view, light, channel).
    Plm,
    /// Clustered PLM: per view and channel a table of K lobes and an index image.
    PlmC,
}

impl ModelKind {
    /// The code stored in the file header.
    pub fn code(self) -> u8 {
        match self {
            ModelKind::Lm => 0,
            ModelKind::Plm => 1,
            ModelKind::PlmC => 2,
        }
    }
    /// Inverse of [`ModelKind::code`].
    pub fn from_code(c: u8) -> Option<Self> {
        match c {
            0 => Some(ModelKind::Lm),
            1 => Some(ModelKind::Plm),
            2 => Some(ModelKind::PlmC),
            _ => None,
        }
    }
    /// Lower-case name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Lm => "lm",
            ModelKind::Plm => "plm",
            ModelKind::PlmC => "plmc",
        }
    }
    /// True if the model carries per-image polynomials.
    pub fn has_polys(self) -> bool {
        self != ModelKind::Lm
    }
}
