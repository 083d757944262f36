//! Importance sampling of the outgoing direction: what [`Decoder::sample`](crate::Decoder::sample) and [`Decoder::pdf`](crate::Decoder::pdf)
//! compute. Informative text: `spec/EVALUATION.md`, "Importance sampling".
//!
//! The density is a mixture over the sphere of closed-form proposals, one per component of the
//! stored model: a cosine for the SH background, and per lobe a shape like its own — Phong's
//! cosine power about the peak direction; a von Mises–Fisher distribution for the angle
//! Gaussian (exp(κ(cos α − 1)) ≈ exp(−κα²/2), so κ = 2/b); for microfacet lobes GGX's
//! distribution of visible normals (Heitz 2018) with the roughness whose distribution term has
//! the lobe's half width, the drawn normal reflecting the incident direction. Directions that
//! fall below the horizon are mirrored back above it (z → −z), so the density on the upper
//! hemisphere is the mixture's density at ωo plus its density at the mirrored ωo, which
//! integrates to 1 exactly: no sample is wasted and no normalisation is estimated. Every
//! proposal's density is bounded, including at grazing incidence. (Drawing the half vector from
//! the lobe's own D·cos θh and reflecting, the textbook choice, gives the density a 1/|ωi·h|
//! pole at ωo = −ωi, which the mirroring would bring above the horizon.)
//!
//! The mixture weights are each component's energy ∫ f̄ cos θo dω in the spectrum-averaged BRDF
//! f̄ (the mean over the file's wavelengths), computed per record when the file is opened — the
//! background's in closed form, each lobe's by a fixed 4×4 stratified quadrature with the lobe's
//! own proposal — and blended between records with the records' interpolation weights, as every
//! other parameter is. The cosine keeps at least [`MIN_COSINE_WEIGHT`] of the mixture, so the
//! density is positive wherever cos θo > 0, whatever the lobes claim.

pub(crate) mod proposal;
pub(crate) mod sample;

use crate::decode::records::blend::{blended_params, blended_peak};
use crate::decode::records::incidence::Records;
use crate::decode::records::lattice::{unit, unit_above, QueryFrame};
use crate::model::angles::{angle_between, dir_from_deg};
use crate::model::lobes::{lobe_values, shape_rule, Proposal};
use crate::model::material::{LobeKind, MAX_LOBES};
use std::f64::consts::PI;

use proposal::Shape;
use sample::{uniforms, ONE_BELOW};
pub use sample::{Sample, MIN_COSINE_WEIGHT};

/// Strata per axis of the quadrature that estimates each lobe's energy when a file is opened.
/// Against a 64 × 64 reference on the golden files, 4 × 4 is within 6% (2 × 2: 11%, 8 × 8: 4%),
/// and opening a file costs 1.2–1.7 µs more per record; the weights' accuracy hardly matters
/// (the albedo estimator's variance in `tests/sampling.rs` is the same with 2 × 2 and 8 × 8),
/// the open time does.
const ENERGY_GRID: usize = 4;

/// Components of one query's mixture: the cosine, plus one per lobe of each blended record when
/// no lobe is shared (at most four records of at most [`MAX_LOBES`] lobes).
const MAX_COMPONENTS: usize = 1 + 4 * MAX_LOBES;

/// What importance sampling precomputes per record when a file is opened.
#[derive(Debug, Clone, Default)]
pub(crate) struct SamplingWeights {
    /// Per record: ∫ f̄_background cos θo dω over the upper hemisphere.
    background: Vec<f64>,
    /// Per record and lobe: ∫ f̄_lobe cos θo dω at the record's incidence, and for angle
    /// Gaussians the logarithm of the width its proposal uses.
    lobes: Vec<Vec<LobeWeight>>,
}

#[derive(Debug, Clone, Copy)]
struct LobeWeight {
    energy: f64,
    ln_width: f64,
}

