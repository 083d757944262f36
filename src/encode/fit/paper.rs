//! The paper's method (Sec. 2.3) and its direct-SH baseline, per incident direction: each
//! spectral coefficient split into a smooth SH background fitted outside a critical angle and a
//! Gaussian peak inside it, the angle chosen by the error (the paper's Fig. 6).

use super::context::{lstsq, FitContext, Fitted};
use super::options::{CriticalAngle, PeakMode};
use super::peak::find_peak_direction;
use crate::encode::metrics::{rel, stored_error};
use crate::encode::samples::IncidentSamples;
use crate::model::angles::{angle_between, dir_from_deg, mirror_deg};
use crate::model::material::{IncidentRecord, Lobe, LobeKind};
use nalgebra::DMatrix;

/// Fits one incident direction by the paper's split ([`PeakMode::Paper`]) or by SH alone
/// ([`PeakMode::None`]).
pub(super) fn fit_paper(ctx: &FitContext, s: &IncidentSamples) -> Result<Fitted, String> {
    let n = s.directions.len();
    let p = ctx.sh.count();
    let dirs: Vec<[f64; 3]> = s
        .directions
        .iter()
        .map(|d| dir_from_deg(d[0], d[1]))
        .collect();
    let rho = DMatrix::from_row_slice(n, ctx.w, &s.values);
    // N×K spectral coefficients of every outgoing spectrum.
    let coeffs = &rho * ctx.projection.transpose();
    let y = ctx.sh_matrix(&dirs);
    let (mt, mp) = mirror_deg(s.theta_i, s.phi_i);
    let candidate = match ctx.peak {
        PeakMode::Joint => unreachable!("handled above"),
        PeakMode::None => {
            let a = lstsq(&y, &coeffs);
            ctx.make_record(s, (mt, mp), 0.0, &a, Vec::new())
        }
        PeakMode::Paper => {
            let (tp, pp) = find_peak_direction(s, (mt, mp));
            let peak = dir_from_deg(tp, pp);
            let alpha: Vec<f64> = dirs.iter().map(|d| angle_between(*d, peak)).collect();
            let try_angle = |gamma: f64| {
                fit_hybrid(&y, &coeffs, &alpha, gamma).map(|(a, lobe)| {
                    let r = ctx.make_record(s, (tp, pp), gamma, &a, lobe);
                    let (e, _) = ctx.measure_parts(&r, &y, &dirs, &alpha, &rho);
                    (r, e)
                })
            };
            match ctx.critical_angle {
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
    let (sq_error, sq_reference) = ctx.measure(&record, s);
    record.rel_error = stored_error(rel(sq_error, sq_reference));
    Ok(Fitted {
        met: true,
        record,
        sq_error,
        sq_reference,
        held_out: None,
        below_floor: false,
    })
}

/// SH background outside `gamma` degrees, then a Gaussian per spectral term inside.
fn fit_hybrid(
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
            if let Some((pk, bk)) = fit_gaussian(&inside, alpha, closest, |i| residual[(i, kk)]) {
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
