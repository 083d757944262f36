//! The θ-line path: how [`Evaluator::eval`] and the batch answer for the files the encoder
//! writes by default — isotropic, no factor model, at most two lobes per record, each a cosine
//! power or a microfacet lobe (kinds 2–4), SH level ≤ 6, ≤ 16 spectral terms.
//!
//! It computes what the general path computes (the same formulas, blends and rounding to f32 of
//! the blended shapes), with the generality those files do not need taken out: a query blends
//! one record or two neighbours, whose lobes are read by position straight from the resident
//! arrays, with no shape table, no Gaussian and no axis. One bookkeeping feeds two sinks: one
//! wavelength's value, its terms summed before its records (for the few queries the kernel
//! hands back: [`super::kernel`]), or the coefficients c_k for several wavelengths. The two
//! paths agree to rounding (`tests/batch.rs` holds `eval` to `eval_deg`, which takes the
//! general path).

use super::evaluator::{Evaluator, SMALL_SH};
use super::lattice::{Blend, Lattice};
use super::sums::{dot_f32, dot_terms};
use crate::model::angles::{azimuth_rotation, polar_deg, rotate_about_z};
use crate::model::lobes::{
    blend_geometric, blend_linear, blend_peak, cosine_power, MicrofacetGeometry,
};
use crate::model::material::LobeKind;
use crate::model::sh::{sh_count, ShBasis};

impl Evaluator {
    /// ρ at one wavelength before the clamp, for unit vectors `wi`, `wo` (local frame, z ≥ 0)
    /// and basis values `b` (B_0..B_{T−1} at the wavelength, T the file's terms); the file is
    /// on the line path ([`Evaluator::on_line`]).
    #[inline(always)]
    pub(crate) fn line_value(&self, wi: [f64; 3], wo: [f64; 3], b: &[f64]) -> f64 {
        let mut sink = OneWavelength { b, acc: 0.0 };
        self.line_terms(wi, wo, &mut sink);
        sink.acc
    }

    /// The coefficients c_0..c_{T−1} into `c` (T zeros, T the file's terms) for unit vectors
    /// `wi`, `wo` (local frame, z ≥ 0), for several wavelengths; on the line path.
    #[inline(always)]
    pub(crate) fn line_coefficients(&self, wi: [f64; 3], wo: [f64; 3], c: &mut [f64]) {
        self.line_terms(wi, wo, &mut Coefficients { c });
    }

    /// The line path's bookkeeping: the query frame, the records and weights, the lobes' values;
    /// each record's sums go to `sink`.
    #[inline(always)]
    fn line_terms(&self, wi: [f64; 3], wo: [f64; 3], sink: &mut impl LineSink) {
        let Lattice::Theta(axis) = &self.lattice else {
            return; // not on a θ line: `on_line` is false
        };
        // The query frame (`Evaluator::query_frame`, isotropic): rotated about z so that its
        // azimuth is 0, by the azimuth's cosine and sine.
        let (r, c, s) = azimuth_rotation(wi);
        let theta = polar_deg(r, wi[2]);
        let wo = rotate_about_z(wo, (c, s));
        // The records to blend (`Lattice::blend`, θ line) and the evaluation incidence
        // (`Evaluator::resolve`): θ clamped to the stored range, the incident vector with it.
        let (i, t) = axis.bracket(theta);
        let blend = if axis.xs.len() == 1 || t <= 0.0 {
            Blend::one(i)
        } else if 1.0 - t <= 0.0 {
            Blend::one(i + 1)
        } else {
            Blend {
                n: 2,
                rec: [i, i + 1, 0, 0],
                w: [1.0 - t, t, 0.0, 0.0],
            }
        };
        let (first, last) = (axis.xs[0], axis.xs[axis.xs.len() - 1]);
        let (theta, wi) = if theta < first {
            (first, self.clamped([r, 0.0, wi[2]], first))
        } else if theta > last {
            (last, self.clamped([r, 0.0, wi[2]], last))
        } else {
            (theta, [r, 0.0, wi[2]])
        };
        let phi = 0.0;
        let res = &self.res;
        let n = blend.n;
        let info = if n == 1 {
            self.alone[blend.rec[0]]
        } else {
            self.pairs[blend.rec[0]]
        };
        let level = info.level as usize;
        if level == 0 {
            // Level 0 (records whose shape is all lobe): one SH function, a constant.
            let y0 = ShBasis::shared().constant();
            for i in 0..n {
                let rec = &res.recs[blend.rec[i]];
                let t = rec.terms as usize;
                sink.sh0(
                    blend.w[i],
                    &res.vals[rec.sh as usize..rec.sh as usize + t],
                    y0,
                );
            }
        } else {
            // The SH values on the stack, sized for the level (zeroing 49 costs as much as a
            // level-2 record's sums).
            match level {
                1 | 2 => self.line_sh::<{ sh_count(2) }>(&blend, level, wo, sink),
                3 | 4 => self.line_sh::<{ sh_count(4) }>(&blend, level, wo, sink),
                _ => self.line_sh::<SMALL_SH>(&blend, level, wo, sink),
            }
        }
        let mut geometry = None;
        for li in 0..info.nlobes as usize {
            if info.shared & (1 << li) != 0 {
                let kind = res.lobe(&res.recs[blend.rec[0]], li).kind;
                let v = self.line_shared(&blend, li, kind, (theta, phi), wi, wo, &mut geometry);
                self.line_amplitudes(&blend, li, v, sink);
                continue;
            }
            for i in 0..n {
                let r = blend.rec[i];
                let rec = &res.recs[r];
                if li >= rec.nlobes as usize {
                    continue;
                }
                let l = res.lobe(rec, li);
                let p = &res.params[l.par as usize..];
                let v = match l.kind {
                    LobeKind::CosinePower => {
                        [cosine_power(p[0] as f64, wo, rec.peak), 0.0, 0.0, 0.0]
                    }
                    _ => microfacet(
                        &mut geometry,
                        wi,
                        wo,
                        [p[0] as f64, p[1] as f64, p[2] as f64],
                        l.kind == LobeKind::MicrofacetSin2,
                    ),
                };
                let one = Blend {
                    n: 1,
                    rec: [r, 0, 0, 0],
                    w: [blend.w[i], 0.0, 0.0, 0.0],
                };
                self.line_amplitudes(&one, li, v, sink);
            }
        }
    }