impl SamplingWeights {
    pub(crate) fn new(dec: Records) -> Self {
        let res = dec.res;
        let bmean = res.basis_means();
        let integrals = cosine_integrals(res.sh_level);
        let mut background = Vec::with_capacity(res.recs.len());
        let mut lobes = Vec::with_capacity(res.recs.len());
        for (r, rec) in res.recs.iter().enumerate() {
            let t = rec.terms as usize;
            let level = rec.level as usize;
            // Only the m = 0 functions survive the integral against max(0, cos θ).
            let mut e = 0.0;
            for (l, integral) in integrals.iter().enumerate().take(level + 1) {
                let j = l * (l + 1);
                let a: f64 = (0..t)
                    .map(|k| bmean[k] * res.sh_row(rec, k)[j] as f64)
                    .sum();
                e += a * integral;
            }
            background.push(e);
            let wi = dir_from_deg(rec.theta_i as f64, rec.phi_i as f64);
            let incidence = (rec.theta_i as f64, rec.phi_i as f64);
            let per_lobe = (0..rec.nlobes as usize)
                .map(|li| {
                    let lobe = res.lobe(rec, li);
                    // The Gaussian's proposal width: the geometric mean of the per-term widths,
                    // weighted by each term's share of the spectrum-averaged amplitude.
                    let ln_width = if shape_rule(lobe.kind).proposal == Proposal::PeakVonMisesFisher
                    {
                        let ln_b = &res.ln_params[lobe.par as usize..lobe.par as usize + t];
                        let (mut num, mut den) = (0.0, 0.0);
                        let terms = res.amplitudes(rec, lobe, 0).iter().zip(&bmean);
                        for ((&p, &mean), &ln_b) in terms.zip(ln_b) {
                            let s = (p as f64 * mean).abs();
                            num += s * ln_b;
                            den += s;
                        }
                        if den > 0.0 {
                            num / den
                        } else {
                            ln_b[0]
                        }
                    } else {
                        0.0
                    };
                    let shape = lobe_shape(dec, &[r], &[1.0], li, &[ln_width], incidence, wi);
                    let energy = lobe_energy(dec, r, li, &bmean, shape, wi);
                    LobeWeight { energy, ln_width }
                })
                .collect();
            lobes.push(per_lobe);
        }
        SamplingWeights { background, lobes }
    }

    /// Record `r`'s background energy and, per lobe, (energy, ln width): what the device
    /// layout's sampling section stores (`spec/GPU_LAYOUT.md`, "Sampling section").
    pub(crate) fn record(&self, r: usize) -> (f64, impl Iterator<Item = (f64, f64)> + '_) {
        (
            self.background[r],
            self.lobes[r].iter().map(|l| (l.energy, l.ln_width)),
        )
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        8 * self.background.capacity()
            + std::mem::size_of::<Vec<LobeWeight>>() * self.lobes.capacity()
            + self
                .lobes
                .iter()
                .map(|l| std::mem::size_of::<LobeWeight>() * l.capacity())
                .sum::<usize>()
    }
}

/// ∫ Y_l^0(ω) max(0, cos θ) dω for l = 0..=level: 2π·K_l^0·∫₀¹ P_l(μ) μ dμ, where the Legendre
/// integral is 1/2 (l = 0), 1/3 (l = 1), 0 (odd l ≥ 3) and
/// (−1)^(l/2+1)·(l−2)! / (2^l·(l/2−1)!·(l/2+1)!) for even l ≥ 2.
fn cosine_integrals(level: usize) -> Vec<f64> {
    (0..=level)
        .map(|l| {
            let legendre = match l {
                0 => 0.5,
                1 => 1.0 / 3.0,
                _ if l % 2 == 1 => 0.0,
                _ => {
                    let h = l / 2;
                    let fact = |n: usize| (1..=n).map(|i| i as f64).product::<f64>();
                    let sign = if (h + 1) % 2 == 0 { 1.0 } else { -1.0 };
                    sign * fact(l - 2) / (2f64.powi(l as i32) * fact(h - 1) * fact(h + 1))
                }
            };
            2.0 * PI * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * legendre
        })
        .collect()
}

