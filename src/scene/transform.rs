//! Mitsuba `<transform>` blocks and the affine helpers the loaders share.
//!
//! Operations compose in document order, each new one pre-multiplied (M = T_new · M), exactly as
//! Mitsuba's XML parser does.

use super::props::XmlDoc;
use crate::Result;
use crate::math::{Frame, Mat3, Mat4, Vec3};
use glam::Vec4;
use roxmltree::Node;

/// Mitsuba's `lookat`: camera space +z toward `target`, +y ≈ `up`, +x = up × dir ("left").
/// A zero `up` picks one perpendicular to the view direction, as Mitsuba does.
pub fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let dir = (target - origin).normalize();
    let up = if up.length_squared() == 0.0 {
        Frame::from_normal(dir).s
    } else {
        up
    };
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    )
}

/// True if every entry is finite.
pub fn is_finite(m: &Mat4) -> bool {
    m.to_cols_array().iter().all(|v| v.is_finite())
}

/// The matrix that transforms normals: inverse transpose of the linear part (None if singular).
pub fn normal_matrix(m: &Mat4) -> Option<Mat3> {
    let l = Mat3::from_mat4(*m);
    let det = l.determinant();
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    Some(l.inverse().transpose())
}

/// Parses the operations inside a `<transform>` element.
pub(crate) fn parse_transform(x: &XmlDoc, node: Node) -> Result<Mat4> {
    let mut m = Mat4::IDENTITY;
    for op in node.children() {
        if !op.is_element() {
            continue;
        }
        let t = match op.tag_name().name() {
            "translate" => {
                x.check_attrs(op, &["x", "y", "z", "value"])?;
                Mat4::from_translation(x.parse_xyz(op, 0.0)?)
            }
            "scale" => {
                x.check_attrs(op, &["x", "y", "z", "value"])?;
                Mat4::from_scale(x.parse_xyz(op, 1.0)?)
            }
            "rotate" => {
                x.check_attrs(op, &["x", "y", "z", "value", "angle"])?;
                let axis = x.parse_xyz(op, 0.0)?;
                let angle = x.parse_f32(op, x.req_attr(op, "angle")?)?;
                if axis.length_squared() == 0.0 {
                    return Err(x.err(op, "<rotate> needs a non-zero axis (x/y/z or value)"));
                }
                Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "matrix" => {
                x.check_attrs(op, &["value"])?;
                let v = x.parse_list(op, x.req_attr(op, "value")?)?;
                match v.len() {
                    16 => {
                        let mut a = [0.0f32; 16];
                        a.copy_from_slice(&v);
                        // The XML lists the matrix row by row; glam is column-major.
                        Mat4::from_cols_array(&a).transpose()
                    }
                    9 => {
                        let mut a = [0.0f32; 9];
                        a.copy_from_slice(&v);
                        Mat4::from_mat3(Mat3::from_cols_array(&a).transpose())
                    }
                    n => return Err(x.err(op, format!("<matrix> expects 16 or 9 values, got {n}"))),
                }
            }
            "lookat" => {
                x.check_attrs(op, &["origin", "target", "up"])?;
                let origin = x.parse_vec3_attr(op, "origin")?;
                let target = x.parse_vec3_attr(op, "target")?;
                let up = if x.attr(op, "up").is_some() {
                    x.parse_vec3_attr(op, "up")?
                } else {
                    Vec3::ZERO
                };
                let r = look_at(origin, target, up);
                if !is_finite(&r) {
                    return Err(x.err(
                        op,
                        "invalid lookat transformation (origin equals target, or up is parallel to the view direction)",
                    ));
                }
                r
            }
            other => {
                return Err(x.err(
                    op,
                    format!("<{other}> cannot occur in a <transform> (expected translate, rotate, scale, matrix, lookat)"),
                ));
            }
        };
        m = t * m;
        if !is_finite(&m) {
            return Err(x.err(op, "transform contains NaN or infinite values"));
        }
    }
    if let Some(t) = node
        .children()
        .find(|c| c.is_text() && !c.text().unwrap_or("").trim().is_empty())
    {
        return Err(x.err(t, "unexpected text inside <transform>"));
    }
    Ok(m)
}

/// Applies `m` to a point.
#[inline]
pub fn xf_point(m: &Mat4, p: Vec3) -> Vec3 {
    let r = *m * Vec4::new(p.x, p.y, p.z, 1.0);
    if r.w == 1.0 {
        r.truncate()
    } else {
        r.truncate() / r.w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookat_matches_mitsuba_convention() {
        let m = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
        // looks along -z world; camera +x ("left") = up × dir = Y × (-Z) = -X
        assert!((m.col(2).truncate() - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        assert!((m.col(0).truncate() - Vec3::new(-1.0, 0.0, 0.0)).length() < 1e-6);
        assert!((m.col(1).truncate() - Vec3::Y).length() < 1e-6);
        assert!((xf_point(&m, Vec3::ZERO) - Vec3::new(0.0, 0.0, 5.0)).length() < 1e-6);
    }

    #[test]
    fn normal_matrix_handles_nonuniform_scale() {
        let m = Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0));
        let n = normal_matrix(&m).unwrap() * Vec3::new(1.0, 1.0, 0.0);
        // The plane x/2 + y = const has normal (0.5, 1, 0) after scaling
        assert!((n.normalize() - Vec3::new(0.5, 1.0, 0.0).normalize()).length() < 1e-6);
        assert!(normal_matrix(&Mat4::from_scale(Vec3::new(0.0, 1.0, 1.0))).is_none());
    }
}
