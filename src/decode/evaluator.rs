//! Reconstruction: the SH background, the lobes and the spectral basis evaluated at a query,
//! parameters blended between stored incidences (`spec/EVALUATION.md`, "Reconstruction").

use super::lattice::{unit, Blend, Lattice, QueryFrame};
use crate::model::angles::{angle_between, deg_from_dir, dir_from_deg, dot, mirror_deg, normalize};
use crate::model::factor::{FactorModel, FeatureValues, MAX_COMPONENTS, MAX_RANK};
use crate::model::lobes::MicrofacetGeometry;
use crate::model::material::{LobeKind, Material, MAX_TERMS};
use crate::model::sh::{sh_count, ShBasis, MAX_SH_LEVEL};
use crate::model::spectral::SpectrumEvaluator;

const MAX_SH: usize = sh_count(MAX_SH_LEVEL);

/// A validated material plus what makes evaluation cheap.
///
/// An incident direction that is not stored is answered by interpolating the *parameters* of the
/// neighbouring records (SH coefficients, lobe amplitudes and shapes, the peak's offset from the
/// mirror direction) and evaluating once, so a specular peak moves with the incident direction
/// instead of cross-fading between two peaks (`spec/EVALUATION.md`, "Between stored incidences").
#[derive(Debug, Clone)]
pub(crate) struct Evaluator {
    pub(crate) material: Material,
    sh: ShBasis,
    /// Per record: the peak direction's offset from the mirror direction, (Δθ, Δφ) in degrees.
    peak_offset: Vec<(f64, f64)>,
    /// Per record: the unit peak vector (isotropic files blend these directly, which needs no
    /// trigonometry: all their records share the φ = 0 frame).
    pub(crate) peaks: Vec<[f64; 3]>,
    /// Natural logarithms of every lobe parameter, [record][lobe][parameter]: widths, exponents
    /// and microfacet b, c are interpolated geometrically, and taking logs once here keeps
    /// `ln` out of the per-query path.
    pub(crate) ln_params: Vec<Vec<Vec<f64>>>,
    lattice: Lattice,
    /// SH level ≤ 6 and ≤ 16 terms: evaluation can use small scratch arrays.
    small: bool,
    spectrum: SpectrumEvaluator,
    /// The factor model shared by every incidence, with its wavelength nodes, if any.
    factor: Option<(FactorModel, WavelengthNodes)>,
    /// The stored θ range's ends with their sine and cosine: a query clamped to an end keeps
    /// its azimuth without trigonometry.
    theta_ends: [(f64, f64, f64); 2],
}

impl Evaluator {
    /// Prepares a material for evaluation; the caller has validated it.
    pub(crate) fn new(material: Material) -> Self {
        let sh = ShBasis::new(material.sh_level);
        let peak_offset = material
            .records
            .iter()
            .map(|r| {
                let (mt, mp) = mirror_deg(r.theta_i as f64, r.phi_i as f64);
                // A peak at the pole has no azimuth: its offset is in θ alone.
                let dphi = if r.theta_p == 0.0 {
                    0.0
                } else {
                    crate::model::angles::phi_delta(r.phi_p as f64, mp)
                };
                (r.theta_p as f64 - mt, dphi)
            })
            .collect();
        let lattice = Lattice::of(&material);
        let small = material.sh_level <= 6 && material.spectral.terms <= 16;
        let peaks = material
            .records
            .iter()
            .map(|r| dir_from_deg(r.theta_p as f64, r.phi_p as f64))
            .collect();
        let ln_params = material
            .records
            .iter()
            .map(|r| {
                r.lobes
                    .iter()
                    .map(|l| l.params.iter().map(|&p| (p as f64).ln()).collect())
                    .collect()
            })
            .collect();
        let spectrum = SpectrumEvaluator::new(&material.spectral);
        let factor = material.factor.clone().map(|f| {
            let nodes = WavelengthNodes::new(&material.wavelengths);
            (f, nodes)
        });
        let end = |t: f64| {
            let (s, c) = t.to_radians().sin_cos();
            (t, s, c)
        };
        let first = material.records.first().map_or(0.0, |r| r.theta_i as f64);
        let last = material.records.last().map_or(0.0, |r| r.theta_i as f64);
        Evaluator {
            material,
            sh,
            peak_offset,
            peaks,
            ln_params,
            lattice,
            small,
            spectrum,
            factor,
            theta_ends: [end(first), end(last)],
        }
    }

