//! A fitted model in its evaluation layout: SoA lobe records, index planes, polynomial rows, the
//! range clamps, the direction interpolators and the light sampler.

use super::lobes::{
    HIT_LOBES, HitLobes, MIN_EXPONENT, MIN_SHARP_SHARE, lobe_albedo, selection_weight, srgb_decode,
};
use crate::bsdf::btf_sampler::BtfLightSampler;
use crate::btf::directions::DirectionInterp;
use crate::math::color::luminance;
use crate::math::simd::{self, Isa};
use crate::math::{Spectrum, Vec3};
use crate::model::{ModelKind, PlmcModel, ValueSpace, ViewParams, codec};
use crate::{Error, Result};
use std::path::Path;
use std::sync::Arc;

/// One lobe record `[ρ, Dx, Dy, Dz, n, 0, 0, 0]`, 32-byte aligned.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct LobeRec(pub [f32; 8]);

/// Polynomial coefficients of one (view, light), coefficient-major: `[a_j of R, G, B]` for
/// j = 0..4 then one pad. `a_j` of the 3 channels is the 4-lane window starting at `3 j` (its pad
/// lane reads the next coefficient, harmless: that lane is discarded).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub struct PolyRow(pub [f32; 16]);

/// How the per-texel lobes are stored.
pub(super) enum Params {
    /// PLM-C, ≤ 256 clusters: records `[view][channel][k]`, index `[texel][view][R, G, B, pad]`
    /// (the 3 views of one evaluation are a few hundred bytes apart: one or two cache lines).
    Clustered8 {
        k: usize,
        records: Vec<LobeRec>,
        index: Vec<[u8; 4]>,
    },
    /// PLM-C with more than 256 clusters: u16 indices.
    Clustered16 {
        k: usize,
        records: Vec<LobeRec>,
        index: Vec<[u16; 4]>,
    },
    /// LM / PLM: one lobe per texel and channel, `[view][texel][channel]` as `[ρ, Dx, Dy, Dz, n]`.
    Texel { lobes: Vec<[f32; 5]> },
}

/// A fitted model in its evaluation layout, with direction interpolators and sampling tables;
/// shared (`Arc`) by every [`PlmcBsdf`] that uses the same file.
pub struct PlmcMaterial {
    pub(super) kind: ModelKind,
    pub(super) space: ValueSpace,
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) n_views: usize,
    pub(super) n_lights: usize,
    pub(super) params: Params,
    /// `[view][light]`; empty for LM.
    pub(super) polys: Vec<PolyRow>,
    /// `[view]` (R, G, B, 0): the largest lobe value Y over the measured lights (and the clusters /
    /// sampled texels). The polynomials were fitted on Y in this range; Y is clamped to it before
    /// the polynomial, which a degree-4 mapping would otherwise extrapolate wildly at unmeasured
    /// light directions near a sharp lobe's peak.
    pub(super) y_max: Vec<[f32; 4]>,
    /// `[view][light]`: the largest polynomial output (model space) per channel over the
    /// clusters / sampled texels at that measured (view, light). Between measured lights the
    /// output is clamped to the largest bound of the 3 lights: a guard against ill-conditioned
    /// fitted polynomials (|a_j| up to 1e38 occur) that are harmless at the measured directions
    /// but explode for lobe values in between; values at measured directions are unchanged.
    pub(super) out_max: Vec<[f32; 4]>,
    /// The measured views' interpolator.
    pub(super) views: DirectionInterp,
    /// Light sampling tables built from the model's texel-mean values, and the light
    /// interpolator they are built on.
    pub(super) sampler: BtfLightSampler,
    /// Per view: true if some lobe of it is sharp enough to be sampled (`lobes.rs`); hits whose
    /// 3 views have none skip gathering their lobes.
    pub(super) sharp_views: Vec<bool>,
    /// The instruction set the kernels run at (`simd::isa()`): AVX2 + FMA runs the generic
    /// kernel's AVX2 build, AVX-512 also the 16-lane kernels of `avx512.rs` and `batch.rs` for
    /// PLM-C with u8 indices and the nearest texel; every build returns the same bits.
    pub(super) isa: Isa,
}

