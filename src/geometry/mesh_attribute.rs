//! Mesh attributes: per-vertex or per-face values a mesh file carries besides positions,
//! normals and uv (vertex colours, face weights), named and grouped as Mitsuba 3.9.1's PLY
//! loader names them (`vertex_color`, `face_weight`, ...), and their value at a hit, as
//! Mitsuba's `Mesh::eval_attribute` interpolates them.

use crate::math::{Spectrum, Vec2};

/// One attribute of a mesh: `dim` values per vertex (`vertex_*`) or per triangle (`face_*`).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    /// Mitsuba's name: `vertex_` or `face_` and the field prefix (`vertex_color`, ...).
    pub name: String,
    /// Values per vertex or triangle (1 to 4).
    pub dim: usize,
    /// `dim` values per vertex or per triangle, in the mesh's order.
    pub data: Vec<f32>,
}

impl MeshAttribute {
    /// True for a per-vertex attribute (interpolated over the triangle), false for per-face.
    pub fn per_vertex(&self) -> bool {
        self.name.starts_with("vertex_")
    }

    /// The attribute on triangle `prim` with vertices `tri` at barycentrics `b` = (b1, b2), as
    /// Mitsuba evaluates it as a colour: 1 value is grey, 3 are RGB, any other count is black
    /// (Mitsuba's `eval_attribute`). Per-face values are constant over the triangle.
    pub fn eval(&self, prim: u32, tri: [u32; 3], b: Vec2) -> Spectrum {
        let d = self.dim;
        let at = |i: u32| {
            let o = i as usize * d;
            match self.data.get(o..o + d) {
                Some(v) if d == 1 => Spectrum::splat(v[0]),
                Some(v) => Spectrum::new(v[0], v[1], v[2]),
                None => Spectrum::ZERO,
            }
        };
        if d != 1 && d != 3 {
            return Spectrum::ZERO;
        }
        if !self.per_vertex() {
            return at(prim);
        }
        // Mitsuba's blend: fmadd(a0, b0, fmadd(a1, b1, a2 · b2)), b0 = 1 − b1 − b2.
        let b0 = 1.0 - b.x - b.y;
        let (a0, a1, a2) = (at(tri[0]), at(tri[1]), at(tri[2]));
        a0 * b0 + (a1 * b.x + a2 * b.y)
    }
}

/// Which of an element's fields form which attribute, by Mitsuba 3.9.1's rules (its PLY
/// loader's `find_other_fields`): `r`, `g`, `b` (and `a`; or `red`, `green`, `blue`, `alpha`)
/// make `<kind>color`; other fields named `prefix_c` with one-character postfixes that run
/// through one of the sequences x y z w, r g b a, 0 1 2 3 or 1 2 3 4, contiguous, make
/// `<kind>prefix` (with `_color` appended for r g b), of 1 or 3 fields; anything else is
/// ignored, as Mitsuba ignores it (with a warning). `kind` is `vertex_` or `face_`; `reserved`
/// are the fields the mesh itself uses. Returns (name, field indices) in attribute order.
pub fn group_fields(kind: &str, names: &[&str], reserved: &[&str]) -> Vec<(String, Vec<usize>)> {
    let find = |n: &str| names.iter().position(|m| *m == n);
    let mut out = Vec::new();
    let rgb = match (find("r"), find("g"), find("b")) {
        (Some(r), Some(g), Some(b)) => Some(([r, g, b], find("a"))),
        _ => match (find("red"), find("green"), find("blue")) {
            (Some(r), Some(g), Some(b)) => Some(([r, g, b], find("alpha"))),
            _ => None,
        },
    };
    let mut colour_fields = Vec::new();
    if let Some((rgb, a)) = rgb {
        colour_fields.extend(rgb);
        colour_fields.extend(a);
        out.push((format!("{kind}color"), colour_fields.clone()));
    }
    const POSTFIXES: [&[u8; 4]; 4] = [b"xr01", b"yg12", b"zb23", b"wa34"];
    let skip = |i: usize| {
        let n = names[i];
        reserved.contains(&n) || ["r", "g", "b", "a"].contains(&n) || colour_fields.contains(&i)
    };
    let split = |n: &str| {
        let pos = n.rfind('_')?;
        let post = &n[pos + 1..];
        (post.len() == 1).then(|| (n[..pos].to_string(), post.as_bytes()[0]))
    };
    let mut seen: Vec<String> = Vec::new();
    let mut i = 0;
    while i < names.len() {
        if skip(i) {
            i += 1;
            continue;
        }
        let Some((prefix, c)) = split(names[i]) else {
            i += 1;
            continue;
        };
        let Some(category) = POSTFIXES[0].iter().position(|&p| p == c) else {
            i += 1;
            continue;
        };
        if seen.contains(&prefix) {
            i += 1;
            continue;
        }
        // The contiguous run of fields continuing this prefix's postfix sequence.
        let mut fields = vec![i];
        let mut j = i + 1;
        while j < names.len() && fields.len() < 4 && !skip(j) {
            match split(names[j]) {
                Some((p, c)) if p == prefix && c == POSTFIXES[fields.len()][category] => {
                    fields.push(j);
                    j += 1;
                }
                _ => break,
            }
        }
        seen.push(prefix.clone());
        if fields.len() == 1 || fields.len() == 3 {
            let colour = if category == 1 { "_color" } else { "" };
            out.push((format!("{kind}{prefix}{colour}"), fields));
        }
        i = j;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_grouped_as_mitsuba_groups_them() {
        let names = [
            "x", "y", "z", "nx", "ny", "nz", "u", "v", "color_0", "color_1", "color_2",
        ];
        let reserved = ["x", "y", "z", "nx", "ny", "nz", "u", "v"];
        assert_eq!(
            group_fields("vertex_", &names, &reserved),
            [("vertex_color".to_string(), vec![8, 9, 10])]
        );
        let face = ["color_0", "color_1", "color_2", "weight_0"];
        assert_eq!(
            group_fields("face_", &face, &[]),
            [
                ("face_color".to_string(), vec![0, 1, 2]),
                ("face_weight".to_string(), vec![3])
            ]
        );
        // Plain r, g, b; an r/g/b postfix adds _color; two fields or no postfix are ignored.
        let v = [
            "red", "green", "blue", "albedo_r", "albedo_g", "albedo_b", "uv2_x", "uv2_y", "foo",
        ];
        assert_eq!(
            group_fields("vertex_", &v, &[]),
            [
                ("vertex_color".to_string(), vec![0, 1, 2]),
                ("vertex_albedo_color".to_string(), vec![3, 4, 5])
            ]
        );
    }

    #[test]
    fn vertex_attributes_interpolate_and_face_attributes_are_constant() {
        let a = MeshAttribute {
            name: "vertex_color".into(),
            dim: 3,
            data: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        };
        let c = a.eval(0, [0, 1, 2], Vec2::new(0.25, 0.5));
        assert_eq!(c, Spectrum::new(0.25, 0.25, 0.5));
        let f = MeshAttribute {
            name: "face_weight".into(),
            dim: 1,
            data: vec![0.1, 0.7],
        };
        assert_eq!(
            f.eval(1, [0, 1, 2], Vec2::new(0.3, 0.3)),
            Spectrum::splat(0.7)
        );
        let four = MeshAttribute {
            name: "vertex_color".into(),
            dim: 4,
            data: vec![1.0; 12],
        };
        assert_eq!(four.eval(0, [0, 1, 2], Vec2::ZERO), Spectrum::ZERO);
    }
}
