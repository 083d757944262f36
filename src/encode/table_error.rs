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
/// spectra themselves, or their map by the metric), and each incidence's L2 and L1 norms, the
/// denominators of its relative errors.
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
    /// Each incidence's L2 norm √Σ y² (at least the smallest positive `f64`).
    pub norms: Vec<f64>,
    /// Each incidence's L1 norm Σ |y| (likewise).
    pub magnitudes: Vec<f64>,
}

impl<'a> Target<'a> {
    /// The target of `y` (D values per node, incidences of R × R nodes), its norms computed
    /// once here.
    pub fn new(y: &'a [f64], d: usize, metric: Option<&'a Metric>, w: usize, r: usize) -> Self {
        let per = (r * r * d).max(1);
        let (norms, magnitudes) = y
            .chunks(per)
            .map(|v| {
                let l2 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                let l1 = v.iter().map(|x| x.abs()).sum::<f64>();
                (l2.max(f64::MIN_POSITIVE), l1.max(f64::MIN_POSITIVE))
            })
            .unzip();
        Target {
            y,
            d,
            metric,
            w,
            r,
            norms,
            magnitudes,
        }
    }

    /// The error of incidence i from its nodes' coefficients `c` (K per node): the larger of
    /// its relative L2 and relative L1 errors, the two measures the module's doc gives reasons
    /// for.
    pub fn error_of(&self, i: usize, c: &[f64], basis: &[f64], k: usize) -> f64 {
        let (w, d, per) = (self.w, self.d, self.r * self.r);
        let mut s = vec![0.0; w];
        let mut m = vec![0.0; d];
        let (mut squares, mut absolutes) = (0.0, 0.0);
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
            }
        }
        (squares.sqrt() / self.norms[i]).max(absolutes / self.magnitudes[i])
    }

    /// The error ([`Self::error_of`]) of every incidence of the spectra rebuilt from
    /// coefficients `c` (K per node, every incidence) on `basis`.
    pub fn errors(&self, c: &[f64], basis: &[f64], k: usize) -> Vec<f64> {
        let per = self.r * self.r * k;
        (0..self.norms.len())
            .map(|i| self.error_of(i, &c[i * per..(i + 1) * per], basis, k))
            .collect()
    }
}