impl PlmcMaterial {
    /// Builds the evaluation layout, interpolators and sampling tables of a validated model.
    pub fn new(model: &PlmcModel) -> Result<Self> {
        model.validate()?;
        let (nv, nl) = (model.views.len(), model.lights.len());
        let texels = model.width * model.height;
        let rec = |l: [f32; 5]| LobeRec([l[0], l[1], l[2], l[3], l[4], 0.0, 0.0, 0.0]);
        let params = match model.kind {
            ModelKind::PlmC => {
                let k = model.clusters.max(1);
                let mut records = vec![LobeRec::default(); nv * 3 * k];
                // The final index when k > 256, on huge pages (see `huge_vec`).
                let mut idx16 = huge_vec(nv * texels, std::iter::repeat_n([0u16; 4], nv * texels));
                for (v, p) in model.params.iter().enumerate() {
                    let ViewParams::Clustered {
                        k: kv,
                        table,
                        index,
                    } = p
                    else {
                        return Err(Error::Invalid(format!(
                            "PLM-C model: view {v} has per-texel lobes"
                        )));
                    };
                    for j in 0..*kv {
                        for c in 0..3 {
                            records[(v * 3 + c) * k + j] = rec(table[3 * j + c].unpack());
                        }
                    }
                    for t in 0..texels {
                        let d = &mut idx16[t * nv + v];
                        d[..3].copy_from_slice(&index[3 * t..3 * t + 3]);
                    }
                }
                if k <= 256 {
                    let index = huge_vec(
                        idx16.len(),
                        idx16
                            .iter()
                            .map(|q| [q[0] as u8, q[1] as u8, q[2] as u8, 0]),
                    );
                    Params::Clustered8 { k, records, index }
                } else {
                    Params::Clustered16 {
                        k,
                        records,
                        index: idx16,
                    }
                }
            }
            ModelKind::Lm | ModelKind::Plm => {
                let mut lobes = Vec::with_capacity(nv * texels * 3);
                advise_huge(&lobes, nv * texels * 3);
                for (v, p) in model.params.iter().enumerate() {
                    let ViewParams::Texel(l) = p else {
                        return Err(Error::Invalid(format!(
                            "{} model: view {v} is clustered",
                            model.kind.name()
                        )));
                    };
                    lobes.extend(l.iter().map(|p| p.unpack()));
                }
                Params::Texel { lobes }
            }
        };
        let polys = if model.kind.has_polys() {
            let mut rows = vec![PolyRow::default(); nv * nl];
            for v in 0..nv {
                for l in 0..nl {
                    for c in 0..3 {
                        let a = model.poly(v, l, c);
                        for j in 0..5 {
                            rows[v * nl + l].0[3 * j + c] = a[j];
                        }
                    }
                }
            }
            rows
        } else {
            Vec::new()
        };
        let (means, y_max, out_max) = super::tables::mean_values(model);
        let y_max = y_max.iter().map(|m| [m[0], m[1], m[2], 0.0]).collect();
        let views = model
            .views
            .interpolator()
            .map_err(|e| Error::Invalid(format!("model view directions: {e}")))?;
        let lights = model
            .lights
            .interpolator()
            .map_err(|e| Error::Invalid(format!("model light directions: {e}")))?;
        let lum: Vec<f32> = means
            .chunks_exact(3)
            .map(|c| luminance(Spectrum::new(c[0], c[1], c[2])))
            .collect();
        let sampler = BtfLightSampler::new(lights, &model.lights.dirs, &lum);
        let mut material = PlmcMaterial {
            kind: model.kind,
            space: model.space,
            width: model.width,
            height: model.height,
            n_views: nv,
            n_lights: nl,
            params,
            polys,
            y_max,
            out_max,
            views,
            sampler,
            sharp_views: Vec::new(),
            isa: simd::isa(),
        };
        // What sampling a hit's own lobes (`lobes.rs`) needs of the layout.
        material.store_lobe_albedos(&model.lights.dirs);
        material.sharp_views = material.find_sharp_views();
        Ok(material)
    }

