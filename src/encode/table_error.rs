//! The warped-table encoder's error measure (`encode::warped`): how far spectra rebuilt from
//! coded tables are from the measurement, per stored incidence, over its R × R nodes and every
//! wavelength (or every value of a metric, an RGB source's colours), in table units: the
//! larger of the relative L2 and the relative L1 error.
//!
//! Why both: a table value is f·cos θo divided by the warp's density of ωo, and the nodes are
//! spread evenly in the warp's square, so the relative L1 error over the nodes is the relative
//! L1 error of f·cos θo over the hemisphere: of the light the incidence sends out, what a
//! render sums. L2 alone lets the error gather where the values are small (off the peak, where
//! a grazing light's pixels look): on satin_rosaline at 2% the grazing point light rendered
//! 2.08% off with L2 alone, 1.69% with both (+7% bytes; paper_white's file is unchanged, the
//! median of the shipped files' 2% files 1.74 kB, `docs/guide/warped-tables.md`). L2 is kept
//! beside it so that no stored error grows: the measure only tightens.

/// A linear map of spectra (W values) to D measured values, row-major.
#[derive(Debug, Clone)]
pub struct Metric {
    /// D, the number of measured values.
    pub rows: usize,
    /// D rows of W values, row-major: value d = Σ_l `matrix[d·W + l]`·s_l.
    pub matrix: Vec<f64>,
}

impl Metric {
    /// The D measured values of spectrum `s` into `out`.
    pub fn apply(&self, s: &[f64], out: &mut [f64]) {
        let w = s.len();
        for (d, o) in out.iter_mut().enumerate().take(self.rows) {
            *o = (0..w).map(|l| self.matrix[d * w + l] * s[l]).sum();
        }
    }
}

/// What rebuilt spectra are compared with: the measurement's values `y` (D per node: the
/// spectra themselves, or their map by the metric).
pub struct Target<'a> {
    /// The measured values, D per node, node-major, incidence-major.
    pub y: &'a [f64],
    /// D, values per node.
    pub d: usize,
    /// The map from spectra to the values, if they are not the spectra.
    pub metric: Option<&'a Metric>,
    /// W, wavelengths per spectrum.
    pub w: usize,
    /// Table side R.
    pub r: usize,
}

impl Target<'_> {
    /// The error of incidence i from its nodes' coefficients `c` (K per node): the larger of
    /// its relative L2 error (against `norm`, the incidence's L2 norm) and its relative L1
    /// error, the two measures the module's doc gives reasons for.
    pub fn error_of(&self, i: usize, c: &[f64], basis: &[f64], k: usize, norm: f64) -> f64 {
        let (w, d, per) = (self.w, self.d, self.r * self.r);
        let mut s = vec![0.0; w];
        let mut m = vec![0.0; d];
        let (mut squares, mut absolutes, mut magnitude) = (0.0, 0.0, 0.0);
        for p in 0..per {
            // Clamped at 0 as the decoder clamps (EVALUATION.md, "Warped tables", step 5): a
            // colour that only a negative spectrum gives back is an error here too.
            for (l, sv) in s.iter_mut().enumerate() {
                *sv = (0..k)
                    .map(|t| c[p * k + t] * basis[t * w + l])
                    .sum::<f64>()
                    .max(0.0);
            }
            let rebuilt: &[f64] = match self.metric {
                Some(mt) => {
                    mt.apply(&s, &mut m);
                    &m
                }
                None => &s,
            };
            let y = &self.y[(i * per + p) * d..(i * per + p + 1) * d];
            for (a, b) in rebuilt.iter().zip(y) {
                squares += (a - b) * (a - b);
                absolutes += (a - b).abs();
                magnitude += b.abs();
            }
        }
        let l2 = squares.sqrt() / norm;
        let l1 = absolutes / magnitude.max(f64::MIN_POSITIVE);
        l2.max(l1)
    }

    /// The error ([`Self::error_of`]) per incidence of the spectra rebuilt from coefficients `c` (K per
    /// node, every incidence) on `basis`, against `y`, normalised by `norms`.
    pub fn errors(&self, c: &[f64], basis: &[f64], k: usize, norms: &[f64]) -> Vec<f64> {
        let per = self.r * self.r * k;
        norms
            .iter()
            .enumerate()
            .map(|(i, &norm)| self.error_of(i, &c[i * per..(i + 1) * per], basis, k, norm))
            .collect()
    }
}
