//! Fitting one incident direction: the paper's method (Sec. 2.3) and its direct-SH baseline.
//!
//! Per incident direction, the spectrum at each outgoing direction is projected on the spectral
//! basis; each coefficient, seen as a function of the outgoing direction, is then split into a
//! smooth background (real SH up to level L, least squares by SVD) and a Gaussian peak around the
//! mirror-reflection direction. The objective and the steps are written out in
//! `spec/EVALUATION.md`, section "How the encoder fits (informative)".

use crate::angles::{angle_between, deg_from_dir, dir_from_deg, mirror_deg, phi_delta, wrap_phi};
use crate::material::{IncidentRecord, Lobe, LobeKind};
use crate::samples::IncidentSamples;
use crate::sh::ShBasis;
use crate::spectral::SpectralSpace;
use nalgebra::DMatrix;

/// How the specular peak is represented.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeakMode {
    /// SH only, no peak: the paper's baseline (its Fig. 4).
    None,
    /// The paper's hybrid: SH background fitted outside a critical angle, then a Gaussian.
    Paper,
    /// Background and lobe amplitudes solved together, the lobe width searched on top
    /// (see [`crate::joint`]).
    Joint,
}

/// The angle (degrees) around the peak direction inside which samples are left to the peak.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CriticalAngle {
    /// Chosen per incident direction by minimising the relative error (the paper's Fig. 6).
    Auto,
    Fixed(f64),
}

/// Everything shared by the fits of one file.
pub struct FitContext {
    /// Options of the joint fit (used when `peak` is [`PeakMode::Joint`]).
    pub joint: crate::joint::JointOptions,
    pub spectral: SpectralSpace,
    pub sh: ShBasis,
    pub peak: PeakMode,
    pub critical_angle: CriticalAngle,
    /// K×W projection matrix (the paper's Eq. 5 by the trapezoidal rule).
    projection: DMatrix<f64>,
    /// K×W: ρ(λ_w) = Σ_k c_k synthesis[k][w].
    pub(crate) synthesis: DMatrix<f64>,
    w: usize,
}

/// A fitted record with the sums behind its error figure, so that errors can be pooled.
pub struct Fitted {
    /// False when an error budget was given and no model met it.
    pub met: bool,
    pub record: IncidentRecord,
    /// Σ(ρ̂ − ρ)² and Σρ² over this incidence's samples.
    pub sq_error: f64,
    pub sq_reference: f64,
}

impl FitContext {
    pub fn new(
        spectral: SpectralSpace,
        wavelengths: &[f64],
        sh_level: usize,
        peak: PeakMode,
        critical_angle: CriticalAngle,
    ) -> Self {
        let w = wavelengths.len();
        let projection = spectral_projection(&spectral, wavelengths);
        // synthesis() is W×K row-major, i.e. K×W column-major.
        let synthesis =
            DMatrix::from_column_slice(spectral.terms, w, &spectral.synthesis(wavelengths));
        FitContext {
            joint: crate::joint::JointOptions {
                max_sh_level: sh_level,
                families: vec![crate::joint::LobeFamily::Gaussian],
                precision: crate::material::Precision::F32,
                max_error: None,
            },
            sh: ShBasis::new(sh_level),
            spectral,
            peak,
            critical_angle,
            projection,
            synthesis,
            w,
        }
    }

    /// The N×(L+1)² matrix of SH functions at unit directions.
    pub(crate) fn sh_matrix(&self, dirs: &[[f64; 3]]) -> DMatrix<f64> {
        let p = self.sh.count();
        let mut y = DMatrix::zeros(dirs.len(), p);
        let mut row = vec![0.0; p];
        for (i, d) in dirs.iter().enumerate() {
            self.sh.eval(*d, &mut row);
            for j in 0..p {
                y[(i, j)] = row[j];
            }
        }
        y
    }