    /// The same material evaluated by the baseline SSE2 kernel even on an AVX2+FMA CPU (to
    /// compare the two builds; results agree to float rounding).
    #[cfg(any(test, feature = "test-support"))]
    pub fn without_avx2(mut self) -> Self {
        self.isa = Isa::PORTABLE;
        self
    }

    /// The same material without the AVX-512 kernel (the generic kernel's AVX2+FMA build where
    /// the CPU has it): to compare the builds; results agree to float rounding.
    #[cfg(any(test, feature = "test-support"))]
    pub fn without_avx512(mut self) -> Self {
        self.isa = self.isa.at_most(simd::Level::Avx2);
        self
    }

    /// True if evaluations run the AVX2+FMA build of the kernel.
    #[cfg(test)]
    pub fn uses_avx2(&self) -> bool {
        self.isa.level() >= simd::Level::Avx2
    }

    /// True if PLM-C evaluations (u8 indices, nearest texel) run the AVX-512 kernel.
    #[cfg(test)]
    pub fn uses_avx512(&self) -> bool {
        self.isa.level() == simd::Level::Avx512 && matches!(self.params, Params::Clustered8 { .. })
    }

    /// Reads a `.plmc` file and builds the material; errors name the file.
    pub fn load(path: &Path) -> Result<Self> {
        let model = codec::read(path)?;
        Self::new(&model).map_err(|e| Error::format(path, e.to_string()))
    }

    /// The model kind.
    pub fn kind(&self) -> ModelKind {
        self.kind
    }

    /// Texels per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows of texels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Starts loading the index entries of `texel` (all views: a few cache lines) into the
    /// cache, without waiting; a no-op for per-texel models, whose views are far apart.
    #[inline]
    pub fn prefetch_texel(&self, texel: usize) {
        let nv = self.n_views;
        let (ptr, bytes) = match &self.params {
            Params::Clustered8 { index, .. } => match index.get(texel * nv..(texel + 1) * nv) {
                Some(s) => (s.as_ptr() as usize, std::mem::size_of_val(s)),
                None => return,
            },
            Params::Clustered16 { index, .. } => match index.get(texel * nv..(texel + 1) * nv) {
                Some(s) => (s.as_ptr() as usize, std::mem::size_of_val(s)),
                None => return,
            },
            Params::Texel { .. } => return,
        };
        if bytes == 0 {
            return;
        }
        for line in (ptr & !63..ptr + bytes).step_by(64) {
            prefetch_line(line);
        }
    }

    /// Where the index planes lie, for prefetches that skip the dispatch on the layout per call
    /// (no entries for per-texel models).
    #[inline]
    pub(super) fn index_span(&self) -> IndexSpan {
        let (base, entry, entries) = match &self.params {
            Params::Clustered8 { index, .. } => (index.as_ptr() as usize, 4, index.len()),
            Params::Clustered16 { index, .. } => (index.as_ptr() as usize, 8, index.len()),
            Params::Texel { .. } => (0, 0, 0),
        };
        IndexSpan {
            base,
            entry,
            entries,
            views: self.n_views,
        }
    }

    /// Starts loading the index entries of `texel` for the views `vi` (one to three cache lines,
    /// what an evaluation at that texel reads) without waiting; a no-op for per-texel models
    /// and for out-of-range texels or views.
    #[inline]
    pub fn prefetch_views(&self, texel: usize, vi: [u32; 3]) {
        self.index_span().prefetch_views(texel, vi);
    }

