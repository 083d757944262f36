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
//! predicting zero everywhere scores rel = 1 (above 1 a model invents energy). Beside each
//! held-out figure, the nearest sample's on the same held-out values ([`crate::encode::nearest`]):
//! a model above it does worse than handing out the measurement.

use crate::decode::Decoder;
use crate::encode::encoder::{encode, EncodeOptions};
use crate::encode::metrics::score;
use crate::encode::metrics::{k_fold, log_epsilon, ErrorSums};
use crate::encode::nearest::{nearest_k_fold, nearest_left_out};
use crate::encode::samples::SampleSet;
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
    /// Values evaluated (incidences × outgoing directions × wavelengths).
    pub values: usize,
    /// Values below 0 before the clamp, and the lowest.
    pub negative: usize,
    /// The lowest finite value before the clamp, 1/sr (+∞ when none was finite).
    pub minimum: f64,
    /// Values that are not finite (never expected).
    pub not_finite: usize,
    /// Values at or below 0 before the clamp (0 as decoded) where θi and θo are both below 85°:
    /// directions where a measured material plainly reflects (issue 41).
    pub zero_below_85: usize,
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
                    let inside = ti < 85.0 && o.0 < 85.0;
                    for &v in &out {
                        g.values += 1;
                        g.zero_below_85 += (inside && v <= 0.0) as usize;
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
                zero_below_85: a.zero_below_85 + b.zero_below_85,
            },
        )
}

/// The three figures of one incidence.
#[derive(Debug, Clone, PartialEq)]
pub struct IncidenceReport {
    /// Incident polar angle θi, degrees.
    pub theta_i: f64,
    /// Incident azimuth φi, degrees.
    pub phi_i: f64,
    /// Number of outgoing directions sampled at this incidence.
    pub samples: usize,
    /// The error at the samples of the model encoded from everything.
    pub fit: ErrorSums,
    /// The k-fold error at this incidence's held-out samples (None without folds).
    pub folds: Option<ErrorSums>,
    /// The error at all its samples when this incidence is left out of the encode (None when
    /// not measured).
    pub left_out: Option<ErrorSums>,
    /// The nearest sample's error on the same folds ([`crate::encode::nearest`]): the baseline
    /// the model must beat (None without folds).
    pub nearest_folds: Option<ErrorSums>,
    /// The nearest sample's error with this incidence left out (None when not measured).
    pub nearest_left_out: Option<ErrorSums>,
}

/// Everything `validate` measures.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationReport {
    /// ε of the log figure ([`log_epsilon`]), 1/sr.
    pub epsilon: f64,
    /// Bytes of the file encoded from all samples, without sample positions.
    pub bytes: usize,
    /// The figures per incidence, in the input's order.
    pub incidences: Vec<IncidenceReport>,
    /// The fit error pooled over every incidence.
    pub fit: ErrorSums,
    /// The k-fold error pooled over every incidence (None without folds).
    pub folds: Option<ErrorSums>,
    /// The leave-one-incidence-out error pooled over the incidences left out (None when none
    /// was).
    pub left_out: Option<ErrorSums>,
    /// The nearest sample's k-fold error pooled over every incidence (None without folds).
    pub nearest_folds: Option<ErrorSums>,
    /// The nearest sample's leave-one-incidence-out error, pooled as `left_out`.
    pub nearest_left_out: Option<ErrorSums>,
    /// The dense-grid count, when asked for ([`ValidateOptions::dense_grid`]).
    pub dense: Option<DenseGrid>,
}

fn encode_to_decoder(set: &SampleSet, opts: &EncodeOptions) -> Result<(Decoder, usize)> {
    let e = encode(set, opts)?;
    let bytes = crate::write_material(&e.material)?.len();
    Ok((Decoder::from_material(e.material)?, bytes))
}

/// Measures the fit, k-fold and leave-one-incidence-out errors of encoding `set` with `opts`.
/// The encodes (the whole set's, each fold's, each incidence left out) run side by side, each
/// parallel inside too, and are scored and pooled in a fixed order, so the figures do not
/// depend on the thread count.
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
    if v.leave_incidence_out && set.incidences.len() < 2 {
        return Err(Error::Parameter(
            "--leave-incidence-out needs at least two incidences".into(),
        ));
    }
    let eps = log_epsilon(set);
    let wl = &set.wavelengths;
    let quiet = EncodeOptions {
        sample_positions: false,
        ..opts.clone()
    };
    // The incidences left out in turn (their indices).
    let left_out: Vec<usize> = (0..set.incidences.len())
        .filter(|&x| {
            let t = set.incidences[x].theta_i;
            v.leave_incidence_out
                && (v.leave_out_only.is_empty()
                    || v.leave_out_only.iter().any(|o| (o - t).abs() < 1e-3))
        })
        .collect();
    let leave_out = |x: usize| -> Result<(ErrorSums, ErrorSums)> {
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
        Ok((
            score(&dec, s, wl, eps, |_| true),
            nearest_left_out(set, x, eps),
        ))
    };
    let (whole, (folds, left)) = rayon::join(
        || encode_to_decoder(set, &quiet),
        || {
            rayon::join(
                || {
                    (v.folds >= 2).then(|| {
                        k_fold(
                            set,
                            |t| Ok(encode_to_decoder(t, &quiet)?.0),
                            v.folds,
                            0,
                            eps,
                        )
                    })
                },
                || {
                    left_out
                        .par_iter()
                        .map(|&x| leave_out(x))
                        .collect::<Vec<_>>()
                },
            )
        },
    );
    // Failures in the order the encodes would run one after another.
    let (dec, bytes) = whole?;
    let folds = folds.transpose()?;
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
            nearest_folds: None,
            nearest_left_out: None,
        })
        .collect();
    if let Some(sums) = folds {
        let nearest = nearest_k_fold(set, v.folds, 0, eps);
        for ((r, s), n) in incidences.iter_mut().zip(sums).zip(nearest) {
            r.folds = Some(s);
            r.nearest_folds = Some(n);
        }
    }
    for (&x, result) in left_out.iter().zip(left) {
        let (model, nearest) = result?;
        incidences[x].left_out = Some(model);
        incidences[x].nearest_left_out = Some(nearest);
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
        nearest_folds: pool(&|r| r.nearest_folds),
        nearest_left_out: pool(&|r| r.nearest_left_out),
        dense,
        incidences,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::encode::metrics::fold_order;

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