    /// Fits one incident direction. Values are rounded to f32 (the caller rounds further for
    /// f16 and re-measures with [`FitContext::measure`]).
    pub fn fit(&self, s: &IncidentSamples) -> Result<Fitted, String> {
        if self.peak == PeakMode::Joint {
            let (mut f, met) = crate::joint::fit_joint(self, s, &self.joint)?;
            f.met = met;
            return Ok(f);
        }
        let n = s.directions.len();
        let p = self.sh.count();
        let dirs: Vec<[f64; 3]> = s
            .directions
            .iter()
            .map(|d| dir_from_deg(d[0], d[1]))
            .collect();
        let rho = DMatrix::from_row_slice(n, self.w, &s.values);
        // N×K spectral coefficients of every outgoing spectrum.
        let coeffs = &rho * self.projection.transpose();
        let y = self.sh_matrix(&dirs);
        let (mt, mp) = mirror_deg(s.theta_i, s.phi_i);
        let candidate = match self.peak {
            PeakMode::Joint => unreachable!("handled above"),
            PeakMode::None => {
                let a = lstsq(&y, &coeffs);
                self.make_record(s, (mt, mp), 0.0, &a, Vec::new())
            }
            PeakMode::Paper => {
                let (tp, pp) = find_peak_direction(s, (mt, mp));
                let peak = dir_from_deg(tp, pp);
                let alpha: Vec<f64> = dirs.iter().map(|d| angle_between(*d, peak)).collect();
                let try_angle = |gamma: f64| {
                    self.fit_hybrid(&y, &coeffs, &alpha, gamma)
                        .map(|(a, lobe)| {
                            let r = self.make_record(s, (tp, pp), gamma, &a, lobe);
                            let (e, _) = self.measure_parts(&r, &y, &dirs, &alpha, &rho);
                            (r, e)
                        })
                };
                match self.critical_angle {
                    CriticalAngle::Fixed(g) => try_angle(g).map(|(r, _)| r).ok_or_else(|| {
                        format!(
                            "a critical angle of {g}° leaves fewer than (L+1)² = {p} background \
                             samples; lower --sh-level or the angle"
                        )
                    })?,
                    CriticalAngle::Auto => {
                        // Coarse sweep every 4°, then every 1° around the best: the error curve
                        // of the paper's Fig. 6 is smooth on this scale.
                        let mut best: Option<(IncidentRecord, f64)> = None;
                        let consider = |g: f64, best: &mut Option<(IncidentRecord, f64)>| {
                            if let Some((r, e)) = try_angle(g) {
                                if best.as_ref().is_none_or(|b| e < b.1) {
                                    *best = Some((r, e));
                                }
                            }
                        };
                        for g in (1..=89).step_by(4) {
                            consider(g as f64, &mut best);
                        }
                        if let Some(g0) = best.as_ref().map(|b| b.0.critical_angle as f64) {
                            for d in [-3.0, -2.0, -1.0, 1.0, 2.0, 3.0] {
                                let g = g0 + d;
                                if (0.5..=89.5).contains(&g) {
                                    consider(g, &mut best);
                                }
                            }
                        }
                        match best {
                            Some((r, _)) => r,
                            None => {
                                return Err(format!(
                                    "no critical angle leaves (L+1)² = {p} background samples \
                                     among {n} outgoing directions; lower --sh-level"
                                ))
                            }
                        }
                    }
                }
            }
        };
        let mut record = candidate;
        let (sq_error, sq_reference) = self.measure(&record, s);
        record.rel_error = stored_error(rel(sq_error, sq_reference));
        Ok(Fitted {
            met: true,
            record,
            sq_error,
            sq_reference,
        })
    }

    /// SH background outside `gamma` degrees, then a Gaussian per spectral term inside.
    fn fit_hybrid(
        &self,
        y: &DMatrix<f64>,
        coeffs: &DMatrix<f64>,
        alpha: &[f64],
        gamma_deg: f64,
    ) -> Option<(DMatrix<f64>, Vec<Lobe>)> {
        let gamma = gamma_deg.to_radians();
        let background: Vec<usize> = (0..alpha.len()).filter(|&i| alpha[i] > gamma).collect();
        if background.len() < y.ncols() {
            return None;
        }
        let yb = y.select_rows(background.iter());
        let cb = coeffs.select_rows(background.iter());
        let a = lstsq(&yb, &cb);
        let residual = coeffs - y * &a;
        let inside: Vec<usize> = (0..alpha.len()).filter(|&i| alpha[i] <= gamma).collect();
        let k = coeffs.ncols();
        let mut amplitude = vec![0.0f32; k];
        let mut width = vec![1.0f32; k];
        let mut any = false;
        if let Some(&closest) = inside
            .iter()
            .min_by(|&&i, &&j| alpha[i].total_cmp(&alpha[j]))
        {
            for kk in 0..k {
                if let Some((pk, bk)) = fit_gaussian(&inside, alpha, closest, |i| residual[(i, kk)])
                {
                    amplitude[kk] = pk as f32;
                    width[kk] = bk as f32;
                    any = true;
                }
            }
        }
        let lobes = if any {
            vec![Lobe {
                kind: LobeKind::AngleGaussian,
                amplitude,
                params: width,
            }]
        } else {
            Vec::new()
        };
        Some((a, lobes))
    }