    /// Interpolation indices and weights of the 3 measured views around `wi` (local frame).
    #[inline]
    pub fn view_lookup(&self, wi: Vec3) -> ([u32; 3], [f32; 3]) {
        self.views.lookup(wi)
    }

    /// Interpolation indices and weights of the 3 measured lights around `wo` (local frame).
    #[inline]
    pub fn light_lookup(&self, wo: Vec3) -> ([u32; 3], [f32; 3]) {
        self.sampler.light_interp().lookup(wo)
    }
}

/// The index planes' address range ([`PlmcMaterial::index_span`]): entry i of the `views` ×
/// texels entries is `entry` bytes at `base + i · entry`.
#[derive(Clone, Copy, Debug)]
pub(super) struct IndexSpan {
    base: usize,
    entry: usize,
    entries: usize,
    views: usize,
}

impl IndexSpan {
    /// [`PlmcMaterial::prefetch_views`]: the entries of `texel` for the views `vi`, skipping
    /// out-of-range texels and views.
    #[inline(always)]
    pub fn prefetch_views(&self, texel: usize, vi: [u32; 3]) {
        for v in vi {
            if (v as usize) < self.views
                && let Some(i) = texel
                    .checked_mul(self.views)
                    .and_then(|i| i.checked_add(v as usize))
                && i < self.entries
            {
                prefetch_line(self.base + i * self.entry);
            }
        }
    }
}

/// Starts loading the cache line of `addr` (a hint: never faults).
#[inline(always)]
fn prefetch_line(addr: usize) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(addr as *const i8)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = addr;
}

/// `items` (`len` of them) in a vector whose memory the kernel is asked, before it is first
/// touched, to back with transparent huge pages (2 MB on x86_64 Linux, `MADV_HUGEPAGE`; only a
/// hint, a no-op where THP is off or on other systems). For the index planes and per-texel
/// lobes (tens to hundreds of MB read at random texels): with 4 KB pages nearly every texel
/// misses the TLB, and its page walk (two-dimensional under virtualisation) stalls the index
/// prefetch of `PlmcBsdf::prepare` and the kernels' first loads.
pub(super) fn huge_vec<T>(len: usize, items: impl Iterator<Item = T>) -> Vec<T> {
    let mut v = Vec::with_capacity(len);
    advise_huge(&v, len);
    v.extend(items);
    debug_assert_eq!(v.len(), len);
    v
}

