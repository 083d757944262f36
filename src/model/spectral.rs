//! Spectral bases: how a spectrum ρ(λ) at one pair of directions becomes K coefficients and back.
//!
//! Normative text: `spec/EVALUATION.md`, section "Spectral basis".

use std::f64::consts::PI;

/// Which family of functions of λ the coefficients multiply. The numeric codes are the ones
/// stored in the file's `HEAD` chunk and never change meaning.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SpectralBasis {
    /// The paper's periodic Fourier series over [λmin, λmax] (Eqs. 4–5): coefficients in the
    /// order a0, a1, b1, a2, b2, …; the basis functions are 1/2, cos(j t), sin(j t) with
    /// t = 2π(λ − λmin)/(λmax − λmin).
    PeriodicFourier,
    /// The cosine series (the Fourier series of the mirror-extended spectrum, i.e. a DCT):
    /// 1, cos(π t), cos(2π t), … with t = (λ − λmin)/(λmax − λmin). No wrap-around, so no ringing
    /// where the spectrum's ends differ.
    Cosine,
    /// A basis derived from the data (the leading right singular vectors of the samples), stored
    /// in the file as its values at the wavelength samples and interpolated linearly between them.
    Tabulated,
}

impl SpectralBasis {
    /// The basis's code in `HEAD` (`spec/FORMAT.md` §4): 1 Fourier, 2 cosine, 3 tabulated.
    pub fn code(self) -> u8 {
        match self {
            SpectralBasis::PeriodicFourier => 1,
            SpectralBasis::Cosine => 2,
            SpectralBasis::Tabulated => 3,
        }
    }

    /// The basis with this `HEAD` code; None for an unknown code.
    pub fn from_code(code: u8) -> Option<Self> {
        match code {
            1 => Some(SpectralBasis::PeriodicFourier),
            2 => Some(SpectralBasis::Cosine),
            3 => Some(SpectralBasis::Tabulated),
            _ => None,
        }
    }

    /// The basis's name as the command line spells it: `"fourier"`, `"cosine"` or `"data"`.
    pub fn name(self) -> &'static str {
        match self {
            SpectralBasis::PeriodicFourier => "fourier",
            SpectralBasis::Cosine => "cosine",
            SpectralBasis::Tabulated => "data",
        }
    }
}

/// Basis functions given by their values at wavelength nodes (for [`SpectralBasis::Tabulated`]).
#[derive(Debug, Clone, PartialEq)]
pub struct BasisTable {
    /// Strictly increasing wavelengths, nm (the file's wavelength samples).
    pub nodes: Vec<f64>,
    /// `terms` rows of `nodes.len()` values: row k is basis function k.
    pub values: Vec<f64>,
    /// How the values are stored (each value must be exactly representable in it).
    pub storage: crate::model::basis_storage::BasisStorage,
}

/// A spectral basis with its number of terms and the wavelength interval it spans.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralSpace {
    /// The family of basis functions.
    pub basis: SpectralBasis,
    /// K, the number of basis functions (the most terms a record may use).
    pub terms: usize,
    /// Interval of the basis in nm. Equal ends are allowed only with one term (one wavelength).
    pub lambda_min: f64,
    /// Upper end of the interval, nm (see `lambda_min`).
    pub lambda_max: f64,
    /// The tabulated functions, present exactly when `basis` is `Tabulated`.
    pub table: Option<BasisTable>,
}

impl SpectralSpace {
    /// A basis given by formula (no table).
    pub fn analytic(basis: SpectralBasis, terms: usize, lambda_min: f64, lambda_max: f64) -> Self {
        SpectralSpace {
            basis,
            terms,
            lambda_min,
            lambda_max,
            table: None,
        }
    }

