//! The measurement's own noise, estimated from its warped tables (issue 39, item 2): the error
//! that no budget should be asked to go below, since below it the bytes code the noise.
//!
//! How: white noise spreads evenly over an orthonormal transform's coefficients, while a
//! measurement on its warped grid is smooth, its energy in the low frequencies. So the spread
//! of the finest coefficients, the quarter of each table's 2-D DCT-II with both indices ≥ R/2,
//! measures the noise: σ = median |C| / 0.6745 (the median of |N(0, σ²)| is 0.6745 σ, and the
//! median ignores the few large coefficients that sharp features leave there; Donoho &
//! Johnstone's estimator). With σ per channel, an incidence of R × R nodes holds noise of
//! energy R²·Σ σ², and its noise floor is that energy's root over the incidence's own
//! (the L2 half of the error the encoder measures, `encode::table_error`; noise in proportion
//! to the values has a relative L1 error √(2/π) ≈ 0.8 times its relative L2).
//!
//! What it reads, measured on the shipped RGL files (`tests/noise_floor.rs`): ≤ 0.11% on the
//! clean measurements; with Gaussian noise of 0.5–2% added (in proportion to each value, or
//! evenly), 0.9–2.5 times the noise added at an incidence and 1.3–1.7 times at the worst one:
//! an upper estimate, because the tables' edges leave coefficients of the noise's size in that
//! quarter too. It errs on the side of not coding noise.

use crate::model::warped::{dct2, TableTransform};

/// The median of |N(0, 1)|.
const MEDIAN_ABS_NORMAL: f64 = 0.674_489_750_196_081_7;

/// Smallest table side with enough fine coefficients (16 in the quarter) for a median.
pub const MIN_NOISE_GRID: usize = 8;

/// The estimated noise of each of `n` incidences, relative to the incidence's L2 norm
/// (`norms[i]`): `y` holds `d` values per node, node-major, incidence-major, R × R nodes an
/// incidence in row-major order. Tables smaller than [`MIN_NOISE_GRID`] give 0 (no estimate).
pub fn noise_floor(y: &[f64], n: usize, r: usize, d: usize, norms: &[f64]) -> Vec<f64> {
    let rr = r * r;
    if r < MIN_NOISE_GRID || y.len() != n * rr * d || norms.len() != n {
        return vec![0.0; n];
    }
    let analysis = TableTransform::Dct.analysis(r);
    let (mut table, mut freq) = (vec![0.0; rr], vec![0.0; rr]);
    let half = r / 2;
    let mut fine = Vec::with_capacity((r - half) * (r - half));
    (0..n)
        .map(|i| {
            let mut energy = 0.0;
            for c in 0..d {
                for (p, t) in table.iter_mut().enumerate() {
                    *t = y[(i * rr + p) * d + c];
                }
                dct2(&analysis, r, &table, &mut freq);
                fine.clear();
                for a in half..r {
                    fine.extend(
                        freq[a * r + half..(a + 1) * r]
                            .iter()
                            .map(|v| v.abs())
                            .filter(|v| v.is_finite()),
                    );
                }
                let sigma = median(&mut fine) / MEDIAN_ABS_NORMAL;
                energy += sigma * sigma * rr as f64;
            }
            let rel = energy.sqrt() / norms[i];
            if rel.is_finite() {
                rel
            } else {
                0.0
            }
        })
        .collect()
}

/// The median (the mean of the middle two for an even count); 0 for none.
fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return 0.0;
    }
    let by = |a: &f64, b: &f64| a.total_cmp(b);
    let (_, &mut hi, _) = v.select_nth_unstable_by(n / 2, by);
    if n % 2 == 1 {
        return hi;
    }
    let lo = v[..n / 2].iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut []), 0.0);
    }

    #[test]
    fn a_smooth_table_has_no_noise_and_white_noise_is_found() {
        // One incidence, one channel, 32 × 32: a smooth bump, then the bump with white noise of
        // a known spread (a fixed linear congruential generator, Box–Muller).
        let r = 32;
        let smooth: Vec<f64> = (0..r * r)
            .map(|p| {
                let (x, y) = ((p % r) as f64 / r as f64, (p / r) as f64 / r as f64);
                1.0 + (-((x - 0.4).powi(2) + (y - 0.6).powi(2)) * 8.0).exp()
            })
            .collect();
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let clean = noise_floor(&smooth, 1, r, 1, &[norm(&smooth)]);
        assert!(clean[0] < 1e-4, "a smooth table read as noise {}", clean[0]);
        let mut state: u64 = 0x2545_f491_4f6c_dd1d;
        let mut uniform = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let sigma = 0.01;
        let noisy: Vec<f64> = smooth
            .iter()
            .map(|v| {
                let g = (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos();
                v + sigma * g
            })
            .collect();
        let est = noise_floor(&noisy, 1, r, 1, &[norm(&noisy)])[0];
        let truth = sigma * r as f64 / norm(&noisy);
        assert!(
            (0.8..1.25).contains(&(est / truth)),
            "estimated {est}, added {truth}"
        );
    }
}
