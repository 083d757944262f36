//! The baseline every model is judged against held out (`spec/EVALUATION.md`, "Held-out error",
//! nearest sample): a held-out value predicted by the spectrum of the nearest sample the model
//! was given, with no model at all. A model whose held-out error is above this one's does worse
//! than handing out the measurement itself (issue 41).
//!
//! "Nearest" is the largest cosine between outgoing directions taken relative to each
//! incidence's azimuth (φo − φi), first among the training samples of the same incidence; an
//! incidence with none (left out, or all of it held out) takes the incidence whose direction is
//! nearest (largest cosine between incident directions), then its nearest outgoing direction.
//! Ties go to the first in the input's order, so the figure is deterministic.

use crate::encode::metrics::{fold_ranks, ErrorSums};
use crate::encode::samples::{IncidentSamples, SampleSet};
use crate::model::angles::dir_from_deg;

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The set's directions as unit vectors, made once: each incidence's direction, and each
/// outgoing direction in its incidence's own azimuthal frame (φo − φi).
struct Directions {
    incident: Vec<[f64; 3]>,
    outgoing: Vec<Vec<[f64; 3]>>,
}

impl Directions {
    fn of(set: &SampleSet) -> Self {
        let relative = |s: &IncidentSamples| -> Vec<[f64; 3]> {
            s.directions
                .iter()
                .map(|&[t, p]| dir_from_deg(t, p - s.phi_i))
                .collect()
        };
        Directions {
            incident: set
                .incidences
                .iter()
                .map(|s| dir_from_deg(s.theta_i, s.phi_i))
                .collect(),
            outgoing: set.incidences.iter().map(relative).collect(),
        }
    }

    /// Among the outgoing directions of incidence j that `allowed` admits, the one nearest to
    /// `v` (relative frame).
    fn nearest_direction(
        &self,
        j: usize,
        v: [f64; 3],
        allowed: impl Fn(usize) -> bool,
    ) -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for (d, &u) in self.outgoing[j].iter().enumerate() {
            if !allowed(d) {
                continue;
            }
            let c = dot(u, v);
            if best.is_none_or(|(_, b)| c > b) {
                best = Some((d, c));
            }
        }
        best.map(|(d, _)| d)
    }

    /// The training sample (incidence, direction) nearest to direction d of incidence i, where
    /// `train(j, e)` says whether sample e of incidence j is in the training set.
    fn nearest_sample(
        &self,
        i: usize,
        d: usize,
        train: &dyn Fn(usize, usize) -> bool,
    ) -> Option<(usize, usize)> {
        let v = self.outgoing[i][d];
        if let Some(e) = self.nearest_direction(i, v, |e| train(i, e)) {
            return Some((i, e));
        }
        let wi = self.incident[i];
        let mut order: Vec<(usize, f64)> = (0..self.incident.len())
            .filter(|&j| j != i)
            .map(|j| (j, dot(self.incident[j], wi)))
            .collect();
        // Nearest incidence first; a stable sort keeps the input's order among equals.
        order.sort_by(|a, b| b.1.total_cmp(&a.1));
        order.into_iter().find_map(|(j, _)| {
            self.nearest_direction(j, v, |e| train(j, e))
                .map(|e| (j, e))
        })
    }
}

/// Adds the prediction of sample (i, d) by its nearest training sample to `sums` (a value with
/// no training sample at all is predicted as 0).
fn score_sample(
    set: &SampleSet,
    dirs: &Directions,
    (i, d): (usize, usize),
    train: &dyn Fn(usize, usize) -> bool,
    eps: f64,
    sums: &mut ErrorSums,
) {
    let w = set.wavelengths.len();
    let measured = &set.incidences[i].values[d * w..(d + 1) * w];
    match dirs.nearest_sample(i, d, train) {
        Some((j, e)) => {
            let predicted = &set.incidences[j].values[e * w..(e + 1) * w];
            for (p, m) in predicted.iter().zip(measured) {
                sums.add(*p, *m, eps);
            }
        }
        None => measured.iter().for_each(|m| sums.add(0.0, *m, eps)),
    }
}

