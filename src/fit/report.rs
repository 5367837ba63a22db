//! Error measures of a reconstruction against the measured data, as in the paper's Table 1:
//! MAE on values normalised to [0, 1] in the data's stored encoding (8-bit sRGB: code/255),
//! averaged per view then over views, plus linear-space MAE and the stored-encoding RMSE.

use crate::btf::StoredEncoding;

/// Error sums of one view (one model).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewError {
    /// Mean absolute error in the stored encoding.
    pub mae: f64,
    /// Mean absolute error of the linear values.
    pub mae_linear: f64,
    /// Mean squared error in the stored encoding.
    pub mse: f64,
}

/// Errors of `recon` against `orig` (same layout, linear values).
pub fn view_error(orig: &[f32], recon: &[f32], enc: StoredEncoding) -> ViewError {
    let (mut a, mut l, mut s) = (0.0f64, 0.0f64, 0.0f64);
    for (&o, &r) in orig.iter().zip(recon) {
        let d = (enc.encode(o) - enc.encode(r)) as f64;
        a += d.abs();
        s += d * d;
        l += (o - r).abs() as f64;
    }
    let n = orig.len().max(1) as f64;
    ViewError {
        mae: a / n,
        mae_linear: l / n,
        mse: s / n,
    }
}

/// Summary of one model over all views.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ModelReport {
    /// MAE in the stored encoding, mean over views of the per-view MAE.
    pub mae: f64,
    /// Linear-space MAE, mean over views.
    pub mae_linear: f64,
    /// Stored-encoding RMSE over all values.
    pub rmse: f64,
    /// Size of the model file in bytes.
    pub bytes: usize,
    /// Raw size / model size.
    pub ratio: f64,
    /// Stored-encoding MAE of every view.
    pub per_view_mae: Vec<f64>,
}

impl ModelReport {
    /// Aggregates per-view errors (equal texel counts per view, so the RMSE is a plain mean).
    pub fn from_views(views: &[ViewError], bytes: usize, raw_bytes: usize) -> Self {
        let n = views.len().max(1) as f64;
        ModelReport {
            mae: views.iter().map(|v| v.mae).sum::<f64>() / n,
            mae_linear: views.iter().map(|v| v.mae_linear).sum::<f64>() / n,
            rmse: (views.iter().map(|v| v.mse).sum::<f64>() / n).sqrt(),
            bytes,
            ratio: raw_bytes as f64 / bytes.max(1) as f64,
            per_view_mae: views.iter().map(|v| v.mae).collect(),
        }
    }
}

/// Raw size the paper compares with: 8-bit RGB per texel per image.
pub fn raw_bytes(views: usize, lights: usize, texels: usize) -> usize {
    views * lights * texels * 3
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::color::linear_to_srgb;

    #[test]
    fn errors_in_both_spaces() {
        let o = [0.0f32, 0.5, 1.0, 0.2];
        let e = view_error(&o, &o, StoredEncoding::Srgb8);
        assert_eq!(e, ViewError::default());
        let r = [0.1f32, 0.5, 2.0, 0.2];
        let e = view_error(&o, &r, StoredEncoding::Linear);
        assert!((e.mae - 1.1 / 4.0).abs() < 1e-7 && e.mae == e.mae_linear);
        let s = view_error(&o, &r, StoredEncoding::Srgb8);
        // 2.0 clamps to 1.0 in sRGB: only the first value differs there.
        assert!((s.mae - linear_to_srgb(0.1) as f64 / 4.0).abs() < 1e-7);
        let m = ModelReport::from_views(&[s, e], 10, 1000);
        assert_eq!(m.ratio, 100.0);
        assert_eq!(m.per_view_mae.len(), 2);
    }
}
