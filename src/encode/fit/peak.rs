//! Finding the specular peak's direction among scattered or gridded samples (the paper's
//! Sec. 2.3, steps 1–4, checked against the mirror direction).

use super::context::lstsq;
use crate::encode::samples::IncidentSamples;
use crate::model::angles::{angle_between, deg_from_dir, dir_from_deg, phi_delta, wrap_phi};
use nalgebra::DMatrix;

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
    let e1 = crate::model::angles::normalize(cross(helper, m))?;
    let e2 = cross(m, e1);
    let uv: Vec<(f64, f64)> = picked
        .iter()
        .map(|&i| {
            let d = dir_from_deg(s.directions[i][0], s.directions[i][1]);
            (
                crate::model::angles::dot(d, e1),
                crate::model::angles::dot(d, e2),
            )
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