    fn make_record(
        &self,
        s: &IncidentSamples,
        peak: (f64, f64),
        critical_angle: f64,
        a: &DMatrix<f64>,
        lobes: Vec<Lobe>,
    ) -> IncidentRecord {
        let (p, k) = (a.nrows(), a.ncols());
        let mut sh = Vec::with_capacity(k * p);
        for kk in 0..k {
            for j in 0..p {
                sh.push(a[(j, kk)] as f32);
            }
        }
        // At the pole φ means nothing; store 0 so equal peaks give equal bytes.
        let phi_p = if peak.0 < 1e-9 { 0.0 } else { peak.1 };
        IncidentRecord {
            terms: k,
            sh_level: self.sh.level(),
            precision: crate::material::Precision::F32,
            theta_i: s.theta_i as f32,
            phi_i: s.phi_i as f32,
            theta_p: (peak.0 + 0.0) as f32,
            // f32 rounding can carry 359.99999 to 360: keep φ in [0, 360).
            phi_p: wrap_phi(phi_p as f32 as f64) as f32 % 360.0,
            rel_error: 0.0,
            critical_angle: critical_angle as f32,
            sh,
            lobes,
        }
    }

    /// Σ(ρ̂ − ρ)² and Σρ² of a record (as stored, f32 or f16-rounded, and decoded: clamped at 0)
    /// against the samples.
    pub fn measure(&self, r: &IncidentRecord, s: &IncidentSamples) -> (f64, f64) {
        let peak = dir_from_deg(r.theta_p as f64, r.phi_p as f64);
        let dirs: Vec<[f64; 3]> = s
            .directions
            .iter()
            .map(|d| dir_from_deg(d[0], d[1]))
            .collect();
        let alpha: Vec<f64> = dirs.iter().map(|v| angle_between(*v, peak)).collect();
        let y = self.sh_matrix(&dirs);
        let rho = DMatrix::from_row_slice(s.directions.len(), self.w, &s.values);
        self.measure_parts(r, &y, &dirs, &alpha, &rho)
    }

    fn measure_parts(
        &self,
        r: &IncidentRecord,
        y: &DMatrix<f64>,
        dirs: &[[f64; 3]],
        alpha: &[f64],
        rho: &DMatrix<f64>,
    ) -> (f64, f64) {
        let k = r.terms;
        let p = crate::sh::sh_count(r.sh_level);
        // A is stored k-major: column-major P×K is exactly that layout.
        let a = DMatrix::from_iterator(p, k, r.sh.iter().map(|v| *v as f64));
        let mut c = y.columns(0, p) * a;
        for lobe in &r.lobes {
            match lobe.kind {
                LobeKind::CosinePower => {
                    for (i, al) in alpha.iter().enumerate() {
                        let g = al.cos().max(0.0).powf(lobe.params[0] as f64);
                        for kk in 0..k {
                            c[(i, kk)] += lobe.amplitude[kk] as f64 * g;
                        }
                    }
                }
                LobeKind::AngleGaussian => {
                    for (i, al) in alpha.iter().enumerate() {
                        for kk in 0..k {
                            c[(i, kk)] += lobe.amplitude[kk] as f64
                                * (-al * al / lobe.params[kk] as f64).exp();
                        }
                    }
                }
                LobeKind::Microfacet | LobeKind::MicrofacetSin2 => {
                    let wi = dir_from_deg(r.theta_i as f64, r.phi_i as f64);
                    let sin2 = lobe.kind == LobeKind::MicrofacetSin2;
                    for (i, d) in dirs.iter().enumerate() {
                        let v = crate::lobes::microfacet_variants_with(&lobe.params, wi, *d, sin2);
                        for kk in 0..k {
                            c[(i, kk)] += (0..4)
                                .map(|j| lobe.amplitude[j * k + kk] as f64 * v[j])
                                .sum::<f64>();
                        }
                    }
                }
            }
        }
        // Clamped at 0 as the decoder returns it (spec/EVALUATION.md, "Reconstruction"), so
        // every stored error is that of the values a decoder gives.
        let approx = (c * self.synthesis.rows(0, k)).map(|v| v.max(0.0));
        let err = (approx - rho).norm_squared();
        (err, rho.norm_squared())
    }
}

