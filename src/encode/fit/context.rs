//! What every per-incidence fit shares: the fit context (spectral projection and synthesis, the
//! SH basis, the mode), a fitted record with the sums behind its error, measuring a record
//! against samples as a decoder would, and least squares.

use super::options::{CriticalAngle, JointOptions, LobeFamily, PeakMode};
use crate::encode::metrics::ErrorSums;
use crate::encode::samples::IncidentSamples;
use crate::model::angles::{angle_between, dir_from_deg, wrap_phi};
use crate::model::lobes::cosine_power_of;
use crate::model::material::{IncidentRecord, Lobe, LobeKind};
use crate::model::sh::ShBasis;
use crate::model::spectral::SpectralSpace;
use nalgebra::DMatrix;

/// Everything shared by the fits of one file.
pub struct FitContext {
    /// Options of the joint fit (used when `peak` is [`PeakMode::Joint`]).
    pub joint: JointOptions,
    /// The file's spectral basis, terms and interval.
    pub spectral: SpectralSpace,
    /// The SH basis up to the file's SH level.
    pub sh: ShBasis,
    /// How the specular peak is represented.
    pub peak: PeakMode,
    /// The critical angle of the paper's split ([`PeakMode::Paper`]).
    pub critical_angle: CriticalAngle,
    /// K×W projection matrix (the paper's Eq. 5 by the trapezoidal rule).
    pub(super) projection: DMatrix<f64>,
    /// K×W: ρ(λ_w) = Σ_k c_k synthesis[k][w].
    pub(crate) synthesis: DMatrix<f64>,
    pub(super) w: usize,
}

/// A fitted record with the sums behind its error figure, so that errors can be pooled.
pub struct Fitted {
    /// False when an error budget was given and no model met it.
    pub met: bool,
    /// The fitted record.
    pub record: IncidentRecord,
    /// Σ(ρ̂ − ρ)² and Σρ² over this incidence's samples.
    pub sq_error: f64,
    /// Σρ² over this incidence's samples (see `sq_error`).
    pub sq_reference: f64,
    /// The record's leave-one-out error at its samples (the joint fit; None for the paper's
    /// split, whose peak and critical angle are not linear in the samples).
    pub held_out: Option<ErrorSums>,
    /// True when the budget lies below this incidence's held-out floor: no model met it at
    /// samples the fit did not see.
    pub below_floor: bool,
}

