//! How far to trust a file between the measurements: the error at samples the encoder did not
//! see. `sbrdf validate` and the tests run this.
//!
//! * **fit**: encode everything, decode at the samples (what `info` reports).
//! * **k-fold**: per incidence, the outgoing samples in a fixed pseudo-random order; fold f holds
//!   out every k-th of them starting at f, from every incidence at once; the material is encoded
//!   from the rest and decoded at the held-out samples; the k folds' predictions are pooled.
//! * **leave one incidence out**: encode without incidence X, decode at all of X's samples.
//!
//! Two figures each (`spec/EVALUATION.md`, "Held-out error"): rel, the relative L2 error
//! sqrt(Σ(ρ̂ − ρ)² / Σρ²), and log, the RMS over values of ln((ρ̂ + ε)/(max(ρ, 0) + ε)) with ε = 1%
//! of the material's median spectral-mean value. On sparse peaky data one near-mirror sample can
//! hold most of Σρ², so rel alone measures that sample; log weighs every value alike, and
//! predicting zero everywhere scores rel = 1 (above 1 a model invents energy).

use crate::decode::Decoder;
use crate::encode::encoder::{encode, EncodeOptions};
use crate::encode::samples::{IncidentSamples, SampleSet};
use crate::error::{Error, Result};
use rayon::prelude::*;

/// What to measure.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidateOptions {
    /// k of the k-fold protocol over outgoing samples (0: none).
    pub folds: usize,
    /// Also leave each incidence out in turn.
    pub leave_incidence_out: bool,
    /// With `leave_incidence_out`, only the incidences at these θi (degrees, to 10⁻³°); empty:
    /// every incidence.
    pub leave_out_only: Vec<f64>,
    /// Also evaluate the whole-input model on a dense grid and count the values that are below
    /// 0 before the decoder's clamp.
    pub dense_grid: bool,
}

impl Default for ValidateOptions {
    fn default() -> Self {
        ValidateOptions {
            folds: 5,
            leave_incidence_out: false,
            leave_out_only: Vec::new(),
            dense_grid: false,
        }
    }
}

/// The model on a dense grid: θi every 5° from 0 to 90 (and φi every 30° for files that are not
/// isotropic), θo every 2.5° from 1.25°, φo every 5°, the file's wavelengths.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DenseGrid {
    pub values: usize,
    /// Values below 0 before the clamp, and the lowest.
    pub negative: usize,
    pub minimum: f64,
    /// Values that are not finite (never expected).
    pub not_finite: usize,
}

fn dense_grid(dec: &Decoder, wavelengths: &[f64]) -> DenseGrid {
    let phis: Vec<f64> = if dec.material().isotropic {
        vec![0.0]
    } else {
        (0..12).map(|j| 30.0 * j as f64).collect()
    };
    let rows: Vec<(f64, f64)> = (0..=18)
        .flat_map(|i| phis.iter().map(move |&p| (5.0 * i as f64, p)))
        .collect();
    rows.par_iter()
        .map(|&(ti, pi)| {
            let mut g = DenseGrid {
                minimum: f64::INFINITY,
                ..DenseGrid::default()
            };
            let mut out = vec![0.0; wavelengths.len()];
            for a in 0..36 {
                for b in 0..72 {
                    let o = (1.25 + 2.5 * a as f64, 5.0 * b as f64);
                    dec.eval_deg_unclamped((ti, pi), o, wavelengths, &mut out);
                    for &v in &out {
                        g.values += 1;
                        if !v.is_finite() {
                            g.not_finite += 1;
                        } else {
                            g.negative += (v < 0.0) as usize;
                            g.minimum = g.minimum.min(v);
                        }
                    }
                }
            }
            g
        })
        .reduce(
            || DenseGrid {
                minimum: f64::INFINITY,
                ..DenseGrid::default()
            },
            |a, b| DenseGrid {
                values: a.values + b.values,
                negative: a.negative + b.negative,
                minimum: a.minimum.min(b.minimum),
                not_finite: a.not_finite + b.not_finite,
            },
        )
}