/// The error as a record stores it: finite, so +∞ (an all-zero reference not reproduced) is
/// stored as the largest f32.
pub fn stored_error(e: f64) -> f32 {
    (e as f32).min(f32::MAX)
}

/// The K×W matrix taking a sampled spectrum to its coefficients: the paper's trapezoidal Eq. (5)
/// for its Fourier basis, least squares (the pseudo-inverse of the W×K synthesis matrix, by SVD)
/// for every other basis.
pub fn spectral_projection(space: &SpectralSpace, wavelengths: &[f64]) -> DMatrix<f64> {
    let (k, w) = (space.terms, wavelengths.len());
    match space.basis {
        crate::spectral::SpectralBasis::PeriodicFourier => {
            DMatrix::from_row_slice(k, w, &space.fourier_projection(wavelengths))
        }
        _ => {
            let s = DMatrix::from_row_slice(w, k, &space.synthesis(wavelengths));
            lstsq(&s, &DMatrix::identity(w, w))
        }
    }
}

/// sqrt(Σ(ρ̂−ρ)² / Σρ²); 0 for an all-zero reference reproduced exactly, +∞ if not.
pub fn rel(sq_error: f64, sq_reference: f64) -> f64 {
    if sq_reference > 0.0 {
        (sq_error / sq_reference).sqrt()
    } else if sq_error == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}

/// Least squares by SVD (rank-revealing: a rank-deficient system gets the minimum-norm answer).
/// Columns are scaled to unit norm first, so a narrow lobe's small column is not mistaken for a
/// dependent one next to the SH columns, and scaled back after.
pub fn lstsq(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let norms: Vec<f64> = a
        .column_iter()
        .map(|c| {
            let n = c.norm();
            if n > 0.0 && n.is_finite() {
                n
            } else {
                1.0
            }
        })
        .collect();
    let mut scaled = a.clone();
    for (j, n) in norms.iter().enumerate() {
        scaled.column_mut(j).scale_mut(1.0 / n);
    }
    let svd = scaled.svd(true, true);
    let smax = svd.singular_values.iter().cloned().fold(0.0, f64::max);
    // Coefficients are stored in f32 or f16: combinations the samples barely determine must not
    // get huge cancelling coefficients, so tiny singular values count as zero.
    let tol = smax * 1e-9;
    let mut x = svd
        .solve(b, tol)
        .unwrap_or_else(|_| DMatrix::zeros(a.ncols(), b.ncols()));
    for (j, n) in norms.iter().enumerate() {
        x.row_mut(j).scale_mut(1.0 / n);
    }
    x
}

/// Fits sign·exp(A + Cα²) to the residual over `inside` (the paper's Eqs. 8–11 with the centre
/// fixed at the peak direction): returns (p, b) with b = −1/C, or None if there is no peak.
fn fit_gaussian(
    inside: &[usize],
    alpha: &[f64],
    closest: usize,
    residual: impl Fn(usize) -> f64,
) -> Option<(f64, f64)> {
    let sign = residual(closest).signum();
    if residual(closest) == 0.0 {
        return None;
    }
    let pts: Vec<(f64, f64)> = inside
        .iter()
        .filter_map(|&i| {
            let v = sign * residual(i);
            (v > 0.0).then(|| (alpha[i] * alpha[i], v.ln()))
        })
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let m = DMatrix::from_fn(pts.len(), 2, |r, c| if c == 0 { 1.0 } else { pts[r].0 });
    let v = DMatrix::from_fn(pts.len(), 1, |r, _| pts[r].1);
    let x = lstsq(&m, &v);
    let (a, c) = (x[(0, 0)], x[(1, 0)]);
    if c.is_nan() || c >= 0.0 {
        return None;
    }
    let (p, b) = (sign * a.exp(), -1.0 / c);
    (p.is_finite() && b.is_finite() && b > 0.0 && (b as f32) > 0.0 && (p as f32).is_finite())
        .then_some((p, b))
}