    /// ρ at unit vectors `wi` (toward the light) and `wo` (toward the viewer) in the local frame
    /// (z = normal), for each wavelength in nm, into `out` (1/sr); never negative (the series is
    /// clamped at 0, `spec/EVALUATION.md`). Directions below the horizon give 0; so do zero or
    /// non-finite vectors. Wavelengths outside the file's spectral interval are clamped to it;
    /// incident directions outside the stored θ range are clamped to it. Writes
    /// `min(wavelengths.len(), out.len())` values; never allocates.
    pub(crate) fn eval(&self, wi: [f32; 3], wo: [f32; 3], wavelengths: &[f32], out: &mut [f32]) {
        let n = wavelengths.len().min(out.len());
        let out = &mut out[..n];
        let (Some(wi), Some(wo)) = (unit(wi), unit(wo)) else {
            out.fill(0.0);
            return;
        };
        if wi[2] < 0.0 || wo[2] < 0.0 {
            out.fill(0.0);
            return;
        }
        let q = self.query_frame(wi);
        let wl = wavelengths.iter().map(|&l| l as f64);
        // Clamped at 0 (spec/EVALUATION.md, "Reconstruction", step 5): a fit can undershoot
        // between its samples, and a renderer would turn that into negative light.
        let sink = |i: usize, v: f64| out[i] = v.max(0.0) as f32;
        self.eval_frame(q.theta, q.phi, Some(q.wi), q.in_frame(wo), wl, sink);
    }

    /// The query's incident direction in the records' frame (`wi` a unit vector with z ≥ 0).
    #[inline]
    pub(crate) fn query_frame(&self, wi: [f64; 3]) -> QueryFrame {
        let r = (wi[0] * wi[0] + wi[1] * wi[1]).sqrt();
        // θ only places the query between stored incidences. Single precision matches what
        // the f32 input vector can say about its own angle (≈1e-7 rad); the `libm` crate's
        // atan2f inlines here and costs a fraction of the system library's f64 atan2.
        let theta = (libm::atan2f(r as f32, wi[2] as f32) as f64).to_degrees();
        if self.material.isotropic {
            // Rotate into the stored frame (φi = 0) with the azimuth's cosine and sine, no trig.
            let (c, s) = if r > 0.0 {
                let inv = 1.0 / r;
                (wi[0] * inv, wi[1] * inv)
            } else {
                (1.0, 0.0)
            };
            QueryFrame {
                theta,
                phi: 0.0,
                wi: [r, 0.0, wi[2]],
                rotation: Some((c, s)),
            }
        } else {
            let (_, phi) = deg_from_dir(wi);
            QueryFrame {
                theta,
                phi,
                wi,
                rotation: None,
            }
        }
    }

    /// Convenience form of [`Decoder::eval`] with angles in degrees.
    pub(crate) fn eval_deg(
        &self,
        incident: (f64, f64),
        outgoing: (f64, f64),
        wavelengths: &[f64],
        out: &mut [f64],
    ) {
        self.eval_deg_with(incident, outgoing, wavelengths, out, true)
    }

    /// [`Evaluator::eval_deg`], with or without step 5's clamp at 0 (unclamped: to measure how
    /// often a model undershoots).
    pub(crate) fn eval_deg_with(
        &self,
        incident: (f64, f64),
        outgoing: (f64, f64),
        wavelengths: &[f64],
        out: &mut [f64],
        clamp: bool,
    ) {
        let n = wavelengths.len().min(out.len());
        let out = &mut out[..n];
        let finite = incident.1.is_finite() && outgoing.1.is_finite();
        if !finite || !(0.0..=90.0).contains(&incident.0) || !(0.0..=90.0).contains(&outgoing.0) {
            out.fill(0.0);
            return;
        }
        let wl = wavelengths[..n].iter().copied();
        let sink = |i: usize, v: f64| out[i] = if clamp { v.max(0.0) } else { v };
        if self.material.isotropic {
            let wo = dir_from_deg(outgoing.0, outgoing.1 - incident.1);
            self.eval_frame(incident.0, 0.0, None, wo, wl, sink);
        } else {
            let wo = dir_from_deg(outgoing.0, outgoing.1);
            self.eval_frame(incident.0, incident.1, None, wo, wl, sink);
        }
    }

