//! PLM's per-image mapping Ỹ = Σ_{j=0..4} a_j Y^j of a model value Y, and its quantised stored
//! form (Bernstein coefficients; see [`PackedPoly`]).

/// Polynomial coefficients a_0..a_4 of Ỹ = Σ a_j Y^j.
pub type Poly = [f32; 5];

/// The identity mapping (used for plain LM models).
pub const IDENTITY: Poly = [0.0, 1.0, 0.0, 0.0, 0.0];

/// Evaluates Σ a_j y^j (Horner); the caller clamps negative results if it needs reflectances.
#[inline]
pub fn eval(a: &Poly, y: f32) -> f32 {
    (((a[4] * y + a[3]) * y + a[2]) * y + a[1]) * y + a[0]
}

/// Domain exponents the quantised encoding covers: D = 2^e.
pub const E_RANGE: std::ops::RangeInclusive<i32> = -40..=40;
/// Largest |q_k| of the quantised Bernstein coefficients.
pub const Q_MAX: f64 = 32767.0;

/// A mapping as a version-2 `.plmc` file stores it (12 bytes instead of 20): its Bernstein
/// coefficients on the domain [0, 2^e], c_k = q_k · 2^s. The Bernstein basis is non-negative and
/// sums to 1, so quantising c_k by ≤ 2^(s−1) changes the mapping by at most that on the domain
/// (the power basis has no such bound: its coefficients cancel).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PackedPoly {
    /// Domain exponent: the mapping is encoded on [0, 2^e].
    pub e: i8,
    /// Step exponent of the coefficients.
    pub s: i8,
    /// Quantised Bernstein coefficients.
    pub q: [i16; 5],
}

/// Bernstein coefficients of `a` on [0, 2^e] (f64; b_j = a_j·2^(e·j) is exact).
fn bernstein(a: &Poly, e: i32) -> [f64; 5] {
    // c_k = Σ_{j≤k} C(k,j)/C(4,j) · b_j
    const M: [[f64; 5]; 5] = [
        [1.0, 0.0, 0.0, 0.0, 0.0],
        [1.0, 0.25, 0.0, 0.0, 0.0],
        [1.0, 0.5, 1.0 / 6.0, 0.0, 0.0],
        [1.0, 0.75, 0.5, 0.25, 0.0],
        [1.0, 1.0, 1.0, 1.0, 1.0],
    ];
    let d = (e as f64).exp2();
    let b: [f64; 5] = std::array::from_fn(|j| a[j] as f64 * d.powi(j as i32));
    std::array::from_fn(|k| (0..=k).map(|j| M[k][j] * b[j]).sum())
}

/// The power-basis mapping a packed polynomial stands for (None if it does not fit in f32).
pub fn decode(p: &PackedPoly) -> Option<Poly> {
    // b_j = Σ_{k≤j} (−1)^(j−k) C(4,j) C(j,k) c_k
    const M: [[f64; 5]; 5] = [
        [1.0, 0.0, 0.0, 0.0, 0.0],
        [-4.0, 4.0, 0.0, 0.0, 0.0],
        [6.0, -12.0, 6.0, 0.0, 0.0],
        [-4.0, 12.0, -12.0, 4.0, 0.0],
        [1.0, -4.0, 6.0, -4.0, 1.0],
    ];
    let step = (p.s as f64).exp2();
    let inv_d = (-(p.e as f64)).exp2();
    let a: Poly = std::array::from_fn(|j| {
        let b: f64 = (0..=j).map(|k| M[j][k] * p.q[k] as f64).sum::<f64>() * step;
        (b * inv_d.powi(j as i32)) as f32
    });
    a.iter().all(|v| v.is_finite()).then_some(a)
}

/// Quantises `a` on the domain [0, 2^e] with the step exponent `s` (None if out of range).
pub fn quantise(a: &Poly, e: i32, s: Option<i32>) -> Option<PackedPoly> {
    let c = bernstein(a, e);
    let big = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !big.is_finite() {
        return None;
    }
    let s = s.unwrap_or(if big == 0.0 {
        0
    } else {
        (big / Q_MAX).log2().ceil() as i32
    });
    let step = (s as f64).exp2();
    let q = c.map(|v| (v / step).round());
    if !(-128..=127).contains(&s) || q.iter().any(|v| v.abs() > Q_MAX) {
        return None;
    }
    Some(PackedPoly {
        e: i8::try_from(e).ok()?,
        s: s as i8,
        q: q.map(|v| v as i16),
    })
}

/// The packed form that decodes to exactly `a` (bit for bit), if there is one: true for every
/// mapping the fitter snapped to this form; other coefficients are stored as f32.
pub fn encode(a: &Poly) -> Option<PackedPoly> {
    let exact = |p: PackedPoly| {
        decode(&p).is_some_and(|d| d.iter().zip(a).all(|(x, y)| x.to_bits() == y.to_bits()))
    };
    // Domains near 1 first (sRGB and reflectance values), then outwards.
    let es = (0..=*E_RANGE.end())
        .flat_map(|i| [i, -i - 1])
        .filter(|e| E_RANGE.contains(e));
    for e in es {
        let Some(p) = quantise(a, e, None) else {
            continue;
        };
        if exact(p) {
            return Some(p);
        }
        // A coefficient rounded to the edge of the step range can pick the neighbouring step.
        for s in [p.s as i32 - 1, p.s as i32 + 1] {
            if let Some(p) = quantise(a, e, Some(s))
                && exact(p)
            {
                return Some(p);
            }
        }
    }
    None
}