/// The paper's algorithm for the mirror-reflection direction (Sec. 2.3, steps 1–4): log-quadratic
/// regressions along each θo row (giving φ centres) and each φo column (giving θ centres) among
/// the samples that stand well above the rest, averaged. Samples are taken relative to the
/// median level (so a diffuse floor does not flatten the log-Gaussian). Scattered directions,
/// where rows and columns hold too few points, use one 2-D log-quadratic fit in the tangent
/// plane; if no peak stands out the geometric mirror direction is used.
///
/// Beyond the paper: the estimate is then compared with the mirror direction itself, and the one
/// about which the bright samples fall off more like a Gaussian of the angle (the smaller
/// residual of ln(level − median) against angle²) is kept. Rows and columns cannot locate a
/// peak past the last sampled θo (grazing incidence: at 89° the samples stop at 87.5°), where
/// the mirror direction is usually right.
pub fn find_peak_direction(s: &IncidentSamples, mirror: (f64, f64)) -> (f64, f64) {
    let Some(bright) = BrightSamples::of(s) else {
        return mirror; // no peak stands out
    };
    let found = locate_peak(s, &bright, mirror);
    let BrightSamples {
        level,
        base,
        picked,
    } = &bright;
    if found == mirror || picked.len() < 3 {
        return found;
    }
    // Residual of the best fit ln(level − base) = a − c·angle², over the bright samples.
    let residual = |centre: (f64, f64)| -> f64 {
        let c = dir_from_deg(centre.0, centre.1);
        let m = DMatrix::from_fn(picked.len(), 2, |r, k| {
            let d = s.directions[picked[r]];
            let a2 = angle_between(dir_from_deg(d[0], d[1]), c).powi(2);
            [1.0, a2][k]
        });
        let v = DMatrix::from_fn(picked.len(), 1, |r, _| (level[picked[r]] - *base).ln());
        let x = lstsq(&m, &v);
        if x[(1, 0)].is_nan() || x[(1, 0)] >= 0.0 {
            return f64::INFINITY; // not falling off away from this centre
        }
        (&m * &x - &v).norm_squared()
    };
    if residual(mirror) < residual(found) {
        mirror
    } else {
        found
    }
}

/// The samples standing well above the rest: their spectrum-averaged levels, the median level,
/// and the indices above half-way between the median and the maximum. Computed once for both
/// the paper's estimate and the check against the mirror direction.
struct BrightSamples {
    level: Vec<f64>,
    base: f64,
    picked: Vec<usize>,
}

impl BrightSamples {
    /// None when no sample stands above the median (or the levels are not numbers).
    fn of(s: &IncidentSamples) -> Option<Self> {
        let w = s.values.len() / s.directions.len();
        let level: Vec<f64> = s
            .values
            .chunks(w)
            .map(|c| c.iter().sum::<f64>() / w as f64)
            .collect();
        let mut sorted = level.clone();
        sorted.sort_by(f64::total_cmp);
        let base = sorted[sorted.len() / 2];
        let max = sorted[sorted.len() - 1];
        if max.is_nan() || max <= base {
            return None;
        }
        let threshold = base + 0.5 * (max - base);
        let picked = (0..level.len()).filter(|&i| level[i] > threshold).collect();
        Some(BrightSamples {
            level,
            base,
            picked,
        })
    }
}