    /// Evaluates at incidence (θ, φ) in degrees — already rotated to φ = 0 for isotropic files,
    /// as is the unit outgoing vector `wo` — passing (i, ρ(λ_i)) to `sink`. `wi`, when given,
    /// is the unit incident vector of (θ, φ) (it saves the trigonometry).
    fn eval_frame(
        &self,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
        wo: [f64; 3],
        wavelengths: impl Iterator<Item = f64>,
        sink: impl FnMut(usize, f64),
    ) {
        // Scratch arrays live on the stack; zeroing the format's maxima (441 SH values, 256
        // terms) would cost more than the evaluation, so files within SH level 6 and 16 terms
        // (every file the encoder writes by default) use small ones.
        if self.small {
            self.eval_sized::<{ sh_count(6) }, 16>(theta, phi, wi, wo, wavelengths, sink)
        } else {
            self.eval_sized::<MAX_SH, MAX_TERMS>(theta, phi, wi, wo, wavelengths, sink)
        }
    }

    fn eval_sized<const NSH: usize, const NT: usize>(
        &self,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
        wo: [f64; 3],
        wavelengths: impl Iterator<Item = f64>,
        mut sink: impl FnMut(usize, f64),
    ) {
        let m = &self.material;
        // The factor model sees the query as it is (its features are clamped to the ranges it
        // was fitted on); the records, the nearest stored incidences.
        let factor = self.factor.as_ref().map(|(f, _)| {
            let wq = wi.unwrap_or_else(|| dir_from_deg(theta, phi));
            let feats = FeatureValues::of(wq, wo).clamped(&f.ranges);
            let mut t = [0.0f64; MAX_COMPONENTS * MAX_RANK];
            f.angular(&feats, &mut t);
            t
        });
        let (blend, wi, theta, phi) = self.resolve(theta, phi, wi);
        let recs = &blend.rec[..blend.n];
        let ws = &blend.w[..blend.n];
        let k = recs.iter().map(|&r| m.records[r].terms).max().unwrap_or(1);
        let level = recs
            .iter()
            .map(|&r| m.records[r].sh_level)
            .max()
            .unwrap_or(0);
        let mut y = [0.0f64; NSH];
        self.sh.eval_to_level(level, wo, &mut y);
        let mut c = [0.0f64; NT];
        for (&r, &w) in recs.iter().zip(ws) {
            let rec = &m.records[r];
            let p = sh_count(rec.sh_level);
            for (kk, ck) in c[..rec.terms].iter_mut().enumerate() {
                let row = &rec.sh[kk * p..(kk + 1) * p];
                let v: f64 = row.iter().zip(&y[..p]).map(|(a, b)| *a as f64 * b).sum();
                *ck += w * v;
            }
        }
        // Lobes: where every blended record has a lobe of the same kind at the same position,
        // its shape parameters are interpolated and it is evaluated once; otherwise each record's
        // lobe is evaluated with its own shape and weighted.
        let max_lobes = recs
            .iter()
            .map(|&r| m.records[r].lobes.len())
            .max()
            .unwrap_or(0);
        // The microfacet geometry depends on the directions alone: computed at most once.
        let mut geometry = None;
        for li in 0..max_lobes {
            let kind = m.records[recs[0]].lobes.get(li).map(|l| l.kind);
            let shared = kind.is_some()
                && recs
                    .iter()
                    .all(|&r| m.records[r].lobes.get(li).map(|l| l.kind) == kind);
            if shared {
                self.add_lobe(
                    &mut c[..k],
                    recs,
                    ws,
                    li,
                    wi,
                    wo,
                    (theta, phi),
                    &mut geometry,
                );
            } else {
                for (&r, &w) in recs.iter().zip(ws) {
                    if li < m.records[r].lobes.len() {
                        let one = ([r], [w]);
                        self.add_lobe(
                            &mut c[..k],
                            &one.0,
                            &one.1,
                            li,
                            wi,
                            wo,
                            (theta, phi),
                            &mut geometry,
                        );
                    }
                }
            }
        }
        for (i, l) in wavelengths.enumerate() {
            if !l.is_finite() {
                sink(i, 0.0); // documented: a non-finite wavelength gives 0
                continue;
            }
            // The sink clamps at 0 (step 5) unless an unclamped value was asked for.
            let mut v = self.spectrum.dot(&c[..k], l);
            if let (Some((f, nodes)), Some(t)) = (&self.factor, &factor) {
                let (j, a) = nodes.bracket(l);
                v += f.value(t, j, a);
            }
            sink(i, v);
        }
    }