    /// Checks the invariants a file or the encoder must satisfy; returns a message otherwise.
    pub fn validate(&self) -> Result<(), String> {
        if self.terms == 0 {
            return Err("the spectral basis needs at least one term".into());
        }
        if !(self.lambda_min.is_finite() && self.lambda_max.is_finite()) || self.lambda_min <= 0.0 {
            return Err(format!(
                "the spectral interval [{}, {}] nm is not a finite positive interval",
                self.lambda_min, self.lambda_max
            ));
        }
        if self.lambda_max < self.lambda_min
            || (self.lambda_max == self.lambda_min && self.terms != 1)
        {
            return Err(format!(
                "the spectral interval [{}, {}] nm is empty but {} terms are used",
                self.lambda_min, self.lambda_max, self.terms
            ));
        }
        match (&self.table, self.basis) {
            (None, SpectralBasis::Tabulated) => {
                return Err("a tabulated basis without its table".into())
            }
            (Some(_), SpectralBasis::PeriodicFourier | SpectralBasis::Cosine) => {
                return Err("a table given for an analytic basis".into())
            }
            (Some(t), SpectralBasis::Tabulated) => {
                if t.nodes.is_empty() || t.values.len() != self.terms * t.nodes.len() {
                    return Err("the basis table does not have terms × nodes values".into());
                }
                if t.values.iter().any(|v| !v.is_finite()) {
                    return Err("a basis table value is not finite".into());
                }
                if t.nodes.windows(2).any(|w| w[1] <= w[0]) {
                    return Err("basis table nodes are not strictly increasing".into());
                }
            }
            (None, _) => {}
        }
        Ok(())
    }

    /// Writes the K basis functions at wavelength λ (nm) into `out[..terms]`. λ outside the
    /// interval is clamped to it: a periodic series must not wrap a query at 710 nm to 410 nm.
    pub fn eval(&self, lambda: f64, out: &mut [f64]) {
        let out = &mut out[..self.terms];
        match self.basis {
            SpectralBasis::PeriodicFourier => {
                out[0] = 0.5;
                if self.terms == 1 {
                    return;
                }
                let span = self.lambda_max - self.lambda_min;
                let l = lambda.clamp(self.lambda_min, self.lambda_max);
                let t = 2.0 * PI * (l - self.lambda_min) / span;
                for (i, v) in out.iter_mut().enumerate().skip(1) {
                    let j = i.div_ceil(2);
                    *v = if i % 2 == 1 {
                        (j as f64 * t).cos()
                    } else {
                        (j as f64 * t).sin()
                    };
                }
            }
            SpectralBasis::Cosine => {
                let span = self.lambda_max - self.lambda_min;
                let t = if span > 0.0 {
                    (lambda.clamp(self.lambda_min, self.lambda_max) - self.lambda_min) / span
                } else {
                    0.0
                };
                for (k, v) in out.iter_mut().enumerate() {
                    *v = (PI * k as f64 * t).cos();
                }
            }
            SpectralBasis::Tabulated => {
                let table = self
                    .table
                    .as_ref()
                    .expect("validated: a tabulated basis has a table");
                let n = &table.nodes;
                let w = n.len();
                // Linear interpolation between nodes, constant beyond the ends.
                // NaN is treated as below the range (the decoder maps it to 0 before this).
                let (i, f) = if lambda.is_nan() || lambda <= n[0] || w == 1 {
                    (0, 0.0)
                } else if lambda >= n[w - 1] {
                    (w - 2, 1.0)
                } else {
                    // Uniform nodes (the usual case) are indexed directly; the guess is checked,
                    // and a binary search settles anything else.
                    let h = (n[w - 1] - n[0]) / (w - 1) as f64;
                    let g = (((lambda - n[0]) / h) as usize).min(w - 2);
                    let i = if n[g] <= lambda && lambda < n[g + 1] {
                        g
                    } else {
                        n.partition_point(|&x| x <= lambda) - 1
                    };
                    (i, (lambda - n[i]) / (n[i + 1] - n[i]))
                };
                for (k, v) in out.iter_mut().enumerate() {
                    let row = &table.values[k * w..(k + 1) * w];
                    *v = if w == 1 {
                        row[0]
                    } else {
                        row[i] + f * (row[i + 1] - row[i])
                    };
                }
            }
        }
    }

    /// The W×K synthesis matrix (row-major): ρ(λ_w) = Σ_k S\[w\]\[k\] c_k.
    pub fn synthesis(&self, wavelengths: &[f64]) -> Vec<f64> {
        let mut m = vec![0.0; wavelengths.len() * self.terms];
        for (w, &l) in wavelengths.iter().enumerate() {
            self.eval(l, &mut m[w * self.terms..(w + 1) * self.terms]);
        }
        m
    }