/// Sums behind one error figure, so that figures pool exactly.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ErrorSums {
    /// Σ(ρ̂ − ρ)², Σρ², Σ ln((ρ̂ + ε)/(max(ρ, 0) + ε))², and the number of values.
    pub sq_error: f64,
    pub sq_reference: f64,
    pub sq_log: f64,
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

    pub fn merge(&mut self, o: &ErrorSums) {
        self.sq_error += o.sq_error;
        self.sq_reference += o.sq_reference;
        self.sq_log += o.sq_log;
        self.count += o.count;
    }

    /// sqrt(Σ(ρ̂ − ρ)² / Σρ²); 0 when both are 0, +∞ for energy where the reference has none.
    pub fn rel(&self) -> f64 {
        crate::encode::fit::rel(self.sq_error, self.sq_reference)
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

/// The three figures of one incidence.
#[derive(Debug, Clone, PartialEq)]
pub struct IncidenceReport {
    pub theta_i: f64,
    pub phi_i: f64,
    pub samples: usize,
    pub fit: ErrorSums,
    pub folds: Option<ErrorSums>,
    pub left_out: Option<ErrorSums>,
}

/// Everything `validate` measures.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationReport {
    pub epsilon: f64,
    /// Bytes of the file encoded from all samples, without sample positions.
    pub bytes: usize,
    pub incidences: Vec<IncidenceReport>,
    pub fit: ErrorSums,
    pub folds: Option<ErrorSums>,
    pub left_out: Option<ErrorSums>,
    pub dense: Option<DenseGrid>,
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
fn score(
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

fn encode_to_decoder(set: &SampleSet, opts: &EncodeOptions) -> Result<(Decoder, usize)> {
    let e = encode(set, opts)?;
    let bytes = crate::write_material(&e.material)?.len();
    Ok((Decoder::from_material(e.material)?, bytes))
}

/// Measures the fit, k-fold and leave-one-incidence-out errors of encoding `set` with `opts`.
/// The encodes run one after the other (each is parallel inside), so the figures do not depend
/// on the thread count.
pub fn validate(
    set: &SampleSet,
    opts: &EncodeOptions,
    v: &ValidateOptions,
) -> Result<ValidationReport> {
    set.validate()
        .map_err(|e| Error::Parameter(format!("invalid samples: {e}")))?;
    if v.folds == 1 {
        return Err(Error::Parameter(
            "--folds 1 holds out every sample; use 2 or more (or 0 for none)".into(),
        ));
    }
    let eps = log_epsilon(set);
    let wl = &set.wavelengths;
    let quiet = EncodeOptions {
        sample_positions: false,
        ..opts.clone()
    };
    let (dec, bytes) = encode_to_decoder(set, &quiet)?;
    let dense = v.dense_grid.then(|| dense_grid(&dec, wl));
    let mut incidences: Vec<IncidenceReport> = set
        .incidences
        .par_iter()
        .map(|s| IncidenceReport {
            theta_i: s.theta_i,
            phi_i: s.phi_i,
            samples: s.directions.len(),
            fit: score(&dec, s, wl, eps, |_| true),
            folds: None,
            left_out: None,
        })
        .collect();
    if v.folds >= 2 {
        let sums = k_fold(set, &quiet, v.folds, 0, eps)?;
        for (r, s) in incidences.iter_mut().zip(sums) {
            r.folds = Some(s);
        }
    }
    if v.leave_incidence_out {
        if set.incidences.len() < 2 {
            return Err(Error::Parameter(
                "--leave-incidence-out needs at least two incidences".into(),
            ));
        }
        for x in 0..set.incidences.len() {
            let t = set.incidences[x].theta_i;
            if !v.leave_out_only.is_empty()
                && !v.leave_out_only.iter().any(|o| (o - t).abs() < 1e-3)
            {
                continue;
            }
            let train = SampleSet {
                wavelengths: wl.clone(),
                incidences: set
                    .incidences
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| *i != x)
                    .map(|(_, s)| s.clone())
                    .collect(),
            };
            let s = &set.incidences[x];
            let (dec, _) = encode_to_decoder(&train, &quiet).map_err(|e| {
                Error::Parameter(format!(
                    "without incidence ({}, {}): {e}",
                    s.theta_i, s.phi_i
                ))
            })?;
            incidences[x].left_out = Some(score(&dec, s, wl, eps, |_| true));
        }
    }
    // Pooled over the incidences that have the figure (all of them, but for a partial
    // leave-one-out); None when none has it.
    let pool = |pick: &dyn Fn(&IncidenceReport) -> Option<ErrorSums>| -> Option<ErrorSums> {
        let mut total: Option<ErrorSums> = None;
        for s in incidences.iter().filter_map(pick) {
            total.get_or_insert_with(ErrorSums::default).merge(&s);
        }
        total
    };
    Ok(ValidationReport {
        epsilon: eps,
        bytes,
        fit: pool(&|r| Some(r.fit)).unwrap_or_default(),
        folds: pool(&|r| r.folds),
        left_out: pool(&|r| r.left_out),
        dense,
        incidences,
    })
}

/// The k-fold held-out sums per incidence of encoding `set` with `opts`: incidence i's outgoing
/// directions in the order of [`fold_order`] with seed index i + `salt`, fold f holding out the
/// positions p with p mod k = f from every incidence at once (`EVALUATION.md`, "Held-out error").
pub fn k_fold(
    set: &SampleSet,
    opts: &EncodeOptions,
    k: usize,
    salt: usize,
    eps: f64,
) -> Result<Vec<ErrorSums>> {
    let wl = &set.wavelengths;
    let orders: Vec<Vec<usize>> = set
        .incidences
        .iter()
        .enumerate()
        .map(|(i, s)| {
            // rank[d]: the position of direction d in the incidence's shuffled order.
            let order = fold_order(s.directions.len(), i + salt);
            let mut rank = vec![0; order.len()];
            for (pos, &d) in order.iter().enumerate() {
                rank[d] = pos;
            }
            rank
        })
        .collect();
    let mut sums = vec![ErrorSums::default(); set.incidences.len()];
    for f in 0..k {
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
        let (dec, _) = encode_to_decoder(&train, opts)
            .map_err(|e| Error::Parameter(format!("fold {} of {k}: {e}", f + 1)))?;
        let fold: Vec<ErrorSums> = set
            .incidences
            .par_iter()
            .enumerate()
            .map(|(i, s)| score(&dec, s, wl, eps, |d| held(i, d)))
            .collect();
        for (a, b) in sums.iter_mut().zip(&fold) {
            a.merge(b);
        }
    }
    Ok(sums)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folds_partition_every_incidence() {
        for n in [1, 5, 7, 181] {
            let order = fold_order(n, 3);
            let mut seen = order.clone();
            seen.sort();
            assert_eq!(seen, (0..n).collect::<Vec<_>>());
            assert_eq!(order, fold_order(n, 3), "deterministic");
        }
        assert_ne!(fold_order(50, 0), fold_order(50, 1));
    }

    #[test]
    fn sums_give_rel_and_log() {
        let mut s = ErrorSums::default();
        s.add(2.0, 1.0, 0.0);
        s.add(0.0, 0.0, 1e-3);
        assert!((s.rel() - 1.0).abs() < 1e-12);
        assert!((s.log() - (2f64.ln().powi(2) / 2.0).sqrt()).abs() < 1e-12);
        // Predicting zero everywhere scores rel = 1; negative predictions count as 0.
        let mut z = ErrorSums::default();
        z.add(-5.0, 3.0, 0.1);
        assert!((z.rel() - 1.0).abs() < 1e-12);
    }
}