    /// Each blended record's SH rows against the SH values y at `wo` up to `level` (≤ the
    /// level of NSH values), into `sink`.
    #[inline(always)]
    fn line_sh<const NSH: usize>(
        &self,
        blend: &Blend,
        level: usize,
        wo: [f64; 3],
        sink: &mut impl LineSink,
    ) {
        let mut y = [0.0f64; NSH];
        ShBasis::shared().eval_to_level(level, wo, &mut y);
        for i in 0..blend.n {
            let rec = &self.res.recs[blend.rec[i]];
            let (t, p) = (rec.terms as usize, sh_count(rec.level as usize));
            let a = &self.res.vals[rec.sh as usize..rec.sh as usize + t * p];
            sink.sh(blend.w[i], a, &y[..p]);
        }
    }

    /// The values of the lobe at position `li`, shared by the blended records, at `wo`: its
    /// shape blended as [`Resident::shared_shape`](super::resident::Resident) blends it (exponent, b and c geometrically,
    /// a linearly, b, c and a rounded to f32; the peak by "Blended peak direction").
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn line_shared(
        &self,
        blend: &Blend,
        li: usize,
        kind: LobeKind,
        incidence: (f64, f64),
        wi: [f64; 3],
        wo: [f64; 3],
        geometry: &mut Option<Option<MicrofacetGeometry>>,
    ) -> [f64; 4] {
        let res = &self.res;
        let n = blend.n;
        let par = |i: usize| res.lobe(&res.recs[blend.rec[i]], li).par as usize;
        let geo = |j: usize| -> f64 {
            if n == 1 {
                return res.params[par(0) + j] as f64;
            }
            blend_geometric((0..n).map(|i| (blend.w[i], res.ln_params[par(i) + j])))
        };
        let r32 = |v: f64| v as f32 as f64;
        match kind {
            LobeKind::CosinePower => {
                // "Blended peak direction", isotropic: the normalised weighted mean of the
                // records' peaks (`Resident::blended_peak` when that vanishes).
                let peak = if n == 1 {
                    res.recs[blend.rec[0]].peak
                } else {
                    let peaks = [0, 1].map(|i| (blend.w[i], res.recs[blend.rec[i]].peak));
                    let (peak, ok) = blend_peak(peaks);
                    if ok {
                        peak
                    } else {
                        self.res
                            .blended_peak(&blend.rec[..n], &blend.w[..n], incidence)
                    }
                };
                [cosine_power(geo(0), wo, peak), 0.0, 0.0, 0.0]
            }
            _ => {
                let a = if n == 1 {
                    res.params[par(0) + 2] as f64
                } else {
                    blend_linear((0..n).map(|i| (blend.w[i], res.params[par(i) + 2] as f64)))
                };
                let p = [r32(geo(0)), r32(geo(1)), r32(a)];
                microfacet(geometry, wi, wo, p, kind == LobeKind::MicrofacetSin2)
            }
        }
    }

    /// The blended records' amplitudes of lobe `li` against its values `v` (one for a cosine
    /// power, four for a microfacet lobe), into `sink`.
    #[inline(always)]
    fn line_amplitudes(&self, blend: &Blend, li: usize, v: [f64; 4], sink: &mut impl LineSink) {
        let res = &self.res;
        for i in 0..blend.n {
            let rec = &res.recs[blend.rec[i]];
            let l = res.lobe(rec, li);
            let t = rec.terms as usize;
            let nv = if l.kind == LobeKind::CosinePower {
                1
            } else {
                4
            };
            let amp = &res.vals[l.amp as usize..l.amp as usize + nv * t];
            sink.lobe(blend.w[i], amp, t, &v[..nv]);
        }
    }
}