    /// The K×W projection matrix (row-major) of the paper's Eq. (5), the integral taken by the
    /// trapezoidal rule over the samples: a_k = (2/Δλ) ∫ ρ(λ) cos(k t) dλ, b_k likewise with sin.
    /// With a single wavelength (Δλ = 0, one term) the coefficient is 2ρ, so that a0/2 = ρ.
    /// This is the paper's projection for its Fourier basis; other bases are fitted by least
    /// squares in the encoder.
    pub fn fourier_projection(&self, wavelengths: &[f64]) -> Vec<f64> {
        let w_count = wavelengths.len();
        let k_count = self.terms;
        let mut m = vec![0.0; k_count * w_count];
        if w_count == 1 {
            m[0] = 2.0;
            return m;
        }
        let span = self.lambda_max - self.lambda_min;
        let mut basis = vec![0.0; k_count];
        for (w, &l) in wavelengths.iter().enumerate() {
            let lo = if w == 0 { l } else { wavelengths[w - 1] };
            let hi = if w + 1 == w_count {
                l
            } else {
                wavelengths[w + 1]
            };
            let weight = 0.5 * (hi - lo);
            self.eval(l, &mut basis);
            for k in 0..k_count {
                // a0 integrates ρ·1, not ρ·(1/2): undo the 1/2 of the synthesis function.
                let f = if k == 0 { 1.0 } else { basis[k] };
                m[k * w_count + w] = 2.0 / span * weight * f;
            }
        }
        m
    }
}

/// Σ_k c_k·B_k(λ) for many λ, with what each query needs computed once: the decoder's resident
/// form of [`SpectralSpace::eval`]. The tabulated basis is kept node-major (the K values of a node
/// side by side) in `f32`, which holds its `f16` or `f32` values exactly, with one reciprocal
/// step when the nodes are evenly spaced; the analytic bases advance cos(jθ), sin(jθ) by a
/// recurrence from one `sin_cos`, which drifts from the direct formula by ~K·1e-16.
#[derive(Debug, Clone)]
pub struct SpectrumEvaluator {
    terms: usize,
    lambda_min: f64,
    lambda_max: f64,
    form: EvaluatorForm,
}

#[derive(Debug, Clone)]
enum EvaluatorForm {
    /// θ = scale·(λ − λmin), with scale = 2π/span (Fourier) or π/span (cosine; 0 for an empty span).
    Fourier {
        scale: f64,
    },
    Cosine {
        scale: f64,
    },
    Table {
        nodes: Vec<f32>,
        /// values[w·K + k] = B_k(nodes[w]).
        values: Vec<f32>,
        /// Some(1/step) when every interval has exactly the same width: the interval is then
        /// found by one multiplication (checked) and its fraction by another.
        inv_step: Option<f64>,
        storage: crate::model::basis_storage::BasisStorage,
    },
}

/// The most nodes of a tabulated basis whose sums [`SpectrumEvaluator::eval_clamped`] keeps on
/// the stack for many wavelengths.
pub const NODE_SUMS: usize = 128;

/// Where a wavelength falls in a tabulated basis: node i and the fraction f toward node i + 1.
#[derive(Debug, Clone, Copy)]
pub struct Cell {
    /// The node at or below the wavelength (W − 2 at or above the last node).
    pub i: usize,
    /// The fraction of the way from node i to node i + 1, in [0, 1].
    pub f: f64,
}

impl SpectrumEvaluator {
    /// The evaluator of a validated spectral space. Panics if a tabulated basis has no table.
    pub fn new(space: &SpectralSpace) -> Self {
        let span = space.lambda_max - space.lambda_min;
        let form = match (space.basis, &space.table) {
            (SpectralBasis::PeriodicFourier, _) => EvaluatorForm::Fourier {
                scale: if span > 0.0 { 2.0 * PI / span } else { 0.0 },
            },
            (SpectralBasis::Cosine, _) => EvaluatorForm::Cosine {
                scale: if span > 0.0 { PI / span } else { 0.0 },
            },
            (SpectralBasis::Tabulated, table) => {
                let table = table
                    .as_ref()
                    .expect("validated: a tabulated basis has a table");
                let w = table.nodes.len();
                let k = space.terms;
                let mut values = vec![0.0f32; w * k];
                for kk in 0..k {
                    for ww in 0..w {
                        values[ww * k + kk] = table.values[kk * w + ww] as f32;
                    }
                }
                let n = &table.nodes;
                let inv_step = (w > 1)
                    .then(|| n[1] - n[0])
                    .filter(|&h| n.windows(2).all(|p| p[1] - p[0] == h))
                    .map(|h| 1.0 / h);
                EvaluatorForm::Table {
                    nodes: n.iter().map(|&x| x as f32).collect(),
                    values,
                    inv_step,
                    storage: table.storage.clone(),
                }
            }
        };
        SpectrumEvaluator {
            terms: space.terms,
            lambda_min: space.lambda_min,
            lambda_max: space.lambda_max,
            form,
        }
    }