/// ∫ f̄ cos θo dω over the upper hemisphere of lobe `li` of record `r` alone, at the record's
/// incidence `wi`, by a stratified quadrature with the lobe's own proposal as the density.
fn lobe_energy(
    dec: Records,
    r: usize,
    li: usize,
    bmean: &[f64],
    shape: Shape,
    wi: [f64; 3],
) -> f64 {
    let res = dec.res;
    let rec = &res.recs[r];
    let lobe = res.lobe(rec, li);
    let t = rec.terms as usize;
    let params = res.params(rec, lobe);
    let mean_amp = |j: usize| -> f64 {
        let amp = res.amplitudes(rec, lobe, j);
        (0..t).map(|k| amp[k] as f64 * bmean[k]).sum()
    };
    let value = |wo: [f64; 3]| -> f64 {
        match lobe.kind {
            LobeKind::AngleGaussian => {
                let a2 = angle_between(wo, rec.peak).powi(2);
                let amp = res.amplitudes(rec, lobe, 0);
                (0..t)
                    .map(|k| amp[k] as f64 * bmean[k] * (-a2 / params[k] as f64).exp())
                    .sum()
            }
            kind => {
                let p = std::array::from_fn(|i| params.get(i).map_or(0.0, |&v| v as f64));
                let (v, nv) = lobe_values(kind, &p, rec.peak, wi, wo, &mut None);
                (0..nv).map(|j| mean_amp(j) * v[j]).sum()
            }
        }
    };
    let n = ENERGY_GRID;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let u = [(i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64];
            let Some(wo) = shape.draw(u, wi) else {
                continue;
            };
            let q = shape.density(wo, wi);
            if wo[2] > 0.0 && q > 0.0 {
                sum += value(wo) * wo[2] / q;
            }
        }
    }
    let e = sum / (n * n) as f64;
    if e.is_finite() {
        e.max(0.0)
    } else {
        0.0
    }
}

/// The shape of lobe `li` blended from records `recs` with weights `ws` (the lobe shared by all
/// of them, or one record's own with weight 1), as `Decoder::eval` blends it; `ln_widths[i]` is
/// record i's Gaussian proposal width (ln rad²), `incidence` the evaluation incidence (degrees)
/// and `wi` its unit vector.
fn lobe_shape(
    dec: Records,
    recs: &[usize],
    ws: &[f64],
    li: usize,
    ln_widths: &[f64],
    incidence: (f64, f64),
    wi: [f64; 3],
) -> Shape {
    let res = dec.res;
    let kind = res.lobe(&res.recs[recs[0]], li).kind;
    // The shape as evaluation blends it.
    let p = blended_params(res, recs, ws, li);
    match shape_rule(kind).proposal {
        Proposal::PeakVonMisesFisher => {
            let wsum: f64 = ws.iter().sum();
            let ln_b = ws.iter().zip(ln_widths).map(|(w, l)| w * l).sum::<f64>() / wsum;
            let kappa = 2.0 * (-ln_b).exp();
            Shape::VonMisesFisher {
                p: blended_peak(dec.res, recs, ws, incidence),
                kappa,
                m: -(-2.0 * kappa).exp_m1(),
            }
        }
        Proposal::PeakCosinePower => Shape::CosinePower {
            p: blended_peak(dec.res, recs, ws, incidence),
            n: p[0],
        },
        Proposal::VisibleNormals { sin2 } => Shape::visible_normals(sin2, p[0], p[1], wi),
        Proposal::VisibleNormalsAniso => Shape::visible_normals_aniso(p[0], p[1], p[2], p[5], wi),
    }
}

/// One query's proposal: components with weights summing to 1, in the records' frame.
struct Mixture {
    n: usize,
    shapes: [Shape; MAX_COMPONENTS],
    weights: [f64; MAX_COMPONENTS],
    /// The evaluation incidence the half-vector proposals reflect about.
    wi: [f64; 3],
}

impl Mixture {
    fn new(dec: Records, sw: &SamplingWeights, q: &QueryFrame) -> Self {
        let res = dec.res;
        let (blend, wi, theta, phi) = dec.places.resolve(dec.res, q.theta, q.phi, Some(q.wi));
        let recs = &blend.rec[..blend.n];
        let ws = &blend.w[..blend.n];
        let mut mix = Mixture {
            n: 1,
            shapes: [Shape::Cosine; MAX_COMPONENTS],
            weights: [0.0; MAX_COMPONENTS],
            wi,
        };
        mix.weights[0] = recs
            .iter()
            .zip(ws)
            .map(|(&r, &w)| w * sw.background[r])
            .sum::<f64>();
        let max_lobes = recs
            .iter()
            .map(|&r| res.recs[r].nlobes as usize)
            .max()
            .unwrap_or(0);
        let kind_at = |r: usize, li: usize| (res.recs[r].kinds >> (4 * li)) & 15;
        let mut ln_widths = [0.0; 4];
        for li in 0..max_lobes {
            // The lobes are shared or not exactly as the evaluation decides.
            let kind = kind_at(recs[0], li);
            let shared = kind != 0 && recs.iter().all(|&r| kind_at(r, li) == kind);
            if shared {
                let energy: f64 = recs
                    .iter()
                    .zip(ws)
                    .map(|(&r, &w)| w * sw.lobes[r][li].energy)
                    .sum();
                for (lw, &r) in ln_widths.iter_mut().zip(recs) {
                    *lw = sw.lobes[r][li].ln_width;
                }
                let shape = lobe_shape(dec, recs, ws, li, &ln_widths, (theta, phi), wi);
                mix.push(shape, energy);
            } else {
                for (&r, &w) in recs.iter().zip(ws) {
                    if let Some(lw) = sw.lobes[r].get(li) {
                        let shape =
                            lobe_shape(dec, &[r], &[1.0], li, &[lw.ln_width], (theta, phi), wi);
                        mix.push(shape, w * lw.energy);
                    }
                }
            }
        }
        mix.normalise();
        mix
    }

