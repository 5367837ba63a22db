//! Mitsuba `<transform>` blocks (the affine helpers themselves live in [`crate::math::transform`]).
//!
//! Operations compose in document order, each new one pre-multiplied (M = T_new · M), exactly as
//! Mitsuba's XML parser does.

use super::document::XmlDoc;
use crate::Result;
use crate::math::transform::{is_finite, look_at};
use crate::math::{Mat3, Mat4, Vec3};
use roxmltree::Node;

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