    /// K, the number of basis functions it evaluates.
    pub fn terms(&self) -> usize {
        self.terms
    }

    /// The tabulated basis as a file stores it (None for the analytic bases).
    pub fn table(&self) -> Option<BasisTable> {
        match &self.form {
            EvaluatorForm::Table {
                nodes,
                values,
                storage,
                ..
            } => {
                let (w, k) = (nodes.len(), self.terms);
                let mut rows = vec![0.0; w * k];
                for kk in 0..k {
                    for ww in 0..w {
                        rows[kk * w + ww] = values[ww * k + kk] as f64;
                    }
                }
                Some(BasisTable {
                    nodes: nodes.iter().map(|&x| x as f64).collect(),
                    values: rows,
                    storage: storage.clone(),
                })
            }
            _ => None,
        }
    }

    /// Heap bytes held (the decoder reports its resident size).
    pub fn heap_bytes(&self) -> usize {
        match &self.form {
            EvaluatorForm::Table {
                nodes,
                values,
                storage,
                ..
            } => 4 * (nodes.capacity() + values.capacity()) + storage.heap_bytes(),
            _ => 0,
        }
    }

    /// The cell of λ (not NaN) in a tabulated basis: (i, f) with B_k(λ) = v_k[i] + f·(v_k[i+1] −
    /// v_k[i]); f = 0 at or below the first node, and (W − 2, 1) at or above the last.
    #[inline(always)]
    fn cell(nodes: &[f32], inv_step: Option<f64>, lambda: f64) -> Cell {
        let w = nodes.len();
        let first = nodes[0] as f64;
        if w == 1 || lambda <= first {
            return Cell { i: 0, f: 0.0 };
        }
        if lambda >= nodes[w - 1] as f64 {
            return Cell { i: w - 2, f: 1.0 };
        }
        if let Some(s) = inv_step {
            // λ > the first node here: the position is positive and, as u32, converts in
            // fewer instructions than as usize.
            let g = (((lambda - first) * s) as u32 as usize).min(w - 2);
            let (lo, hi) = (nodes[g] as f64, nodes[g + 1] as f64);
            if lo <= lambda && lambda < hi {
                return Cell {
                    i: g,
                    f: (lambda - lo) * s,
                };
            }
        }
        let i = nodes.partition_point(|&x| x as f64 <= lambda) - 1;
        let (lo, hi) = (nodes[i] as f64, nodes[i + 1] as f64);
        Cell {
            i,
            f: (lambda - lo) / (hi - lo),
        }
    }

    /// Whether `n` wavelengths are evaluated from node sums: a tabulated basis of at most
    /// [`NODE_SUMS`] nodes, at least 4 wavelengths and at least a quarter as many as nodes (the
    /// sums cost W·K multiply-adds; each wavelength then costs one interpolation instead of K).
    #[inline(always)]
    pub fn uses_node_sums(&self, n: usize) -> bool {
        matches!(&self.form, EvaluatorForm::Table { nodes, .. }
            if nodes.len() <= NODE_SUMS && n >= 4 && 4 * n >= nodes.len())
    }