    fn push(&mut self, shape: Shape, energy: f64) {
        if energy > 0.0 && energy.is_finite() && self.n < MAX_COMPONENTS {
            self.shapes[self.n] = shape;
            self.weights[self.n] = energy;
            self.n += 1;
        }
    }

    /// Energies to probabilities, the cosine's at least [`MIN_COSINE_WEIGHT`].
    fn normalise(&mut self) {
        let cosine = if self.weights[0].is_finite() {
            self.weights[0].max(0.0)
        } else {
            0.0
        };
        let lobes: f64 = self.weights[1..self.n].iter().sum();
        if !(lobes > 0.0 && lobes.is_finite()) {
            self.n = 1;
            self.weights[0] = 1.0;
            return;
        }
        let p_cos = (cosine / (cosine + lobes)).max(MIN_COSINE_WEIGHT);
        self.weights[0] = p_cos;
        let scale = (1.0 - p_cos) / lobes;
        for w in &mut self.weights[1..self.n] {
            *w *= scale;
        }
    }

    /// The density over the upper hemisphere at the unit vector `wo` (z ≥ 0): every
    /// component's density at wo and at its mirror image below the horizon, where `draw`
    /// folds from.
    fn density(&self, wo: [f64; 3]) -> f64 {
        let below = [wo[0], wo[1], -wo[2]];
        let mut sum = self.weights[0] * Shape::Cosine.density(wo, self.wi);
        for (shape, &w) in self.shapes[1..self.n].iter().zip(&self.weights[1..self.n]) {
            sum += w * (shape.density(wo, self.wi) + shape.density(below, self.wi));
        }
        sum
    }

    /// A direction on the upper hemisphere: a component chosen by u[0], whose remainder is
    /// reused (rescaled) to draw from it; a direction below the horizon is mirrored above it.
    fn draw(&self, u: [f64; 2]) -> Option<[f64; 3]> {
        let mut i = self.n - 1;
        let mut lo = 0.0;
        for (k, &w) in self.weights[..self.n].iter().enumerate() {
            if u[0] < lo + w {
                i = k;
                break;
            }
            lo += w;
        }
        let u0 = ((u[0] - lo) / self.weights[i]).clamp(0.0, ONE_BELOW);
        let w = self.shapes[i].draw([u0, u[1]], self.wi)?;
        Some([w[0], w[1], w[2].abs()])
    }
}

pub(crate) fn sample(
    dec: Records,
    sw: &SamplingWeights,
    wi: [f32; 3],
    u: [f32; 2],
) -> Option<Sample> {
    let u = uniforms(u)?;
    let wi = unit(wi)?;
    if wi[2] < 0.0 {
        return None;
    }
    let q = dec.places.query_frame(wi);
    let mix = Mixture::new(dec, sw, &q);
    let w = q.out_of_frame(mix.draw(u)?);
    let wo = [w[0] as f32, w[1] as f32, w[2] as f32];
    // The density at the direction as returned (rounded to f32), computed as `pdf` computes it.
    let back = unit(wo)?;
    let pdf = mix.density(q.in_frame(back)) as f32;
    (pdf > 0.0 && pdf.is_finite()).then_some(Sample { wo, pdf })
}