impl FitContext {
    /// The context for a file with this spectral space, input `wavelengths` (nm), SH level and
    /// peak mode; the joint fit's options start as Gaussian lobes up to `sh_level`, f32, no
    /// budget (the encoder sets its own).
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
            joint: JointOptions {
                max_sh_level: sh_level,
                families: vec![LobeFamily::Gaussian],
                precision: crate::model::Precision::F32,
                max_error: None,
                held_out: false,
                log_epsilon: 1e-12,
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

    pub(super) fn make_record(
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
            precision: crate::model::Precision::F32,
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

    pub(super) fn measure_parts(
        &self,
        r: &IncidentRecord,
        y: &DMatrix<f64>,
        dirs: &[[f64; 3]],
        alpha: &[f64],
        rho: &DMatrix<f64>,
    ) -> (f64, f64) {
        // Clamped at 0 as the decoder returns it (spec/EVALUATION.md, "Reconstruction"), so
        // every stored error is that of the values a decoder gives.
        let approx = self.reconstruct(r, y, dirs, alpha).map(|v| v.max(0.0));
        let err = (approx - rho).norm_squared();
        (err, rho.norm_squared())
    }

    /// The lowest value a record takes (before the decoder's clamp) over its whole outgoing
    /// hemisphere at its own incidence: θo every 2.5° from 1.25°, φo every 5°, every wavelength.
    pub fn minimum_on_hemisphere(&self, r: &IncidentRecord) -> f64 {
        let peak = dir_from_deg(r.theta_p as f64, r.phi_p as f64);
        let dirs: Vec<[f64; 3]> = (0..36)
            .flat_map(|a| (0..72).map(move |b| dir_from_deg(1.25 + 2.5 * a as f64, 5.0 * b as f64)))
            .collect();
        let alpha: Vec<f64> = dirs.iter().map(|v| angle_between(*v, peak)).collect();
        let y = self.sh_matrix(&dirs);
        self.reconstruct(r, &y, &dirs, &alpha)
            .iter()
            .cloned()
            .fold(f64::INFINITY, f64::min)
    }

    /// The record's values (not clamped) at `dirs`: rows are directions, columns wavelengths.
    fn reconstruct(
        &self,
        r: &IncidentRecord,
        y: &DMatrix<f64>,
        dirs: &[[f64; 3]],
        alpha: &[f64],
    ) -> DMatrix<f64> {
        let k = r.terms;
        let p = crate::model::sh::sh_count(r.sh_level);
        // A is stored k-major: column-major P×K is exactly that layout.
        let a = DMatrix::from_iterator(p, k, r.sh.iter().map(|v| *v as f64));
        let mut c = y.columns(0, p) * a;
        for lobe in &r.lobes {
            match lobe.kind {
                LobeKind::CosinePower => {
                    for (i, al) in alpha.iter().enumerate() {
                        let g = cosine_power_of(lobe.params[0] as f64, al.cos());
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
                LobeKind::Microfacet | LobeKind::MicrofacetSin2 | LobeKind::MicrofacetAniso => {
                    let wi = dir_from_deg(r.theta_i as f64, r.phi_i as f64);
                    for (i, d) in dirs.iter().enumerate() {
                        let v = crate::model::lobes::microfacet_kind_variants(
                            lobe.kind,
                            &lobe.params,
                            wi,
                            *d,
                        );
                        for kk in 0..k {
                            c[(i, kk)] += (0..4)
                                .map(|j| lobe.amplitude[j * k + kk] as f64 * v[j])
                                .sum::<f64>();
                        }
                    }
                }
            }
        }
        c * self.synthesis.rows(0, k)
    }
}

/// The K×W matrix taking a sampled spectrum to its coefficients: the paper's trapezoidal Eq. (5)
/// for its Fourier basis, least squares (the pseudo-inverse of the W×K synthesis matrix, by SVD)
/// for every other basis.
pub fn spectral_projection(space: &SpectralSpace, wavelengths: &[f64]) -> DMatrix<f64> {
    let (k, w) = (space.terms, wavelengths.len());
    match space.basis {
        crate::model::spectral::SpectralBasis::PeriodicFourier => {
            DMatrix::from_row_slice(k, w, &space.fourier_projection(wavelengths))
        }
        _ => {
            let s = DMatrix::from_row_slice(w, k, &space.synthesis(wavelengths));
            lstsq(&s, &DMatrix::identity(w, w))
        }
    }
}

/// Least squares by SVD (rank-revealing: a rank-deficient system gets the minimum-norm answer).
/// Columns are scaled to unit norm first, so a narrow lobe's small column is not mistaken for a
/// dependent one next to the SH columns, and scaled back after.
pub fn lstsq(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    lstsq_with_leverage(a, b, false).0
}

/// [`lstsq`], and with `leverage` the diagonal of the hat matrix A·A⁺ (each sample's leverage
/// h_i ∈ [0, 1], from the same SVD and tolerance): a sample's leave-one-out residual is its
/// residual divided by 1 − h_i.
pub fn lstsq_with_leverage(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    leverage: bool,
) -> (DMatrix<f64>, Vec<f64>) {
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
    let mut h = Vec::new();
    if leverage {
        let u = svd.u.as_ref().expect("U requested");
        h = vec![0.0; a.nrows()];
        for (j, &sv) in svd.singular_values.iter().enumerate() {
            if sv > tol {
                for (i, hi) in h.iter_mut().enumerate() {
                    *hi += u[(i, j)] * u[(i, j)];
                }
            }
        }
    }
    (x, h)
}