    /// S_w = Σ_k c\[k\]·v_k\[w\] for every node w of a tabulated basis, into the front of
    /// `sums` (returned); empty for the analytic bases or more than [`NODE_SUMS`] nodes.
    #[inline(always)]
    pub fn node_sums<'a>(&self, c: &[f64], sums: &'a mut [f64; NODE_SUMS]) -> &'a [f64] {
        let EvaluatorForm::Table { nodes, values, .. } = &self.form else {
            return &sums[..0];
        };
        let (w, k) = (nodes.len(), self.terms);
        if w > NODE_SUMS {
            return &sums[..0];
        }
        let c = &c[..c.len().min(k)];
        let sums = &mut sums[..w];
        // A few terms (the usual case) unrolled: a loop's set-up per node would cost more.
        match c.len() {
            1 => node_sums_n::<1>(c, values, k, sums),
            2 => node_sums_n::<2>(c, values, k, sums),
            3 => node_sums_n::<3>(c, values, k, sums),
            4 => node_sums_n::<4>(c, values, k, sums),
            _ => {
                for (s, row) in sums.iter_mut().zip(values.chunks_exact(k)) {
                    let mut sum = 0.0;
                    for (a, &v) in c.iter().zip(row) {
                        sum += a * v as f64;
                    }
                    *s = sum;
                }
            }
        }
        sums
    }

    /// [`Self::cell`] for unevenly spaced nodes, cells `hint` and `hint + 1` tried before the
    /// search: the same cell, the same f.
    #[inline(always)]
    fn cell_near(nodes: &[f32], hint: usize, lambda: f64) -> Cell {
        for i in [hint, hint + 1] {
            if i + 1 < nodes.len() {
                let (lo, hi) = (nodes[i] as f64, nodes[i + 1] as f64);
                if lo < lambda && lambda < hi || (lo == lambda && i > 0) {
                    return Cell {
                        i,
                        f: (lambda - lo) / (hi - lo),
                    };
                }
            }
        }
        Self::cell(nodes, None, lambda)
    }

    /// Where λ (not NaN) falls among a tabulated basis's nodes (node 0 for an analytic basis).
    #[inline(always)]
    pub fn cell_of(&self, lambda: f64) -> Cell {
        match &self.form {
            EvaluatorForm::Table {
                nodes, inv_step, ..
            } => Self::cell(nodes, *inv_step, lambda),
            _ => Cell { i: 0, f: 0.0 },
        }
    }

    /// Σ_k c_k·B_k(λ) from the node sums of c and λ's cell: S_i + f·(S_{i+1} − S_i).
    #[inline(always)]
    pub fn from_node_sums(sums: &[f64], cell: Cell) -> f64 {
        let Some(&s0) = sums.get(cell.i) else {
            return 0.0;
        };
        match sums.get(cell.i + 1) {
            Some(&s1) => s0 + cell.f * (s1 - s0),
            None => s0,
        }
    }

    /// B_0..B_{n−1}(λ) into `out[..n]`, n = `out.len()` ≤ K; λ clamped as in
    /// [`SpectralSpace::eval`] and not NaN.
    #[inline(always)]
    pub fn basis(&self, lambda: f64, out: &mut [f64]) {
        let out_len = out.len().min(self.terms);
        let out = &mut out[..out_len];
        match &self.form {
            EvaluatorForm::Fourier { scale } => {
                let l = lambda.clamp(self.lambda_min, self.lambda_max);
                let (s1, c1) = (scale * (l - self.lambda_min)).sin_cos();
                let (mut cj, mut sj) = (1.0, 0.0);
                for (k, o) in out.iter_mut().enumerate() {
                    if k == 0 {
                        *o = 0.5;
                    } else if k % 2 == 1 {
                        (cj, sj) = (cj * c1 - sj * s1, sj * c1 + cj * s1);
                        *o = cj;
                    } else {
                        *o = sj;
                    }
                }
            }
            EvaluatorForm::Cosine { scale } => {
                let l = lambda.clamp(self.lambda_min, self.lambda_max);
                let x = (scale * (l - self.lambda_min)).cos();
                let (mut prev, mut cur) = (x, 1.0);
                for o in out.iter_mut() {
                    *o = cur;
                    (prev, cur) = (cur, 2.0 * x * cur - prev);
                }
            }
            EvaluatorForm::Table {
                nodes,
                values,
                inv_step,
                ..
            } => {
                let k = self.terms;
                let Cell { i, f } = Self::cell(nodes, *inv_step, lambda);
                if nodes.len() == 1 {
                    for (o, v) in out.iter_mut().zip(&values[..k]) {
                        *o = *v as f64;
                    }
                    return;
                }
                let (r0, r1) = (&values[i * k..i * k + k], &values[(i + 1) * k..(i + 2) * k]);
                // A few terms (the usual case) unrolled: a loop's set-up would cost more.
                match out.len() {
                    1 => lerp_rows::<1>(r0, r1, f, out),
                    2 => lerp_rows::<2>(r0, r1, f, out),
                    3 => lerp_rows::<3>(r0, r1, f, out),
                    4 => lerp_rows::<4>(r0, r1, f, out),
                    _ => {
                        for ((o, &v0), &v1) in out.iter_mut().zip(r0).zip(r1) {
                            let (v0, v1) = (v0 as f64, v1 as f64);
                            *o = v0 + f * (v1 - v0);
                        }
                    }
                }
            }
        }
    }

    /// Σ_k c\[k\]·B_k(λ) over the first `c.len()` (≤ K) terms; λ outside the interval is clamped
    /// as in [`SpectralSpace::eval`]. λ must not be NaN (the decoder answers NaN itself).
    #[inline(always)]
    pub fn dot(&self, c: &[f64], lambda: f64) -> f64 {
        let c = &c[..c.len().min(self.terms)];
        match &self.form {
            EvaluatorForm::Fourier { scale } => {
                let Some((&c0, rest)) = c.split_first() else {
                    return 0.0;
                };
                let l = lambda.clamp(self.lambda_min, self.lambda_max);
                let (s1, c1) = (scale * (l - self.lambda_min)).sin_cos();
                let (mut cj, mut sj) = (1.0, 0.0);
                let mut sum = 0.5 * c0;
                for pair in rest.chunks(2) {
                    (cj, sj) = (cj * c1 - sj * s1, sj * c1 + cj * s1);
                    sum += pair[0] * cj;
                    if let Some(b) = pair.get(1) {
                        sum += b * sj;
                    }
                }
                sum
            }
            EvaluatorForm::Cosine { scale } => {
                let l = lambda.clamp(self.lambda_min, self.lambda_max);
                let x = (scale * (l - self.lambda_min)).cos();
                // Chebyshev recurrence: cos(kθ) = 2x·cos((k−1)θ) − cos((k−2)θ).
                let (mut prev, mut cur) = (x, 1.0); // cos(−θ), cos(0)
                let mut sum = 0.0;
                for &ck in c {
                    sum += ck * cur;
                    (prev, cur) = (cur, 2.0 * x * cur - prev);
                }
                sum
            }
            EvaluatorForm::Table {
                nodes,
                values,
                inv_step,
                ..
            } => {
                let k = self.terms;
                let n = c.len();
                let Cell { i, f } = Self::cell(nodes, *inv_step, lambda);
                if nodes.len() == 1 {
                    let mut sum = 0.0;
                    for (a, &b) in c.iter().zip(&values[..n]) {
                        sum += a * b as f64;
                    }
                    return sum;
                }
                let (r0, r1) = (
                    &values[i * k..i * k + n],
                    &values[(i + 1) * k..(i + 1) * k + n],
                );
                let mut sum = 0.0;
                for ((a, &v0), &v1) in c.iter().zip(r0).zip(r1) {
                    let (v0, v1) = (v0 as f64, v1 as f64);
                    sum += a * (v0 + f * (v1 - v0));
                }
                sum
            }
        }
    }

    /// max(0, Σ_k c_k·B_k(λ)) for every wavelength into `out` (`min` of the two lengths), 0 for
    /// a wavelength that is not finite: the last step of evaluation
    /// (`spec/EVALUATION.md`, "Reconstruction", step 5).
    ///
    /// Many wavelengths from a tabulated basis ([`SpectrumEvaluator::uses_node_sums`]) take
    /// the node sums S_w = Σ_k c_k·v_k\[w\] once and interpolate them per wavelength, which is
    /// Σ_k c_k·B_k(λ) rearranged (equal to rounding, `spec/EVALUATION.md` "Rounding"); the
    /// batch entry point does the same, so its values stay `eval`'s bit for bit.
    #[inline(always)]
    pub fn eval_clamped(&self, c: &[f64], wavelengths: &[f32], out: &mut [f32]) {
        if self.uses_node_sums(wavelengths.len()) {
            let mut sums = [0.0f64; NODE_SUMS];
            let sums = self.node_sums(c, &mut sums);
            if let EvaluatorForm::Table {
                nodes, inv_step, ..
            } = &self.form
            {
                // Unevenly spaced nodes would be searched per wavelength; the usual ascending
                // wavelengths fall in the previous one's cell or the next, checked first (the
                // same cell, so the same bits).
                if inv_step.is_none() {
                    let mut hint = 0;
                    for (o, &l) in out.iter_mut().zip(wavelengths) {
                        let l = l as f64;
                        *o = if l.is_finite() {
                            let cell = Self::cell_near(nodes, hint, l);
                            hint = cell.i;
                            Self::from_node_sums(sums, cell).max(0.0) as f32
                        } else {
                            0.0
                        };
                    }
                    return;
                }
                for (o, &l) in out.iter_mut().zip(wavelengths) {
                    let l = l as f64;
                    *o = if l.is_finite() {
                        let cell = Self::cell(nodes, *inv_step, l);
                        Self::from_node_sums(sums, cell).max(0.0) as f32
                    } else {
                        0.0
                    };
                }
            }
            return;
        }
        for (o, &l) in out.iter_mut().zip(wavelengths) {
            let l = l as f64;
            *o = if l.is_finite() {
                self.dot(c, l).max(0.0) as f32
            } else {
                0.0
            };
        }
    }
}

