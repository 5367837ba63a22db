//! Affine helpers every loader and the renderer share: Mitsuba's `lookat`, normal matrices,
//! point transforms with a projective divide, finiteness checks.

use super::{Frame, Mat3, Mat4, Vec3};
use glam::Vec4;

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