fn locate_peak(s: &IncidentSamples, bright: &BrightSamples, mirror: (f64, f64)) -> (f64, f64) {
    let BrightSamples {
        level,
        base,
        picked,
    } = bright;
    let lnv = |i: usize| (level[i] - base).ln();

    // Step 2: rows of equal θo give φ centres, as offsets from the mirror azimuth so the wrap
    // at 0/360° does not split a peak. Rows are symmetric about the peak, so their average is
    // unbiased.
    let group = |key: usize| {
        let mut groups: std::collections::BTreeMap<u64, Vec<usize>> = Default::default();
        for &i in picked {
            groups
                .entry(s.directions[i][key].to_bits())
                .or_default()
                .push(i);
        }
        groups
    };
    let ln_of = |m: &[usize]| m.iter().map(|&i| lnv(i)).collect::<Vec<_>>();
    let phi_centres: Vec<f64> = group(0)
        .values()
        .filter(|m| m.len() >= 3)
        .filter_map(|m| {
            let x: Vec<f64> = m
                .iter()
                .map(|&i| phi_delta(s.directions[i][1], mirror.1))
                .collect();
            quadratic_centre(&x, &ln_of(m))
        })
        .collect();
    if !phi_centres.is_empty() {
        let phi_p = wrap_phi(mirror.1 + phi_centres.iter().sum::<f64>() / phi_centres.len() as f64);
        // Step 3, restricted: a column of equal φo peaks where its meridian passes closest to
        // the peak, which is nearer the pole than the peak unless the meridian runs through
        // it. Averaging every column (the paper's literal step 4) biases θ low (by 4° at
        // n = 15), so only the columns nearest φp are used, nearest first.
        let mut columns: Vec<(f64, Vec<usize>)> = group(1)
            .into_values()
            .filter(|m| m.len() >= 3)
            .map(|m| (phi_delta(s.directions[m[0]][1], phi_p).abs(), m))
            .collect();
        columns.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut theta_centres = Vec::new();
        let mut nearest = f64::INFINITY;
        for (d, m) in &columns {
            if *d > nearest + 1e-9 {
                break;
            }
            let x: Vec<f64> = m.iter().map(|&i| s.directions[i][0]).collect();
            if let Some(c) = quadratic_centre(&x, &ln_of(m)) {
                theta_centres.push(c);
                nearest = nearest.min(*d);
            }
        }
        if !theta_centres.is_empty() {
            let t = theta_centres.iter().sum::<f64>() / theta_centres.len() as f64;
            return (t.clamp(0.0, 90.0), phi_p);
        }
    }
    peak_2d(s, picked, &lnv, mirror).unwrap_or(mirror)
}

/// Centre −B/(2C) of ln f = A + Bx + Cx², if the fit opens downward and the centre lies within
/// the points' span.
fn quadratic_centre(x: &[f64], lnf: &[f64]) -> Option<f64> {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(*v), h.max(*v))
        });
    if hi - lo <= 0.0 {
        return None;
    }
    let m = DMatrix::from_fn(x.len(), 3, |r, c| x[r].powi(c as i32));
    let v = DMatrix::from_column_slice(x.len(), 1, lnf);
    let s = lstsq(&m, &v);
    let (b, c) = (s[(1, 0)], s[(2, 0)]);
    if c.is_nan() || c >= 0.0 {
        return None;
    }
    let centre = -b / (2.0 * c);
    (centre.is_finite() && centre >= lo && centre <= hi).then_some(centre)
}

/// 2-D log-quadratic fit around the brightest sample in tangent-plane coordinates.
fn peak_2d(
    s: &IncidentSamples,
    picked: &[usize],
    lnv: &dyn Fn(usize) -> f64,
    mirror: (f64, f64),
) -> Option<(f64, f64)> {
    if picked.len() < 6 {
        return None;
    }
    let m = dir_from_deg(mirror.0, mirror.1);
    // Orthonormal tangent frame at the mirror direction.
    let helper = if m[2].abs() < 0.9 {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let e1 = crate::angles::normalize(cross(helper, m))?;
    let e2 = cross(m, e1);
    let uv: Vec<(f64, f64)> = picked
        .iter()
        .map(|&i| {
            let d = dir_from_deg(s.directions[i][0], s.directions[i][1]);
            (crate::angles::dot(d, e1), crate::angles::dot(d, e2))
        })
        .collect();
    let a = DMatrix::from_fn(uv.len(), 6, |r, c| {
        let (u, v) = uv[r];
        [1.0, u, v, u * u, v * v, u * v][c]
    });
    let b = DMatrix::from_fn(uv.len(), 1, |r, _| lnv(picked[r]));
    let x = lstsq(&a, &b);
    let (bu, bv, cuu, cvv, cuv) = (x[(1, 0)], x[(2, 0)], x[(3, 0)], x[(4, 0)], x[(5, 0)]);
    // Stationary point of the quadratic; it must be a maximum.
    let det = 4.0 * cuu * cvv - cuv * cuv;
    if !(cuu < 0.0 && det > 0.0) {
        return None;
    }
    let u = (-2.0 * cvv * bu + cuv * bv) / det;
    let v = (cuv * bu - 2.0 * cuu * bv) / det;
    if (u * u + v * v).is_nan() || u * u + v * v >= 1.0 {
        return None;
    }
    let w = (1.0 - u * u - v * v).sqrt();
    let d = [
        u * e1[0] + v * e2[0] + w * m[0],
        u * e1[1] + v * e2[1] + w * m[1],
        u * e1[2] + v * e2[2] + w * m[2],
    ];
    let (t, p) = deg_from_dir(d);
    Some((t.clamp(0.0, 90.0), p))
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
