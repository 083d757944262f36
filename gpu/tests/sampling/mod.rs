//! What the sampling tests share (`device.rs`'s sampling tests and `translate.rs`): compute entry
//! points for `sbrdf_pdf` and `sbrdf_sample`, and the χ² test of `tests/sampling.rs` (copied: the
//! root crate's integration tests are not a library this crate can use).

#![allow(dead_code)] // each test file uses its own part of this module

use std::f64::consts::PI;

/// Two more entry points, appended after `common::ENTRY_POINTS`, for the prelude's queries:
/// `pdf_at` gives `sbrdf_pdf(base, wi, wo)` (one f32 per query); `sample_dir` gives
/// `sbrdf_sample(base, wi, wo.xy)` (four f32: direction, pdf), the query's `wo.xy` carrying u.
pub const SAMPLING_ENTRY_POINTS: &str = r#"
@compute @workgroup_size(64)
fn pdf_at(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&queries)) { return; }
    let q = queries[i];
    results[i] = sbrdf_pdf(q.base, q.wi, q.wo);
}

@compute @workgroup_size(64)
fn sample_dir(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&queries)) { return; }
    let q = queries[i];
    let s = sbrdf_sample(q.base, q.wi, q.wo.xy);
    results[4u * i] = s.x;
    results[4u * i + 1u] = s.y;
    results[4u * i + 2u] = s.z;
    results[4u * i + 3u] = s.w;
}
"#;

/// The entry points' names, in the order they appear in the module after `common::ENTRY_POINTS`.
pub const SAMPLING_ENTRIES: [&str; 2] = ["pdf_at", "sample_dir"];

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9: ~1e-15 relative).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularised upper incomplete gamma function Q(a, x): the χ² test's p-value is
/// Q(dof/2, χ²/2). Series below a + 1, Lentz's continued fraction above (Numerical Recipes).
fn gamma_q(a: f64, x: f64) -> f64 {
    let lead = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * lead
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        lead * h
    }
}

/// Pearson's χ² of observed against expected counts, bins expecting fewer than 5 pooled (the
/// usual condition for the χ² approximation): (statistic, degrees of freedom, p-value); None when
/// the pool is too small for a term of its own yet holds more than 5 + 5× its expectation.
pub fn chi2(observed: &[u64], expected: &[f64]) -> Option<(f64, usize, f64)> {
    let (mut stat, mut bins) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            pool_o += o as f64;
            pool_e += e;
        } else {
            stat += (o as f64 - e).powi(2) / e;
            bins += 1;
        }
    }
    if pool_e >= 5.0 {
        stat += (pool_o - pool_e).powi(2) / pool_e;
        bins += 1;
    } else if pool_o > 5.0 + 5.0 * pool_e {
        return None;
    }
    let dof = bins.max(2) - 1;
    Some((stat, dof, gamma_q(dof as f64 / 2.0, stat / 2.0)))
}

/// Midpoint cells of an nt × np grid in (θ, φ) over the upper hemisphere: (θ index, φ index,
/// centre direction rounded to f32, exact solid angle).
pub fn hemisphere(nt: usize, np: usize) -> Vec<(usize, usize, [f32; 3], f64)> {
    let dt = 0.5 * PI / nt as f64;
    let dp = 2.0 * PI / np as f64;
    let mut cells = Vec::with_capacity(nt * np);
    for i in 0..nt {
        let area = ((i as f64 * dt).cos() - ((i + 1) as f64 * dt).cos()) * dp;
        let t = (i as f64 + 0.5) * dt;
        for j in 0..np {
            let p = (j as f64 + 0.5) * dp;
            let w = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
            cells.push((i, j, [w[0] as f32, w[1] as f32, w[2] as f32], area));
        }
    }
    cells
}

/// The (θ, φ) bin of a direction on an nt × np grid over the upper hemisphere.
pub fn bin_of(w: [f32; 3], nt: usize, np: usize) -> usize {
    let w = [w[0] as f64, w[1] as f64, w[2] as f64];
    let (t, p) = sbrdf::model::angles::deg_from_dir(w);
    let i = ((t / 90.0 * nt as f64) as usize).min(nt - 1);
    let j = ((p / 360.0 * np as f64) as usize).min(np - 1);
    i * np + j
}

/// The angle between two directions (radians), 2·atan2(|a − b|, |a + b|) of the normalised
/// vectors: accurate for small angles.
pub fn angle(a: [f32; 3], b: [f32; 3]) -> f64 {
    let n = |v: [f32; 3]| {
        let v = [v[0] as f64, v[1] as f64, v[2] as f64];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    };
    let (a, b) = (n(a), n(b));
    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    let s = ((a[0] + b[0]).powi(2) + (a[1] + b[1]).powi(2) + (a[2] + b[2]).powi(2)).sqrt();
    2.0 * d.atan2(s)
}
