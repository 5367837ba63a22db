//! Feature-image selection for PLM-C clustering: greedily pick the images whose value histograms
//! are most different (symmetric Kullback–Leibler distance) from those already chosen.

/// Histogram bins per image (on √(value / max), so dark images are not collapsed into one bin).
pub const BINS: usize = 64;
/// Probability floor that keeps the KL divergence finite for empty bins.
const EPS: f64 = 1e-6;

/// Normalised histograms of `images` (each a slice of one image's values; values below 0 count
/// as 0). All images share the bin edges so histograms are comparable.
pub fn histograms(images: &[&[f32]]) -> Vec<[f64; BINS]> {
    let max = images
        .iter()
        .flat_map(|im| im.iter())
        .copied()
        .fold(0.0f32, f32::max);
    images
        .iter()
        .map(|im| {
            let mut h = [0.0f64; BINS];
            for &v in im.iter() {
                let t = if max > 0.0 {
                    (v.max(0.0) / max).sqrt()
                } else {
                    0.0
                };
                let b = ((t * BINS as f32) as usize).min(BINS - 1);
                h[b] += 1.0;
            }
            let total = im.len().max(1) as f64;
            for x in h.iter_mut() {
                *x = (*x / total).max(EPS);
            }
            let s: f64 = h.iter().sum();
            h.iter_mut().for_each(|x| *x /= s);
            h
        })
        .collect()
}

/// Symmetric Kullback–Leibler distance D(p‖q) + D(q‖p) between two smoothed histograms.
pub fn kl_symmetric(p: &[f64; BINS], q: &[f64; BINS]) -> f64 {
    p.iter().zip(q).map(|(&a, &b)| (a - b) * (a / b).ln()).sum()
}

/// Chooses `count` image indices: first the image with the most informative (highest entropy)
/// histogram, then repeatedly the image whose smallest KL distance to the chosen ones is largest.
/// Deterministic (ties go to the lower index); returns all images if `count ≥ images`.
pub fn select_images(images: &[&[f32]], count: usize) -> Vec<usize> {
    let n = images.len();
    if count >= n {
        return (0..n).collect();
    }
    if count == 0 {
        return Vec::new();
    }
    let h = histograms(images);
    let entropy = |p: &[f64; BINS]| -p.iter().map(|&x| x * x.ln()).sum::<f64>();
    let mut first = 0;
    for i in 1..n {
        if entropy(&h[i]) > entropy(&h[first]) {
            first = i;
        }
    }
    let mut chosen = vec![first];
    let mut min_dist: Vec<f64> = (0..n).map(|i| kl_symmetric(&h[i], &h[first])).collect();
    min_dist[first] = f64::NEG_INFINITY;
    while chosen.len() < count {
        let mut best = usize::MAX;
        for i in 0..n {
            if min_dist[i] > f64::NEG_INFINITY
                && (best == usize::MAX || min_dist[i] > min_dist[best])
            {
                best = i;
            }
        }
        chosen.push(best);
        min_dist[best] = f64::NEG_INFINITY;
        for i in 0..n {
            if min_dist[i] > f64::NEG_INFINITY {
                min_dist[i] = min_dist[i].min(kl_symmetric(&h[i], &h[best]));
            }
        }
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_distinct_images_before_duplicates() {
        // Three families of images; duplicates within a family have identical histograms.
        let dark: Vec<f32> = (0..100).map(|i| i as f32 * 0.001).collect();
        let mid: Vec<f32> = (0..100).map(|i| 0.3 + i as f32 * 0.002).collect();
        let bright: Vec<f32> = (0..100).map(|i| 0.8 + i as f32 * 0.002).collect();
        let images: Vec<&[f32]> = vec![&dark, &dark, &mid, &dark, &mid, &bright, &bright];
        let s = select_images(&images, 3);
        let fam = |i: usize| [0, 0, 1, 0, 1, 2, 2][i];
        let mut f: Vec<i32> = s.iter().map(|&i| fam(i)).collect();
        f.sort();
        assert_eq!(f, vec![0, 1, 2]);
        assert_eq!(select_images(&images, 3), s);
        assert_eq!(select_images(&images, 10), (0..7).collect::<Vec<_>>());
    }

    #[test]
    fn constant_images_are_handled() {
        let z = vec![0.0f32; 16];
        let images: Vec<&[f32]> = vec![&z; 5];
        let s = select_images(&images, 2);
        assert_eq!(s.len(), 2);
        assert_ne!(s[0], s[1]);
    }
}
