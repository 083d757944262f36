//! Joint fitting, beyond the paper: the SH background and the lobe amplitudes are solved
//! together by linear least squares for given lobe shape parameters, and the shape parameters
//! are searched on top (variable projection). No critical angle is needed.
//!
//! Per incidence, with the spectral synthesis matrix S (W×K) factored S = Q·R (Q orthonormal),
//! the samples ρ (N×W) split into Cq = ρ·Q (N×K) and a part no model in this basis can
//! represent. For a design matrix M = [Y | G(θ)] (SH functions and lobe shapes at the N
//! outgoing directions) the best coefficients are M⁺·Cq, and the error is
//! ‖Cq − M·M⁺·Cq‖² + ‖ρ‖² − ‖Cq‖²: the relative-error objective of every record, measured on
//! all samples with equal weight. Y is fixed per incidence, so it is projected out once and a
//! shape candidate costs O(N·(L+1)²) instead of a new factorisation.

use crate::angles::{angle_between, dir_from_deg, mirror_deg};
use crate::fit::{find_peak_direction, lstsq, rel, stored_error, FitContext, Fitted};
use crate::material::{IncidentRecord, Lobe, LobeKind, Precision};
use crate::samples::IncidentSamples;
use nalgebra::DMatrix;

/// Smallest and largest Gaussian width searched, rad² (n ≈ 2/b for a Phong lobe: n from 0.5
/// to 2·10⁷).
const WIDTH_RANGE: (f64, f64) = (1e-7, 4.0);

/// Orthonormal basis of the column space of `m` (rank-revealing, via SVD).
fn column_space(m: &DMatrix<f64>) -> DMatrix<f64> {
    let svd = m.clone().svd(true, false);
    let u = svd.u.expect("U requested");
    let smax = svd.singular_values.iter().cloned().fold(0.0, f64::max);
    let tol = smax * (m.nrows().max(m.ncols()) as f64) * f64::EPSILON;
    let keep: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&i| svd.singular_values[i] > tol)
        .collect();
    u.select_columns(keep.iter())
}

/// Fits one incidence jointly. `ctx.sh` gives the SH level; the lobe is one Gaussian in the
/// angle from the peak direction with one width shared by all spectral terms.
pub fn fit_joint(ctx: &FitContext, s: &IncidentSamples) -> Result<Fitted, String> {
    let n = s.directions.len();
    let w = ctx.synthesis.ncols();
    let k = ctx.spectral.terms;
    let dirs: Vec<[f64; 3]> = s
        .directions
        .iter()
        .map(|d| dir_from_deg(d[0], d[1]))
        .collect();
    let rho = DMatrix::from_row_slice(n, w, &s.values);
    // S = Q R with Q orthonormal over the wavelength samples.
    let synthesis = ctx.synthesis.transpose(); // W×K
    let qr = synthesis.clone().qr();
    let (q, r) = (qr.q(), qr.r());
    if (0..k).any(|i| r[(i, i)].abs() <= 1e-12 * r[(0, 0)].abs().max(1e-300)) {
        return Err(format!(
            "the {k} spectral basis functions are not independent on the {w} wavelength samples"
        ));
    }
    let cq = &rho * &q; // N×K

    let p = ctx.sh.count();
    let mut y = DMatrix::zeros(n, p);
    let mut row = vec![0.0; p];
    for (i, d) in dirs.iter().enumerate() {
        ctx.sh.eval(*d, &mut row);
        for j in 0..p {
            y[(i, j)] = row[j];
        }
    }
    let qy = column_space(&y);
    let c_perp = &cq - &qy * (qy.transpose() * &cq);

    let (mt, mp) = mirror_deg(s.theta_i, s.phi_i);
    let (tp, pp) = find_peak_direction(s, (mt, mp));
    let peak = dir_from_deg(tp, pp);
    let alpha2: Vec<f64> = dirs
        .iter()
        .map(|d| angle_between(*d, peak).powi(2))
        .collect();

    // Error reduction from adding the lobe of width b, after the SH part is projected out.
    let gain = |log_b: f64| -> f64 {
        let b = log_b.exp();
        let g = DMatrix::from_iterator(n, 1, alpha2.iter().map(|a| (-a / b).exp()));
        let g_perp = &g - &qy * (qy.transpose() * &g);
        let norm2 = g_perp.norm_squared();
        if norm2 <= 1e-300 {
            return 0.0;
        }
        (g_perp.transpose() * &c_perp).norm_squared() / norm2
    };
    let (lo, hi) = (WIDTH_RANGE.0.ln(), WIDTH_RANGE.1.ln());
    let steps = 48;
    let mut best = (f64::NEG_INFINITY, lo);
    for i in 0..=steps {
        let x = lo + (hi - lo) * i as f64 / steps as f64;
        let v = gain(x);
        if v > best.0 {
            best = (v, x);
        }
    }
    // Golden-section refinement around the best grid point.
    let h = (hi - lo) / steps as f64;
    let (mut a, mut b) = ((best.1 - h).max(lo), (best.1 + h).min(hi));
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - phi * (b - a), a + phi * (b - a));
    let (mut f1, mut f2) = (gain(x1), gain(x2));
    for _ in 0..40 {
        if f1 > f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - phi * (b - a);
            f1 = gain(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + phi * (b - a);
            f2 = gain(x2);
        }
    }
    let (gain_best, log_b) = if f1.max(f2) > best.0 {
        if f1 > f2 {
            (f1, x1)
        } else {
            (f2, x2)
        }
    } else {
        best
    };
    let width = log_b.exp();
    // The lobe must pay for itself: keep it only if it removes a visible share of the error.
    let use_lobe = gain_best > 1e-9 * c_perp.norm_squared().max(1e-300);

    let mut m = y.clone();
    if use_lobe {
        m = m.insert_column(p, 0.0);
        for i in 0..n {
            m[(i, p)] = (-alpha2[i] / width).exp();
        }
    }
    let xq = lstsq(&m, &cq); // cols×K in Q space
                             // Back to the basis: ρ̂ = M·Xq·Qᵀ = M·Xq·R⁻ᵀ·Sᵀ, so X = Xq·R⁻ᵀ.
    let r_inv_t = lstsq(&r.transpose(), &DMatrix::identity(k, k));
    let x = xq * r_inv_t.transpose(); // cols×K
    let mut sh = Vec::with_capacity(k * p);
    for kk in 0..k {
        for j in 0..p {
            sh.push(x[(j, kk)] as f32);
        }
    }
    let lobes = if use_lobe {
        vec![Lobe {
            kind: LobeKind::AngleGaussian,
            amplitude: (0..k).map(|kk| x[(p, kk)] as f32).collect(),
            params: vec![width as f32; k],
        }]
    } else {
        Vec::new()
    };
    let phi_p = if tp < 1e-9 { 0.0 } else { pp };
    let mut record = IncidentRecord {
        terms: k,
        sh_level: ctx.sh.level(),
        precision: Precision::F32,
        theta_i: s.theta_i as f32,
        phi_i: s.phi_i as f32,
        theta_p: (tp + 0.0) as f32,
        phi_p: crate::angles::wrap_phi(phi_p as f32 as f64) as f32 % 360.0,
        rel_error: 0.0,
        critical_angle: 0.0,
        sh,
        lobes,
    };
    let (sq_error, sq_reference) = ctx.measure(&record, s);
    record.rel_error = stored_error(rel(sq_error, sq_reference));
    Ok(Fitted {
        record,
        sq_error,
        sq_reference,
    })
}