/// Where the line path's per-record sums go: one wavelength's value or the coefficients.
pub(crate) trait LineSink {
    /// A level-0 record's SH row `a` (one value per term) with weight `w`; Y_0^0 = `y0`.
    fn sh0(&mut self, w: f64, a: &[f32], y0: f64);
    /// A record's SH rows `a` (one row of y.len() values per term) against the SH values `y`.
    fn sh(&mut self, w: f64, a: &[f32], y: &[f64]);
    /// A lobe's amplitudes `amp` (a row of `t` per variant) against its variants' values `v`.
    fn lobe(&mut self, w: f64, amp: &[f32], t: usize, v: &[f64]);
}

/// One wavelength, basis values `b`: Σ_r w_r·Σ_k B_k·(…), terms before records ("Rounding").
struct OneWavelength<'a> {
    b: &'a [f64],
    acc: f64,
}

impl LineSink for OneWavelength<'_> {
    #[inline(always)]
    fn sh0(&mut self, w: f64, a: &[f32], y0: f64) {
        self.acc += w * (dot_terms(a, &self.b[..a.len()]) * y0);
    }

    #[inline(always)]
    fn sh(&mut self, w: f64, a: &[f32], y: &[f64]) {
        let mut sum = 0.0;
        for (row, &bk) in a.chunks_exact(y.len()).zip(self.b) {
            sum += bk * dot_f32(row, y);
        }
        self.acc += w * sum;
    }

    #[inline(always)]
    fn lobe(&mut self, w: f64, amp: &[f32], t: usize, v: &[f64]) {
        let b = self.b;
        // A few terms (the usual case) unrolled, chosen once per record.
        let sum = match t {
            1 => variant_sums::<1>(amp, v, b),
            2 => variant_sums::<2>(amp, v, b),
            3 => variant_sums::<3>(amp, v, b),
            4 => variant_sums::<4>(amp, v, b),
            _ => {
                let mut sum = 0.0;
                for (row, &vj) in amp.chunks_exact(t).zip(v) {
                    sum += vj * dot_terms(row, &b[..t]);
                }
                sum
            }
        };
        self.acc += w * sum;
    }
}

/// The coefficients c_k, as the general path forms them (`Evaluator::coefficients`).
struct Coefficients<'a> {
    c: &'a mut [f64],
}

impl LineSink for Coefficients<'_> {
    #[inline(always)]
    fn sh0(&mut self, w: f64, a: &[f32], y0: f64) {
        for (ck, &ak) in self.c.iter_mut().zip(a) {
            *ck += w * (ak as f64 * y0);
        }
    }

    #[inline(always)]
    fn sh(&mut self, w: f64, a: &[f32], y: &[f64]) {
        for (ck, row) in self.c.iter_mut().zip(a.chunks_exact(y.len())) {
            *ck += w * dot_f32(row, y);
        }
    }

    #[inline(always)]
    fn lobe(&mut self, w: f64, amp: &[f32], t: usize, v: &[f64]) {
        for (k, ck) in self.c.iter_mut().enumerate().take(t) {
            let mut sum = 0.0;
            for (j, &vj) in v.iter().enumerate() {
                sum += vj * amp[j * t + k] as f64;
            }
            *ck += w * sum;
        }
    }
}

/// The four microfacet variants for parameters `p` = [b, c, a], the geometry computed once per
/// query (None inside: wi = −wo, every variant 0).
#[inline(always)]
pub(crate) fn microfacet(
    geometry: &mut Option<Option<MicrofacetGeometry>>,
    wi: [f64; 3],
    wo: [f64; 3],
    p: [f64; 3],
    sin2: bool,
) -> [f64; 4] {
    match *geometry.get_or_insert_with(|| MicrofacetGeometry::new(wi, wo)) {
        Some(g) => g.variants_f64(p, sin2),
        None => [0.0; 4],
    }
}

/// Σ_j v\[j\]·Σ_{k<T} amp\[j·T + k\]·b\[k\]: a lobe's variants (`v`) against its amplitudes at
/// one wavelength (basis values `b`), for a record of T terms.
#[inline(always)]
fn variant_sums<const T: usize>(amp: &[f32], v: &[f64], b: &[f64]) -> f64 {
    let Some(b) = b.first_chunk::<T>() else {
        return 0.0;
    };
    let mut sum = 0.0;
    for (row, &vj) in amp.chunks_exact(T).zip(v) {
        let Some(row) = row.first_chunk::<T>() else {
            break;
        };
        let mut d = 0.0;
        for k in 0..T {
            d += row[k] as f64 * b[k];
        }
        sum += vj * d;
    }
    sum
}