    /// The records to blend for a query incidence (θ, φ in degrees, in the records' frame), the
    /// incident vector they are evaluated with (`wi`, when given, is the unit vector of (θ, φ))
    /// and its angles: outside the stored θ range the nearest stored θ is used, incident vector
    /// included.
    #[inline]
    pub(crate) fn resolve(
        &self,
        theta: f64,
        phi: f64,
        wi: Option<[f64; 3]>,
    ) -> (Blend, [f64; 3], f64, f64) {
        let (blend, at_theta, at_phi) = self.lattice.blend(&self.material, theta, phi);
        let wi = match wi {
            Some(v) if at_theta == theta && at_phi == phi => v,
            Some(v) if at_phi == phi => self.clamped(v, at_theta),
            _ => dir_from_deg(at_theta, at_phi),
        };
        (blend, wi, at_theta, at_phi)
    }

    /// The unit vector at polar angle `theta` (degrees; one of the stored range's ends) with the
    /// azimuth of the unit vector `v`; φ = 0 when `v` is the normal.
    fn clamped(&self, v: [f64; 3], theta: f64) -> [f64; 3] {
        let Some(&(_, s, c)) = self.theta_ends.iter().find(|e| e.0 == theta) else {
            return dir_from_deg(theta, crate::model::angles::deg_from_dir(v).1);
        };
        let r = (v[0] * v[0] + v[1] * v[1]).sqrt();
        if r > 0.0 {
            [s * v[0] / r, s * v[1] / r, c]
        } else {
            [s, 0.0, c]
        }
    }

    /// Adds lobe `li` of the records `recs` (all of the same kind), blended with weights `ws`:
    /// amplitudes linearly, widths and exponents geometrically, the peak's offset from the
    /// mirror direction linearly.
    #[allow(clippy::too_many_arguments)]
    fn add_lobe(
        &self,
        c: &mut [f64],
        recs: &[usize],
        ws: &[f64],
        li: usize,
        wi: [f64; 3],
        wo: [f64; 3],
        incidence: (f64, f64),
        geometry: &mut Option<Option<MicrofacetGeometry>>,
    ) {
        let m = &self.material;
        let lobe0 = &m.records[recs[0]].lobes[li];
        let geo_mean = |param: usize| -> f64 {
            if recs.len() == 1 {
                return m.records[recs[0]].lobes[li].params[param] as f64;
            }
            recs.iter()
                .zip(ws)
                .map(|(&r, &w)| w * self.ln_params[r][li][param])
                .sum::<f64>()
                .exp()
        };
        let peak = || self.blended_peak(recs, ws, incidence);
        // Σ_r w_r·amplitude_r[index] for the records that have that term.
        let amp = |variant: usize, kk: usize| -> f64 {
            recs.iter()
                .zip(ws)
                .map(|(&r, &w)| {
                    let rec = &m.records[r];
                    if kk < rec.terms {
                        w * rec.lobes[li].amplitude[variant * rec.terms + kk] as f64
                    } else {
                        0.0
                    }
                })
                .sum()
        };
        match lobe0.kind {
            LobeKind::AngleGaussian => {
                let a2 = angle_between(wo, peak()).powi(2);
                for (kk, ck) in c.iter_mut().enumerate() {
                    // Per-term widths: a record without term kk contributes nothing to it.
                    let (mut lw, mut wsum) = (0.0, 0.0);
                    for (&r, &w) in recs.iter().zip(ws) {
                        if kk < m.records[r].terms {
                            lw += w * self.ln_params[r][li][kk];
                            wsum += w;
                        }
                    }
                    if recs.len() == 1 && kk < m.records[recs[0]].terms {
                        let b = m.records[recs[0]].lobes[li].params[kk] as f64;
                        *ck += amp(0, kk) * (-a2 / b).exp();
                    } else if wsum > 0.0 {
                        *ck += amp(0, kk) * (-a2 / (lw / wsum).exp()).exp();
                    }
                }
            }
            LobeKind::CosinePower => {
                // The cosine is capped at 1: rounding can exceed it, and a large exponent would
                // turn 1 + ε into infinity.
                // g^n as exp(n·ln g): powf's value to ~1e-15 relative, a little quicker, and the
                // geometric mean of the exponents is already a logarithm.
                let ln_g = dot(wo, peak()).clamp(0.0, 1.0).ln();
                let g = if recs.len() == 1 {
                    (m.records[recs[0]].lobes[li].params[0] as f64 * ln_g).exp()
                } else {
                    let ln_n: f64 = recs
                        .iter()
                        .zip(ws)
                        .map(|(&r, &w)| w * self.ln_params[r][li][0])
                        .sum();
                    (ln_n.exp() * ln_g).exp()
                };
                self.add_amplitudes(c, recs, ws, li, &[g]);
            }
            LobeKind::Microfacet | LobeKind::MicrofacetSin2 => {
                // The Smith parameter is interpolated linearly; normalised by the weights, so a
                // record evaluated on its own (lobes not shared) keeps its stored value.
                let (wa, wsum) = recs
                    .iter()
                    .zip(ws)
                    .fold((0.0, 0.0), |(wa, wsum), (&r, &w)| {
                        (wa + w * m.records[r].lobes[li].params[2] as f64, wsum + w)
                    });
                let a = wa / wsum;
                let params = [geo_mean(0) as f32, geo_mean(1) as f32, a as f32];
                let Some(g) = *geometry.get_or_insert_with(|| MicrofacetGeometry::new(wi, wo))
                else {
                    return; // wi = −wo: every variant is 0
                };
                let v = g.variants(&params, lobe0.kind == LobeKind::MicrofacetSin2);
                self.add_amplitudes(c, recs, ws, li, &v);
            }
        }
    }

