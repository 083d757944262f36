//! The error figures every part of the encoder measures itself by (`spec/EVALUATION.md`,
//! "Held-out error"): the sums behind rel and log, ε of the log figure, the fixed order the
//! folds cut, and the k-fold protocol itself, which the encoder's inner model selection and
//! [`super::validate`] both run (each passes how to encode).

use crate::decode::Decoder;
use crate::encode::samples::{IncidentSamples, SampleSet};
use crate::error::{Error, Result};
use rayon::prelude::*;

/// Sums behind one error figure, so that figures pool exactly.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ErrorSums {
    /// Σ(ρ̂ − ρ)², Σρ², Σ ln((ρ̂ + ε)/(max(ρ, 0) + ε))², and the number of values.
    pub sq_error: f64,
    /// Σρ² (see `sq_error`).
    pub sq_reference: f64,
    /// Σ ln((ρ̂ + ε)/(max(ρ, 0) + ε))² (see `sq_error`).
    pub sq_log: f64,
    /// The number of values summed.
    pub count: usize,
}

impl ErrorSums {
    /// Adds one predicted value against its measurement.
    pub fn add(&mut self, predicted: f64, measured: f64, epsilon: f64) {
        let p = predicted.max(0.0);
        self.sq_error += (p - measured) * (p - measured);
        self.sq_reference += measured * measured;
        let l = ((p + epsilon) / (measured.max(0.0) + epsilon)).ln();
        self.sq_log += l * l;
        self.count += 1;
    }

    /// Adds the sums of `o` to these (pooling two sets of values).
    pub fn merge(&mut self, o: &ErrorSums) {
        self.sq_error += o.sq_error;
        self.sq_reference += o.sq_reference;
        self.sq_log += o.sq_log;
        self.count += o.count;
    }

    /// sqrt(Σ(ρ̂ − ρ)² / Σρ²); 0 when both are 0, +∞ for energy where the reference has none.
    pub fn rel(&self) -> f64 {
        rel(self.sq_error, self.sq_reference)
    }

    /// The RMS log ratio; 0 with no values.
    pub fn log(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            (self.sq_log / self.count as f64).sqrt()
        }
    }
}

/// ε of the log figure: 1% of the median over samples of the spectral mean value; 1% of the
/// mean absolute value if that median is not positive, and 10⁻¹² at the least.
pub fn log_epsilon(set: &SampleSet) -> f64 {
    let w = set.wavelengths.len().max(1);
    let mut means: Vec<f64> = set
        .incidences
        .iter()
        .flat_map(|s| s.values.chunks(w).map(|c| c.iter().sum::<f64>() / w as f64))
        .collect();
    means.sort_by(f64::total_cmp);
    let median = means.get(means.len() / 2).copied().unwrap_or(0.0);
    let e = if median > 0.0 {
        0.01 * median
    } else {
        let n = means.len().max(1) as f64;
        0.01 * means.iter().map(|v| v.abs()).sum::<f64>() / n
    };
    e.max(1e-12)
}

/// The fixed order of an incidence's samples that the folds cut: a xorshift shuffle seeded from
/// the incidence's index, so every run and every machine holds out the same samples.
pub fn fold_order(n: usize, incidence: usize) -> Vec<usize> {
    let mut state =
        0x9E37_79B9_7F4A_7C15u64 ^ (incidence as u64).wrapping_mul(0x2545_F491_4F6C_DD1D);
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut order: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        let j = (next() % (i as u64 + 1)) as usize;
        order.swap(i, j);
    }
    order
}

/// Decodes `dec` at every sample of `s`, adding each value to `sums`.
pub(crate) fn score(
    dec: &Decoder,
    s: &IncidentSamples,
    wavelengths: &[f64],
    eps: f64,
    keep: impl Fn(usize) -> bool,
) -> ErrorSums {
    let w = wavelengths.len();
    let mut sums = ErrorSums::default();
    let mut out = vec![0.0; w];
    for (d, dir) in s.directions.iter().enumerate() {
        if !keep(d) {
            continue;
        }
        dec.eval_deg(
            (s.theta_i, s.phi_i),
            (dir[0], dir[1]),
            wavelengths,
            &mut out,
        );
        for (p, m) in out.iter().zip(&s.values[d * w..(d + 1) * w]) {
            sums.add(*p, *m, eps);
        }
    }
    sums
}

/// The k-fold held-out sums per incidence of encoding `set` with `encode`: incidence i's outgoing
/// directions in the order of [`fold_order`] with seed index i + `salt`, fold f holding out the
/// positions p with p mod k = f from every incidence at once (`EVALUATION.md`, "Held-out error").
pub fn k_fold(
    set: &SampleSet,
    encode: impl Fn(&SampleSet) -> Result<Decoder> + Sync,
    k: usize,
    salt: usize,
    eps: f64,
) -> Result<Vec<ErrorSums>> {
    let wl = &set.wavelengths;
    let orders = fold_ranks(set, salt);
    // The folds' encodes side by side (each is parallel inside too; alone, an encode's last
    // fit keeps one core), their sums merged in fold order: the same figures, and the same
    // first failure, as one fold after another.
    let folds: Vec<Result<Vec<ErrorSums>>> = (0..k)
        .into_par_iter()
        .map(|f| {
            let held = |i: usize, d: usize| orders[i][d] % k == f;
            let train = SampleSet {
                wavelengths: wl.clone(),
                incidences: set
                    .incidences
                    .iter()
                    .enumerate()
                    .filter_map(|(i, s)| {
                        let keep: Vec<usize> =
                            (0..s.directions.len()).filter(|&d| !held(i, d)).collect();
                        (!keep.is_empty()).then(|| subset_directions(s, &keep, wl.len()))
                    })
                    .collect(),
            };
            let dec = encode(&train)
                .map_err(|e| Error::Parameter(format!("fold {} of {k}: {e}", f + 1)))?;
            Ok(set
                .incidences
                .par_iter()
                .enumerate()
                .map(|(i, s)| score(&dec, s, wl, eps, |d| held(i, d)))
                .collect())
        })
        .collect();
    let mut sums = vec![ErrorSums::default(); set.incidences.len()];
    for fold in folds {
        for (a, b) in sums.iter_mut().zip(&fold?) {
            a.merge(b);
        }
    }
    Ok(sums)
}

/// Per incidence i, rank[d]: the position of direction d in the incidence's shuffled order
/// ([`fold_order`] seeded with i + `salt`); fold f of k holds out the d with rank[d] mod k = f.
pub(crate) fn fold_ranks(set: &SampleSet, salt: usize) -> Vec<Vec<usize>> {
    set.incidences
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let order = fold_order(s.directions.len(), i + salt);
            let mut rank = vec![0; order.len()];
            for (pos, &d) in order.iter().enumerate() {
                rank[d] = pos;
            }
            rank
        })
        .collect()
}

/// The samples of `s` at the directions `keep` (indices, increasing).
fn subset_directions(s: &IncidentSamples, keep: &[usize], w: usize) -> IncidentSamples {
    IncidentSamples {
        theta_i: s.theta_i,
        phi_i: s.phi_i,
        directions: keep.iter().map(|&d| s.directions[d]).collect(),
        values: keep
            .iter()
            .flat_map(|&d| s.values[d * w..(d + 1) * w].iter().copied())
            .collect(),
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

/// The error as a record stores it: finite, so +∞ (an all-zero reference not reproduced) is
/// stored as the largest f32.
pub fn stored_error(e: f64) -> f32 {
    (e as f32).min(f32::MAX)
}