/// The nearest sample's k-fold sums per incidence, on exactly the folds of
/// [`crate::encode::metrics::k_fold`] with the same `salt`.
pub fn nearest_k_fold(set: &SampleSet, k: usize, salt: usize, eps: f64) -> Vec<ErrorSums> {
    let ranks = fold_ranks(set, salt);
    let mut sums = vec![ErrorSums::default(); set.incidences.len()];
    if k < 2 {
        return sums;
    }
    let dirs = Directions::of(set);
    for f in 0..k {
        let train = |j: usize, e: usize| ranks[j][e] % k != f;
        for (i, s) in set.incidences.iter().enumerate() {
            for d in (0..s.directions.len()).filter(|&d| ranks[i][d] % k == f) {
                score_sample(set, &dirs, (i, d), &train, eps, &mut sums[i]);
            }
        }
    }
    sums
}

/// The nearest sample's sums at every sample of incidence `x` when `x` is left out.
pub fn nearest_left_out(set: &SampleSet, x: usize, eps: f64) -> ErrorSums {
    let mut sums = ErrorSums::default();
    let dirs = Directions::of(set);
    let train = |j: usize, _e: usize| j != x;
    for d in 0..set.incidences[x].directions.len() {
        score_sample(set, &dirs, (x, d), &train, eps, &mut sums);
    }
    sums
}

#[cfg(test)]
mod tests {
    use super::*;

    fn incidence(theta_i: f64, phi_i: f64, dirs: &[[f64; 2]], values: &[f64]) -> IncidentSamples {
        IncidentSamples {
            theta_i,
            phi_i,
            directions: dirs.to_vec(),
            values: values.to_vec(),
        }
    }

    /// A hand-worked set: each value is predicted by the one whose direction is nearest, in the
    /// incidence's azimuthal frame, or from the nearest incidence when its own has none.
    #[test]
    fn predicts_by_the_nearest_training_sample() {
        let set = SampleSet {
            wavelengths: vec![500.0],
            incidences: vec![
                incidence(
                    10.0,
                    0.0,
                    &[[0.0, 0.0], [20.0, 180.0], [60.0, 180.0]],
                    &[1.0, 2.0, 4.0],
                ),
                // φi = 90°: (25°, 270°) is (25°, 180°) in its own frame.
                incidence(40.0, 90.0, &[[25.0, 270.0]], &[8.0]),
            ],
        };
        let eps = 0.01;
        // Incidence 1 left out: its only sample takes incidence 0's nearest, (20°, 180°) = 2.
        let s = nearest_left_out(&set, 1, eps);
        let mut want = ErrorSums::default();
        want.add(2.0, 8.0, eps);
        assert_eq!(s, want);
        // Incidence 0 left out: every sample takes incidence 1's only one (8).
        let s = nearest_left_out(&set, 0, eps);
        let mut want = ErrorSums::default();
        for m in [1.0, 2.0, 4.0] {
            want.add(8.0, m, eps);
        }
        assert_eq!(s, want);
        // Folds: every value predicted exactly once, none by itself.
        let f = nearest_k_fold(&set, 2, 0, eps);
        assert_eq!(f.iter().map(|s| s.count).sum::<usize>(), 4);
        assert!(f.iter().all(|s| s.sq_error > 0.0));
    }

    #[test]
    fn constant_incidences_are_predicted_exactly() {
        let dirs: Vec<[f64; 2]> = (0..12).map(|k| [7.0 * k as f64, 30.0 * k as f64]).collect();
        let set = SampleSet {
            wavelengths: vec![450.0, 650.0],
            incidences: vec![incidence(0.0, 0.0, &dirs, &[0.3; 24])],
        };
        let f = nearest_k_fold(&set, 3, 0, 1e-3);
        assert_eq!(f[0].count, 24);
        assert_eq!((f[0].rel(), f[0].log()), (0.0, 0.0));
    }
}