    /// The peak direction of a lobe blended from the records `recs` with weights `ws`, at the
    /// evaluation incidence (θ, φ) in degrees (`spec/EVALUATION.md`, "Blended peak direction").
    pub(crate) fn blended_peak(
        &self,
        recs: &[usize],
        ws: &[f64],
        incidence: (f64, f64),
    ) -> [f64; 3] {
        if recs.len() == 1 {
            return self.peaks[recs[0]];
        }
        if self.material.isotropic {
            // Records 1D in θ, one frame: the normalised weighted mean of their peaks.
            let mut v = [0.0; 3];
            for (&r, &w) in recs.iter().zip(ws) {
                for (vi, pi) in v.iter_mut().zip(self.peaks[r]) {
                    *vi += w * pi;
                }
            }
            if let Some(u) = normalize(v) {
                return u;
            }
        }
        // Records at different azimuths: blend the offsets from each one's mirror direction.
        let (dt, dp) = recs.iter().zip(ws).fold((0.0, 0.0), |(a, b), (&r, &w)| {
            (a + w * self.peak_offset[r].0, b + w * self.peak_offset[r].1)
        });
        let (mt, mp) = mirror_deg(incidence.0, incidence.1);
        dir_from_deg(mt + dt, mp + dp)
    }

    /// c[k] += Σ_r w_r Σ_j v[j]·amplitude_r[j·K_r + k] over the terms k each record has: the
    /// lobe's variants `v`, evaluated once, weighted by every blended record's amplitudes.
    fn add_amplitudes(&self, c: &mut [f64], recs: &[usize], ws: &[f64], li: usize, v: &[f64]) {
        for (&r, &w) in recs.iter().zip(ws) {
            let rec = &self.material.records[r];
            let amplitude = &rec.lobes[li].amplitude;
            let t = rec.terms.min(c.len());
            for (j, &vj) in v.iter().enumerate() {
                let s = w * vj;
                let row = &amplitude[j * rec.terms..j * rec.terms + t];
                for (ck, &a) in c[..t].iter_mut().zip(row) {
                    *ck += s * a as f64;
                }
            }
        }
    }
}

/// The file's wavelengths as interpolation nodes: a wavelength's bracket (j, a), value =
/// (1 − a)·v_j + a·v_{j+1}, λ clamped to the nodes' range.
#[derive(Debug, Clone)]
pub(crate) struct WavelengthNodes {
    nodes: Vec<f64>,
}

impl WavelengthNodes {
    fn new(w: &[f32]) -> Self {
        WavelengthNodes {
            nodes: w.iter().map(|&v| v as f64).collect(),
        }
    }

    fn bracket(&self, l: f64) -> (usize, f64) {
        let n = &self.nodes;
        if n.len() == 1 || l.is_nan() || l <= n[0] {
            return (0, 0.0);
        }
        let last = n.len() - 1;
        if l >= n[last] {
            return (last, 0.0);
        }
        let j = n.partition_point(|&x| x <= l) - 1;
        (j, (l - n[j]) / (n[j + 1] - n[j]))
    }
}
