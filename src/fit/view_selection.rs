//! Which views a fit process works on (`btfpt fit --views`), so one fit is split over machines:
//! each fits a subset into the shared parts directory and a final run assembles them.

use crate::{Error, Result};
use std::ops::Range;

/// A sorted set of non-overlapping, non-empty view index ranges, all within the view count.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ViewSelection {
    ranges: Vec<Range<usize>>,
}

impl ViewSelection {
    /// Every view of a BTF with `count` views.
    pub fn all(count: usize) -> Self {
        ViewSelection {
            ranges: std::iter::once(0..count)
                .filter(|r| !r.is_empty())
                .collect(),
        }
    }

    /// Parses `--views` for a BTF with `count` views: `A..B` (views A to B-1), `A` (one view), a
    /// comma-separated list of those (sorted or not, never overlapping), or `I/N` (part I of N
    /// equal consecutive ranges, 0-based, for job arrays that do not know the view count).
    pub fn parse(spec: &str, count: usize) -> Result<Self> {
        let bad = |msg: String| Error::Invalid(format!("--views '{spec}': {msg}"));
        let num = |s: &str, what: &str| -> Result<usize> {
            let t = s.trim();
            if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) {
                return Err(bad(format!("{what} '{t}' is not a non-negative integer")));
            }
            t.parse::<usize>()
                .map_err(|_| bad(format!("{what} '{t}' is too large")))
        };
        if let Some((i, n)) = spec.split_once('/') {
            let (i, n) = (num(i, "part")?, num(n, "part count")?);
            if n == 0 || i >= n {
                return Err(bad(format!("part {i} of {n}: the part must be in 0..{n}")));
            }
            if n > count {
                return Err(bad(format!("{n} parts but the BTF has only {count} views")));
            }
            let at = |k: usize| count * k / n;
            return Ok(ViewSelection {
                ranges: std::iter::once(at(i)..at(i + 1)).collect(),
            });
        }
        let mut ranges = Vec::new();
        for item in spec.split(',') {
            let r = match item.split_once("..") {
                Some((a, b)) => num(a, "start")?..num(b, "end")?,
                None => {
                    let v = num(item, "view")?;
                    v..v + 1
                }
            };
            if r.start >= r.end {
                return Err(bad(format!(
                    "{}..{} is empty (A..B fits views A to B-1)",
                    r.start, r.end
                )));
            }
            if r.end > count {
                return Err(bad(format!(
                    "{}..{} goes beyond the {count} views (0..{count})",
                    r.start, r.end
                )));
            }
            ranges.push(r);
        }
        ranges.sort_by_key(|r| r.start);
        for w in ranges.windows(2) {
            if w[1].start < w[0].end {
                return Err(bad(format!(
                    "{}..{} and {}..{} overlap",
                    w[0].start, w[0].end, w[1].start, w[1].end
                )));
            }
        }
        Ok(ViewSelection { ranges })
    }

    /// Whether view `v` is selected.
    pub fn contains(&self, v: usize) -> bool {
        self.ranges.iter().any(|r| r.contains(&v))
    }

    /// Number of selected views.
    pub fn len(&self) -> usize {
        self.ranges.iter().map(|r| r.len()).sum()
    }

    /// Whether no view is selected.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether every one of `count` views is selected.
    pub fn is_all(&self, count: usize) -> bool {
        self.len() == count
    }
}

/// Views as compact ranges for messages: `[0, 1, 2, 5, 7, 8]` → "0..3, 5, 7..9".
pub fn describe(views: &[usize]) -> String {
    let mut out = Vec::new();
    let mut i = 0;
    while i < views.len() {
        let mut j = i;
        while j + 1 < views.len() && views[j + 1] == views[j] + 1 {
            j += 1;
        }
        out.push(if i == j {
            views[i].to_string()
        } else {
            format!("{}..{}", views[i], views[j] + 1)
        });
        i = j + 1;
    }
    out.join(", ")
}

impl std::fmt::Display for ViewSelection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v: Vec<usize> = self.ranges.iter().flat_map(|r| r.clone()).collect();
        f.write_str(&describe(&v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_lists_and_parts_parse() {
        let s = ViewSelection::parse("0..27", 81).unwrap();
        assert_eq!((s.len(), s.contains(26), s.contains(27)), (27, true, false));
        let s = ViewSelection::parse("40..81, 3,10..12", 81).unwrap();
        assert_eq!(s.to_string(), "3, 10..12, 40..81");
        assert_eq!(s.len(), 44);
        // Parts of 81 views in 4: 20, 20, 20, 21 views, covering every view once.
        let parts: Vec<_> = (0..4)
            .map(|i| ViewSelection::parse(&format!("{i}/4"), 81).unwrap())
            .collect();
        assert_eq!(
            parts.iter().map(|p| p.to_string()).collect::<Vec<_>>(),
            ["0..20", "20..40", "40..60", "60..81"]
        );
        for v in 0..81 {
            assert_eq!(parts.iter().filter(|p| p.contains(v)).count(), 1);
        }
        assert!(ViewSelection::parse("0..81", 81).unwrap().is_all(81));
        assert!(ViewSelection::all(81).is_all(81));
    }

    #[test]
    fn malformed_overlapping_and_out_of_range_views_are_refused() {
        for (spec, msg) in [
            ("", "not a non-negative integer"),
            ("a..b", "start 'a'"),
            ("-1..4", "start '-1'"),
            ("5..3", "empty"),
            ("4..4", "empty"),
            ("0..82", "beyond the 81 views"),
            ("81", "beyond"),
            ("0..10,5..15", "0..10 and 5..15 overlap"),
            ("3,3", "overlap"),
            ("1..2..3", "end '2..3'"),
            ("4/4", "must be in 0..4"),
            ("0/0", "must be in 0..0"),
            ("0/82", "only 81 views"),
            ("x/2", "part 'x'"),
            ("99999999999999999999999..1", "too large"),
        ] {
            let e = ViewSelection::parse(spec, 81).unwrap_err().to_string();
            assert!(
                e.contains("--views") && e.contains(msg),
                "'{spec}': {e} (expected '{msg}')"
            );
        }
    }

    #[test]
    fn describe_compacts_runs() {
        assert_eq!(describe(&[0, 1, 2, 5, 7, 8]), "0..3, 5, 7..9");
        assert_eq!(describe(&[]), "");
    }
}