/// Asks for transparent huge pages on the 2 MB-aligned part of the first `len` elements of
/// `v`'s allocation (see [`huge_vec`]); call before the memory is first written.
fn advise_huge<T>(v: &Vec<T>, len: usize) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let bytes = len.min(v.capacity()) * std::mem::size_of::<T>();
        let start = v.as_ptr() as usize;
        let (a, b) = (start.next_multiple_of(HUGE), (start + bytes) / HUGE * HUGE);
        if b > a {
            // SAFETY: [a, b) lies inside the vector's allocation (a and b are page aligned);
            // madvise changes only how the kernel backs those pages, never their contents or
            // the mapping. Its result is ignored: it is a hint.
            unsafe { libc::madvise(a as *mut libc::c_void, b - a, libc::MADV_HUGEPAGE) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (v, len);
}

/// Summary only: the tables can be large.
/// The pad slot of a cluster record (`LobeRec`, `[ρ, Dx, Dy, Dz, n, pad…]`) that holds the
/// lobe's albedo after the mapping.
pub(super) const ALBEDO_SLOT: usize = 5;

impl PlmcMaterial {
    /// Writes [`lobe_albedo`] into slot [`ALBEDO_SLOT`] of every cluster record (a pad slot the
    /// kernels do not read, on the cache line the lobe's parameters are read from): the lobe
    /// value at its peak clamped and mapped as the kernel does, by the polynomial of the
    /// measured light nearest to the lobe's axis (`light_dirs`), then decoded. Per-texel
    /// models have no pad: their albedos are estimated per hit, without the mapping.
    pub(super) fn store_lobe_albedos(&mut self, light_dirs: &[Vec3]) {
        let albedo = self.cluster_lobe_albedos(light_dirs);
        if let Params::Clustered8 { records, .. } | Params::Clustered16 { records, .. } =
            &mut self.params
        {
            for (r, a) in records.iter_mut().zip(albedo) {
                r.0[ALBEDO_SLOT] = a;
            }
        }
    }

    /// Per view: whether its lobes of exponent at least [`MIN_EXPONENT`] (the only ones
    /// [`HitLobes`] keeps) carry at least [`MIN_SHARP_SHARE`] of the view's albedo summed over
    /// texels and channels (luminance-weighted, as the selection is).
    pub(super) fn find_sharp_views(&self) -> Vec<bool> {
        let nv = self.n_views;
        let mut sharp = vec![0f64; nv];
        let mut all = vec![0f64; nv];
        let mut add = |v: usize, c: usize, l: &[f32], albedo: f32| {
            let a = f64::from(selection_weight(1.0, c, albedo));
            if a > 0.0 && a < f64::INFINITY {
                all[v] += a;
                if l[0] > 0.0 && l[4] >= MIN_EXPONENT {
                    sharp[v] += a;
                }
            }
        };
        let texels = self.width * self.height;
        match &self.params {
            Params::Clustered8 { k, records, index } => {
                for (i, ix) in index.iter().enumerate() {
                    let v = i % nv;
                    for (c, &cl) in ix[..3].iter().enumerate() {
                        let r = &records[(v * 3 + c) * k + cl as usize].0;
                        add(v, c, r, r[ALBEDO_SLOT]);
                    }
                }
            }
            Params::Clustered16 { k, records, index } => {
                for (i, ix) in index.iter().enumerate() {
                    let v = i % nv;
                    for (c, &cl) in ix[..3].iter().enumerate() {
                        let r = &records[(v * 3 + c) * k + cl as usize].0;
                        add(v, c, r, r[ALBEDO_SLOT]);
                    }
                }
            }
            Params::Texel { lobes } => {
                for (i, l) in lobes.iter().enumerate() {
                    let (v, c) = (i / (3 * texels.max(1)), i % 3);
                    add(v, c, l, self.texel_lobe_albedo(l));
                }
            }
        }
        (0..nv)
            .map(|v| all[v] > 0.0 && sharp[v] >= f64::from(MIN_SHARP_SHARE) * all[v])
            .collect()
    }

    /// [`lobe_albedo`] of a per-texel model's lobe: without the mapping (LM has none; PLM's
    /// polynomials are per view and light, not known at the peak here), decoded.
    fn texel_lobe_albedo(&self, l: &[f32; 5]) -> f32 {
        lobe_albedo(l, |y| match self.space {
            ValueSpace::Linear => y.max(0.0),
            ValueSpace::Srgb => srgb_decode(y),
        })
    }

    /// [`lobe_albedo`] of every cluster record (see [`PlmcMaterial::store_lobe_albedos`]).
    fn cluster_lobe_albedos(&self, light_dirs: &[Vec3]) -> Vec<f32> {
        let (k, records) = match &self.params {
            Params::Clustered8 { k, records, .. } | Params::Clustered16 { k, records, .. } => {
                (*k, records)
            }
            Params::Texel { .. } => return Vec::new(),
        };
        let nl = self.n_lights;
        let mut out = vec![0f32; records.len()];
        for (j, (rec, o)) in records.iter().zip(out.iter_mut()).enumerate() {
            let (v, c) = (j / (3 * k), j / k % 3);
            let l = record5(&rec.0);
            let map = |y: f32| {
                let mut y = y;
                if !self.polys.is_empty() {
                    // The measured light nearest to the axis (the largest cosine).
                    let mut best = (f32::NEG_INFINITY, 0);
                    for (i, d) in light_dirs.iter().enumerate() {
                        let cos = l[1] * d.x + l[2] * d.y + l[3] * d.z;
                        if cos > best.0 {
                            best = (cos, i);
                        }
                    }
                    let row = &self.polys[v * nl + best.1].0;
                    let a = |p: usize| row[3 * p + c];
                    let x = y.min(self.y_max[v][c]);
                    let p = a(0) + x * (a(1) + x * (a(2) + x * (a(3) + x * a(4))));
                    y = p.min(self.out_max[v * nl + best.1][c]);
                }
                match self.space {
                    ValueSpace::Linear => y.max(0.0),
                    ValueSpace::Srgb => srgb_decode(y),
                }
            };
            *o = lobe_albedo(&l, map);
        }
        out
    }

    /// The lobe mixture of a hit at views `vi` (weights `vw`) filtered by `texels`: the lobes
    /// of the texel with the largest filter weight; None (the empty mixture) when none of the
    /// views has sharp lobes, so a caller keeps the empty one it has instead of copying one.
    pub(super) fn hit_lobes(
        &self,
        vi: [u32; 3],
        vw: [f32; 3],
        texels: &[(usize, f32)],
    ) -> Option<HitLobes> {
        let mut t = texels.first().map_or(0, |x| x.0);
        let mut best = f32::NEG_INFINITY;
        for &(i, w) in texels {
            if w > best {
                (t, best) = (i, w);
            }
        }
        if !(0..3).any(|a| vw[a] > 0.0 && self.sharp_views[vi[a] as usize]) {
            return None;
        }
        let nv = self.n_views;
        let mut lobes = [[0f32; 5]; HIT_LOBES];
        let mut weight = [0f32; HIT_LOBES];
        for a in 0..3 {
            if !(vw[a] > 0.0) {
                continue;
            }
            let v = vi[a] as usize;
            for c in 0..3 {
                let (l, albedo) = match &self.params {
                    Params::Clustered8 { k, records, index } => {
                        let j = (v * 3 + c) * k + index[t * nv + v][c] as usize;
                        (record5(&records[j].0), records[j].0[ALBEDO_SLOT])
                    }
                    Params::Clustered16 { k, records, index } => {
                        let j = (v * 3 + c) * k + index[t * nv + v][c] as usize;
                        (record5(&records[j].0), records[j].0[ALBEDO_SLOT])
                    }
                    Params::Texel { lobes: per_texel } => {
                        let l = per_texel[(v * self.width * self.height + t) * 3 + c];
                        (l, self.texel_lobe_albedo(&l))
                    }
                };
                lobes[3 * a + c] = l;
                weight[3 * a + c] = selection_weight(vw[a], c, albedo);
            }
        }
        Some(HitLobes::new(&lobes, &weight))
    }
}

/// The `[ρ, Dx, Dy, Dz, n]` of a padded lobe record.
#[inline(always)]
fn record5(r: &[f32; 8]) -> [f32; 5] {
    [r[0], r[1], r[2], r[3], r[4]]
}

impl std::fmt::Debug for PlmcMaterial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let clusters = match &self.params {
            Params::Clustered8 { k, .. } | Params::Clustered16 { k, .. } => *k,
            Params::Texel { .. } => 0,
        };
        f.debug_struct("PlmcMaterial")
            .field("kind", &self.kind.name())
            .field("space", &self.space)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("lights", &self.n_lights)
            .field("clusters", &clusters)
            .finish_non_exhaustive()
    }
}

/// One material per model file while anything uses it (several `<bsdf>` may share a file).
pub fn shared_material(path: &Path) -> Result<Arc<PlmcMaterial>> {
    static CACHE: crate::io::shared::SharedCache<PlmcMaterial> = std::sync::Mutex::new(None);
    crate::io::shared::shared_by_path(&CACHE, path, PlmcMaterial::load)
}