pub(crate) fn pdf(dec: Records, sw: &SamplingWeights, wi: [f32; 3], wo: [f32; 3]) -> f32 {
    let (Some(wi), Some(wo)) = (unit_above(wi), unit_above(wo)) else {
        return 0.0;
    };
    let q = dec.places.query_frame(wi);
    Mixture::new(dec, sw, &q).density(q.in_frame(wo)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::angles::dot;

    /// Midpoint quadrature of a density over the sphere.
    fn integral(mut f: impl FnMut([f64; 3]) -> f64) -> f64 {
        let (nt, np) = (1600, 800);
        let mut sum = 0.0;
        for i in 0..nt {
            let t = (i as f64 + 0.5) * PI / nt as f64;
            let (st, ct) = t.sin_cos();
            for j in 0..np {
                let p = (j as f64 + 0.5) * 2.0 * PI / np as f64;
                let (sp, cp) = p.sin_cos();
                sum += f([st * cp, st * sp, ct]) * st;
            }
        }
        sum * (PI / nt as f64) * (2.0 * PI / np as f64)
    }

    #[test]
    fn every_proposal_is_a_density_over_the_sphere() {
        // Grazing incidences included: there half of a lobe's proposal falls below the horizon,
        // and a density with a pole would show here as a slowly converging integral.
        for ti in [0.0, 50.0, 83.0, 89.5] {
            let wi = dir_from_deg(ti, 0.0);
            let p = dir_from_deg(ti, 180.0);
            let shapes = [
                Shape::Cosine,
                Shape::CosinePower { p, n: 1.0 },
                Shape::CosinePower { p, n: 60.0 },
                Shape::VonMisesFisher {
                    p,
                    kappa: 0.3,
                    m: -(-0.6f64).exp_m1(),
                },
                Shape::VonMisesFisher {
                    p,
                    kappa: 40.0,
                    m: -(-80.0f64).exp_m1(),
                },
                Shape::visible_normals(true, 24.0, 2.0, wi),
                Shape::visible_normals(false, 30.0, 1.5, wi),
                Shape::visible_normals(false, 3.0, 0.2, wi),
                Shape::visible_normals(true, 0.5, 0.7, wi),
                Shape::ggx(1.0, 1.0, [1.0, 0.0], wi),
                // Anisotropic: GGX 0.14 × 0.35 at 30° (narrower axes need a finer quadrature
                // at 89.5°: 0.08 gives ∫ = 0.9976, 0.9995, 0.9999 on 1600, 6400 and 12800 θ
                // steps; `tests/sampling.rs` checks them where they are stored), and a width
                // ratio turned past 90° (the proposal's frame turns with the axis).
                Shape::visible_normals_aniso(50.0, 7.2, 2.0, 30.0, wi),
                Shape::visible_normals_aniso(5.0, 200.0, 1.5, 163.0, wi),
            ];
            for s in shapes {
                let total = integral(|w| s.density(w, wi));
                assert!((total - 1.0).abs() < 2e-3, "θi = {ti}, {s:?}: ∫ = {total}");
                // Every drawn direction is a unit vector where the density is positive and
                // finite (a sample the density calls impossible would make an estimator
                // divide by 0).
                for i in 0..16 {
                    for j in 0..16 {
                        let u = [(i as f64 + 0.5) / 16.0, (j as f64 + 0.5) / 16.0];
                        if let Some(w) = s.draw(u, wi) {
                            let q = s.density(w, wi);
                            assert!(q > 0.0 && q.is_finite(), "{s:?} at {w:?}: {q}");
                            assert!((dot(w, w) - 1.0).abs() < 1e-12);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn a_ggx_lobe_is_sampled_by_its_own_distribution() {
        // b = (1 − α²)/α², c = 2 is GGX of roughness α: the proposal's roughness is α.
        let alpha = 0.3f64;
        let b = (1.0 - alpha * alpha) / (alpha * alpha);
        match Shape::visible_normals(true, b, 2.0, [0.0, 0.0, 1.0]) {
            Shape::VisibleNormals { ax, ay, k, .. } => {
                assert!((ax - alpha).abs() < 1e-12 && ax == ay, "{ax} {ay}");
                assert!((k - 0.25).abs() < 1e-15, "{k}"); // G1 = 1 at normal incidence
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_background_energy_is_the_cosine_integral_of_the_sh_functions() {
        // Compare the closed form with a quadrature of every m = 0 function up to level 8.
        let level = 8;
        let sh = crate::model::sh::ShBasis::new(level);
        let closed = cosine_integrals(level);
        let mut y = vec![0.0; sh.count()];
        for (l, want) in closed.iter().enumerate() {
            let got = integral(|w| {
                if w[2] <= 0.0 {
                    return 0.0;
                }
                sh.eval(w, &mut y);
                y[l * (l + 1)] * w[2]
            });
            assert!((got - want).abs() < 1e-5, "l = {l}: {got} vs {want}");
        }
    }
}