/// sums\[w\] = Σ_{k<N} c\[k\]·values\[w·stride + k\] (`c` holds N, `values` a row of
/// `stride` ≥ N per node).
#[inline(always)]
fn node_sums_n<const N: usize>(c: &[f64], values: &[f32], stride: usize, sums: &mut [f64]) {
    let Some(c) = c.first_chunk::<N>() else {
        return;
    };
    for (s, row) in sums.iter_mut().zip(values.chunks_exact(stride)) {
        let Some(row) = row.first_chunk::<N>() else {
            return;
        };
        let mut sum = 0.0;
        for k in 0..N {
            sum += c[k] * row[k] as f64;
        }
        *s = sum;
    }
}

/// out\[k\] = r0\[k\] + f·(r1\[k\] − r0\[k\]) for k < N (every slice holds at least N).
#[inline(always)]
fn lerp_rows<const N: usize>(r0: &[f32], r1: &[f32], f: f64, out: &mut [f64]) {
    let (Some(r0), Some(r1), Some(out)) = (
        r0.first_chunk::<N>(),
        r1.first_chunk::<N>(),
        out.first_chunk_mut::<N>(),
    ) else {
        return;
    };
    for k in 0..N {
        let (v0, v1) = (r0[k] as f64, r1[k] as f64);
        out[k] = v0 + f * (v1 - v0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_found_from_a_hint_is_the_searched_cell_bit_for_bit() {
        // Unevenly spaced nodes, wavelengths at, between and beyond them, every hint.
        let nodes = [400.0f32, 410.0, 425.0, 450.0, 452.5, 500.0, 610.0, 700.0];
        let mut lambdas = vec![350.0, 399.9, 700.0, 750.0, f64::MIN_POSITIVE];
        for w in nodes.windows(2) {
            let (a, b) = (w[0] as f64, w[1] as f64);
            lambdas.extend([a, a + 1e-9, (a + b) / 2.0, b - 1e-9]);
        }
        for &l in &lambdas {
            let want = SpectrumEvaluator::cell(&nodes, None, l);
            for hint in 0..nodes.len() + 2 {
                let got = SpectrumEvaluator::cell_near(&nodes, hint, l);
                assert_eq!(
                    (got.i, got.f.to_bits()),
                    (want.i, want.f.to_bits()),
                    "λ {l}, hint {hint}"
                );
            }
        }
    }

    fn space(terms: usize) -> SpectralSpace {
        SpectralSpace::analytic(SpectralBasis::PeriodicFourier, terms, 400.0, 700.0)
    }

    #[test]
    fn codes_round_trip() {
        for b in [
            SpectralBasis::PeriodicFourier,
            SpectralBasis::Cosine,
            SpectralBasis::Tabulated,
        ] {
            assert_eq!(SpectralBasis::from_code(b.code()), Some(b));
        }
        assert_eq!(SpectralBasis::from_code(0), None);
    }

    #[test]
    fn cosine_basis_values() {
        let s = SpectralSpace::analytic(SpectralBasis::Cosine, 3, 400.0, 700.0);
        let mut b = [0.0; 3];
        s.eval(400.0, &mut b);
        assert_eq!(b, [1.0, 1.0, 1.0]);
        s.eval(550.0, &mut b);
        assert!((b[1]).abs() < 1e-15 && (b[2] + 1.0).abs() < 1e-15);
        s.eval(700.0, &mut b);
        assert!((b[1] + 1.0).abs() < 1e-15 && (b[2] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn tabulated_basis_interpolates_linearly_and_clamps() {
        let s = SpectralSpace {
            table: Some(BasisTable {
                nodes: vec![400.0, 500.0, 700.0],
                values: vec![1.0, 2.0, 4.0, 0.0, -1.0, 1.0],
                storage: crate::model::basis_storage::BasisStorage::Float(
                    crate::model::Precision::F32,
                ),
            }),
            ..SpectralSpace::analytic(SpectralBasis::Tabulated, 2, 400.0, 700.0)
        };
        assert!(s.validate().is_ok());
        let mut b = [0.0; 2];
        s.eval(450.0, &mut b);
        assert_eq!(b, [1.5, -0.5]);
        s.eval(600.0, &mut b);
        assert_eq!(b, [3.0, 0.0]);
        s.eval(380.0, &mut b);
        assert_eq!(b, [1.0, 0.0]);
        s.eval(900.0, &mut b);
        assert_eq!(b, [4.0, 1.0]);
    }

    #[test]
    fn projection_reproduces_low_harmonics_exactly() {
        // A spectrum that lies in the span of the first 5 functions is recovered exactly by the
        // trapezoidal projection on a uniform grid (the rule is exact for periodic trig products).
        let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
        let s = space(5);
        let truth = [0.8, 0.1, -0.05, 0.02, 0.03];
        let syn = s.synthesis(&wl);
        let rho: Vec<f64> = (0..wl.len())
            .map(|w| (0..5).map(|k| syn[w * 5 + k] * truth[k]).sum())
            .collect();
        let proj = s.fourier_projection(&wl);
        for k in 0..5 {
            let c: f64 = (0..wl.len()).map(|w| proj[k * wl.len() + w] * rho[w]).sum();
            assert!((c - truth[k]).abs() < 1e-12, "k={k}: {c}");
        }
    }

    #[test]
    fn single_wavelength() {
        let s = SpectralSpace::analytic(SpectralBasis::PeriodicFourier, 1, 550.0, 550.0);
        assert!(s.validate().is_ok());
        let p = s.fourier_projection(&[550.0]);
        let mut b = [0.0];
        s.eval(550.0, &mut b);
        assert_eq!(p[0] * 0.7 * b[0], 0.7);
        let bad = SpectralSpace { terms: 3, ..s };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn queries_outside_the_interval_clamp() {
        let s = space(5);
        let (mut a, mut b) = ([0.0; 5], [0.0; 5]);
        s.eval(750.0, &mut a);
        s.eval(700.0, &mut b);
        assert_eq!(a, b);
    }
    #[test]
    fn evaluator_agrees_with_the_basis_functions() {
        let table = BasisTable {
            nodes: vec![400.0, 410.0, 420.0, 430.0, 450.0, 700.0],
            // Values a file can hold (the decoder keeps them as f32).
            values: (0..18)
                .map(|i| (((i * 7919) % 13) as f64 / 13.0 - 0.4) as f32 as f64)
                .collect(),
            storage: crate::model::basis_storage::BasisStorage::Float(crate::model::Precision::F32),
        };
        let uniform = BasisTable {
            nodes: (0..31).map(|i| 400.0 + 10.0 * i as f64).collect(),
            values: (0..93)
                .map(|i| (((i * 104729) % 17) as f64 / 17.0 - 0.3) as f32 as f64)
                .collect(),
            storage: crate::model::basis_storage::BasisStorage::Float(crate::model::Precision::F32),
        };
        let spaces = [
            SpectralSpace::analytic(SpectralBasis::PeriodicFourier, 13, 400.0, 700.0),
            SpectralSpace::analytic(SpectralBasis::PeriodicFourier, 1, 550.0, 550.0),
            SpectralSpace::analytic(SpectralBasis::Cosine, 40, 395.0, 705.0),
            SpectralSpace::analytic(SpectralBasis::Cosine, 1, 550.0, 550.0),
            SpectralSpace {
                table: Some(table),
                ..SpectralSpace::analytic(SpectralBasis::Tabulated, 3, 400.0, 700.0)
            },
            SpectralSpace {
                table: Some(uniform),
                ..SpectralSpace::analytic(SpectralBasis::Tabulated, 3, 400.0, 700.0)
            },
        ];
        for s in &spaces {
            assert!(s.validate().is_ok());
            let ev = SpectrumEvaluator::new(s);
            let c: Vec<f64> = (0..s.terms).map(|k| 1.0 / (k as f64 + 1.0)).collect();
            let mut b = vec![0.0; s.terms];
            for l in [
                300.0, 395.0, 400.0, 404.9, 410.0, 449.99, 523.7, 550.0, 699.9, 700.0, 800.0,
            ] {
                if let Some(t) = &s.table {
                    assert_eq!(ev.table().as_ref(), Some(t), "the table comes back exactly");
                }
                for used in [1, s.terms] {
                    s.eval(l, &mut b);
                    let direct: f64 = c[..used].iter().zip(&b).map(|(x, y)| x * y).sum();
                    let fast = ev.dot(&c[..used], l);
                    // The basis values the batch decoder keeps give the same sum, bit for bit.
                    let mut bv = vec![0.0; used];
                    ev.basis(l, &mut bv);
                    let mut via = 0.0;
                    for (x, y) in c[..used].iter().zip(&bv) {
                        via += x * y;
                    }
                    assert_eq!(via.to_bits(), (fast + 0.0).to_bits(), "{:?} λ={l}", s.basis);
                    assert!(
                        (fast - direct).abs() <= 1e-12 * (1.0 + direct.abs()),
                        "{:?} K={} λ={l} used={used}: {fast} vs {direct}",
                        s.basis,
                        s.terms
                    );
                }
            }
        }
    }
}
