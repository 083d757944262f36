//! Fitting the factor model ([`crate::model::factor`]) to every incidence at once, for measured
//! data: Levenberg–Marquardt on the two held-out metrics themselves (mean squared log ratio plus
//! squared relative L2), with a smoothness penalty on every table whose strength is chosen by
//! cross-validation inside the training data. The steps are written out in
//! `spec/EVALUATION.md`, "How the encoder fits (informative)", "Factor model".
//!
//! Why these choices (measured on the Cornell and NIST data, `examples/measured.rs`): a model
//! shared across incidences predicts a held-out near-mirror sample from the other incidences'
//! spikes, where a per-incidence fit has one sample on it; fitting in log space with a model
//! positive by construction keeps the measurement floor (42% of the acrylic's values are exact
//! zeros) free of invented light; and too little smoothing lets exp() of an unconstrained table
//! explode between the samples, which the relative-error term of the CV score catches.

use crate::encode::metrics::{fold_ranks, log_epsilon, ErrorSums};
use crate::encode::samples::SampleSet;
use crate::model::angles::dir_from_deg;
use crate::model::factor::{
    Axis, FactorComponent, FactorModel, Feature, FeatureRanges, FeatureValues, Taps, ETA_MAX,
};
use crate::model::Precision;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// One component to fit: its features and rank.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentSpec {
    /// The angle features its tables are over.
    pub features: Vec<Feature>,
    /// Its rank R (number of log terms), 1 to [`crate::model::factor::MAX_RANK`].
    pub rank: usize,
}

/// The default structure: a body (diffuse) term of rank 3 over θi, θo, θd and (θi, x), a broad
/// specular term over θh, θd, θi, θo, and a sharp one over θh, θd.
pub fn default_components() -> Vec<ComponentSpec> {
    use Feature::*;
    vec![
        ComponentSpec {
            features: vec![Incidence, Exitance, DifferenceAngle, IncidenceToward],
            rank: 3,
        },
        ComponentSpec {
            features: vec![HalfAngle, DifferenceAngle, Incidence, Exitance],
            rank: 1,
        },
        ComponentSpec {
            features: vec![HalfAngle, DifferenceAngle],
            rank: 1,
        },
    ]
}

/// What to fit and how hard to smooth.
#[derive(Debug, Clone, PartialEq)]
pub struct FactorOptions {
    /// The components to fit ([`default_components`] by default).
    pub components: Vec<ComponentSpec>,
    /// Candidate table smoothness strengths; with more than one, chosen by `inner_folds`-fold
    /// cross-validation on the training data (score log² + rel²), ties to the larger.
    pub smoothness: Vec<f64>,
    /// Folds of the inner cross-validation that chooses the smoothness (below 2: the first
    /// candidate is taken).
    pub inner_folds: usize,
    /// The precision the model's parameters are stored in.
    pub precision: Precision,
    /// Most Levenberg–Marquardt iterations per fit.
    pub max_iterations: usize,
}

impl Default for FactorOptions {
    fn default() -> Self {
        FactorOptions {
            components: default_components(),
            smoothness: vec![1e-2, 1e-3],
            inner_folds: 2,
            precision: Precision::F16,
            max_iterations: 300,
        }
    }
}

/// The seed-index offset of the inner cross-validation's folds (so they differ from
/// `validate`'s outer folds, seed index 0).
pub const INNER_FOLD_SALT: usize = 7919;

/// Smoothness of the spectra and modulations, and the ridge on every parameter.
const SPECTRAL_SMOOTHNESS: f64 = 1e-6;
const RIDGE: f64 = 1e-6;

/// A fitted model, the smoothness it was fitted with, and the cross-validation behind the choice.
#[derive(Debug, Clone)]
pub struct FactorFit {
    /// The fitted model.
    pub model: FactorModel,
    /// The table smoothness strength it was fitted with.
    pub smoothness: f64,
    /// Per candidate: (μ, inner held-out sums per incidence); empty with one candidate.
    pub inner: Vec<(f64, Vec<ErrorSums>)>,
}

impl FactorFit {
    /// The inner held-out sums per incidence at the chosen smoothness, if there was a choice.
    pub fn held_out(&self) -> Option<&[ErrorSums]> {
        self.inner
            .iter()
            .find(|c| c.0 == self.smoothness)
            .map(|c| c.1.as_slice())
    }
}

/// The samples in the form the fit uses: one row per outgoing direction of every incidence.
struct Rows {
    /// Per row, per feature code − 1: up to 4 (table index, weight) taps.
    taps: Vec<[Taps; 6]>,
    features: Vec<FeatureValues>,
    /// rows × W measured values.
    values: Vec<f64>,
    w: usize,
}

impl Rows {
    fn of(set: &SampleSet, keep: &dyn Fn(usize, usize) -> bool) -> Rows {
        let w = set.wavelengths.len();
        let (mut taps, mut features, mut values) = (Vec::new(), Vec::new(), Vec::new());
        for (i, s) in set.incidences.iter().enumerate() {
            let wi = dir_from_deg(s.theta_i, s.phi_i);
            for (d, dir) in s.directions.iter().enumerate() {
                if !keep(i, d) {
                    continue;
                }
                let f = FeatureValues::of(wi, dir_from_deg(dir[0], dir[1]));
                features.push(f);
                taps.push(all_taps(&f));
                values.extend_from_slice(&s.values[d * w..(d + 1) * w]);
            }
        }
        Rows {
            taps,
            features,
            values,
            w,
        }
    }

    fn len(&self) -> usize {
        self.features.len()
    }

    /// The training data's range of every feature (θh, θd, θi, θo, x).
    fn ranges(&self) -> FeatureRanges {
        let mut r = [[f32::INFINITY, f32::NEG_INFINITY]; 5];
        for f in &self.features {
            for (k, v) in [f.h, f.d, f.i, f.o, f.x].into_iter().enumerate() {
                r[k][0] = r[k][0].min(v as f32);
                r[k][1] = r[k][1].max(v as f32);
            }
        }
        // Widened a little so that f32 rounding leaves every training value inside, then kept
        // in the format's bounds.
        for (k, x) in r.iter_mut().enumerate() {
            let (lo, hi) = if k == 4 { (-1.0, 1.0) } else { (0.0, 90.0) };
            x[0] = (x[0] - 1e-5).clamp(lo, hi);
            x[1] = (x[1] + 1e-5).clamp(lo, hi);
        }
        r
    }
}

fn all_taps(f: &FeatureValues) -> [Taps; 6] {
    let mut t = [([(0, 0.0); 4], 0); 6];
    for code in 1..=6u8 {
        let k = Feature::from_code(code).expect("codes 1–6 are features");
        t[code as usize - 1] = f.taps(k);
    }
    t
}

/// Per rank: its modulation's offset (ranks ≥ 1) and each feature's table offset.
type RankSlots = (Option<usize>, Vec<usize>);

/// Where each parameter lives in the flat vector: per component, its spectrum, then per rank
/// its modulation (rank ≥ 1) and one table per feature.
struct Layout {
    /// Per component: spectrum offset; per rank: (modulation offset or None, per feature its
    /// table offset).
    comps: Vec<(usize, Vec<RankSlots>)>,
    specs: Vec<ComponentSpec>,
    len: usize,
}

impl Layout {
    fn new(specs: &[ComponentSpec], w: usize) -> Layout {
        let mut o = 0;
        let mut comps = Vec::new();
        for c in specs {
            let s = o;
            o += w;
            let mut ranks = Vec::new();
            for r in 0..c.rank {
                let m = (r >= 1).then(|| {
                    o += w;
                    o - w
                });
                let mut t = Vec::new();
                for k in &c.features {
                    t.push(o);
                    o += k.table_len();
                }
                ranks.push((m, t));
            }
            comps.push((s, ranks));
        }
        Layout {
            comps,
            specs: specs.to_vec(),
            len: o,
        }
    }

    fn model(&self, p: &[f64], ranges: FeatureRanges, precision: Precision) -> FactorModel {
        let round = |v: f64| match precision {
            Precision::F32 => v as f32,
            Precision::F16 => half::f16::from_f64(v).to_f32(),
        };
        let w = |at: usize, n: usize| p[at..at + n].iter().map(|&v| round(v)).collect::<Vec<_>>();
        let nw = self.comps.first().map_or(0, |c| {
            // The spectrum's length: up to the first table or modulation.
            let (s, ranks) = c;
            ranks[0].1.first().copied().unwrap_or(self.len) - s
        });
        let components = self
            .comps
            .iter()
            .zip(&self.specs)
            .map(|((s, ranks), spec)| FactorComponent {
                features: spec.features.clone(),
                spectrum: w(*s, nw),
                modulation: ranks
                    .iter()
                    .filter_map(|(m, _)| m.map(|m| w(m, nw)))
                    .collect(),
                tables: ranks
                    .iter()
                    .map(|(_, t)| {
                        t.iter()
                            .zip(&spec.features)
                            .map(|(&o, k)| w(o, k.table_len()))
                            .collect()
                    })
                    .collect(),
            })
            .collect();
        FactorModel {
            precision,
            ranges,
            components,
        }
    }
}

/// The penalty matrix μ·DᵀD of one table: second differences in index space for θh, θd and x,
/// second divided differences in 1/cos θ for θi and θo (null space: linear in 1/cos θ), both axes
/// of the 2-D table.
fn table_penalty(k: Feature) -> DMatrix<f64> {
    fn d2(axis: Axis) -> DMatrix<f64> {
        let n = axis.nodes.len();
        let mut d = DMatrix::zeros(n - 2, n);
        let u: Vec<f64> = axis.nodes.iter().map(|&v| axis.coordinate(v)).collect();
        for j in 0..n - 2 {
            if axis.secant {
                let (h1, h2) = (u[j + 1] - u[j], u[j + 2] - u[j + 1]);
                let s = (h1 + h2) / 4.0;
                d[(j, j)] = s / h1;
                d[(j, j + 1)] = -s * (h1 + h2) / (h1 * h2);
                d[(j, j + 2)] = s / h2;
            } else {
                d[(j, j)] = 1.0;
                d[(j, j + 1)] = -2.0;
                d[(j, j + 2)] = 1.0;
            }
        }
        d
    }
    let one = |a: Axis| {
        let d = d2(a);
        d.transpose() * d
    };
    match k {
        Feature::HalfAngle => one(Axis::H),
        Feature::DifferenceAngle => one(Axis::D),
        Feature::Incidence | Feature::Exitance => one(Axis::POLAR),
        Feature::Toward => one(Axis::X),
        Feature::IncidenceToward => {
            let (a, b) = (Axis::POLAR_COARSE, Axis::X);
            let (na, nb) = (a.nodes.len(), b.nodes.len());
            let (da, db) = (one(a), one(b));
            // Kronecker sums: (Da ⊗ I) + (I ⊗ Db), indices i·nb + j.
            DMatrix::from_fn(na * nb, na * nb, |r, c| {
                let (ra, rb, ca, cb) = (r / nb, r % nb, c / nb, c % nb);
                let mut v = 0.0;
                if rb == cb {
                    v += da[(ra, ca)];
                }
                if ra == ca {
                    v += db[(rb, cb)];
                }
                v
            })
        }
    }
}

fn second_difference_gram(n: usize) -> DMatrix<f64> {
    if n < 3 {
        return DMatrix::zeros(n, n);
    }
    let mut d = DMatrix::zeros(n - 2, n);
    for j in 0..n - 2 {
        d[(j, j)] = 1.0;
        d[(j, j + 1)] = -2.0;
        d[(j, j + 2)] = 1.0;
    }
    d.transpose() * d
}

/// The whole penalty matrix for smoothness `mu`.
fn penalty(layout: &Layout, w: usize, mu: f64) -> DMatrix<f64> {
    let mut r = DMatrix::identity(layout.len, layout.len) * RIDGE;
    let spec = second_difference_gram(w) * SPECTRAL_SMOOTHNESS;
    let mut add = |at: usize, m: &DMatrix<f64>| {
        let n = m.nrows();
        let mut v = r.view_mut((at, at), (n, n));
        v += m;
    };
    for ((s, ranks), c) in layout.comps.iter().zip(&layout.specs) {
        add(*s, &spec);
        for (m, tables) in ranks {
            if let Some(m) = m {
                add(*m, &spec);
            }
            for (&o, k) in tables.iter().zip(&c.features) {
                add(o, &(table_penalty(*k) * mu));
            }
        }
    }
    r
}

/// Per row: T_cr for every component and rank, and g_c = exp(min(η_c, 60)) per wavelength.
struct State {
    /// rows × total rank.
    t: Vec<f64>,
    /// rows × components × W.
    g: Vec<f64>,
    /// rows × W: Σ_c g_c.
    ph: Vec<f64>,
    objective: f64,
}

struct Problem<'a> {
    rows: &'a Rows,
    layout: Layout,
    /// ln(max(V, 0) + ε).
    ln_v: Vec<f64>,
    eps: f64,
    w_log: f64,
    w_lin: f64,
    penalty: DMatrix<f64>,
    total_rank: usize,
}

impl<'a> Problem<'a> {
    fn new(rows: &'a Rows, specs: &[ComponentSpec], eps: f64, mu: f64) -> Problem<'a> {
        let w = rows.w;
        let layout = Layout::new(specs, w);
        let n = (rows.len() * w).max(1) as f64;
        let sum_sq: f64 = rows.values.iter().map(|v| v * v).sum();
        Problem {
            ln_v: rows
                .values
                .iter()
                .map(|v| (v.max(0.0) + eps).ln())
                .collect(),
            eps,
            w_log: 1.0 / n.sqrt(),
            w_lin: if sum_sq > 0.0 {
                1.0 / sum_sq.sqrt()
            } else {
                0.0
            },
            penalty: penalty(&layout, w, mu),
            total_rank: specs.iter().map(|c| c.rank).sum(),
            layout,
            rows,
        }
    }

    fn state(&self, p: &[f64]) -> State {
        let (rows, w, nc) = (self.rows, self.rows.w, self.layout.comps.len());
        let tr = self.total_rank;
        let mut t = vec![0.0; rows.len() * tr];
        let mut g = vec![0.0; rows.len() * nc * w];
        let mut ph = vec![0.0; rows.len() * w];
        let mut data_term = 0.0;
        for x in 0..rows.len() {
            let taps = &rows.taps[x];
            let tx = &mut t[x * tr..(x + 1) * tr];
            let mut k = 0;
            for ((_, ranks), spec) in self.layout.comps.iter().zip(&self.layout.specs) {
                for (_, tables) in ranks {
                    let mut v = 0.0;
                    for (&o, f) in tables.iter().zip(&spec.features) {
                        let (tp, m) = &taps[f.code() as usize - 1];
                        for &(j, wt) in &tp[..*m] {
                            v += wt * p[o + j];
                        }
                    }
                    tx[k] = v;
                    k += 1;
                }
            }
            let mut k = 0;
            for (c, (s, ranks)) in self.layout.comps.iter().enumerate() {
                for l in 0..w {
                    let mut eta = p[s + l] + tx[k];
                    for (r, (m, _)) in ranks.iter().enumerate().skip(1) {
                        eta += p[m.expect("rank ≥ 1 has a modulation") + l] * tx[k + r];
                    }
                    let gv = eta.min(ETA_MAX).exp();
                    g[(x * nc + c) * w + l] = gv;
                    ph[x * w + l] += gv;
                }
                k += ranks.len();
            }
            for l in 0..w {
                let i = x * w + l;
                let rl = self.w_log * ((ph[i] + self.eps).ln() - self.ln_v[i]);
                let rn = self.w_lin * (ph[i] - rows.values[i]);
                data_term += rl * rl + rn * rn;
            }
        }
        let pv = DVector::from_column_slice(p);
        let pen = (pv.transpose() * &self.penalty * &pv)[(0, 0)];
        State {
            t,
            g,
            ph,
            objective: 0.5 * (data_term + pen),
        }
    }

    /// The Gauss–Newton normal matrix JᵀWJ + penalty and the gradient at `p`. Per row, the
    /// Jacobian of ρ̂(λ) has, for the table parameters of group (c, r), g_c(λ)·w_cr(λ) times the
    /// tap weight, and for the spectral vector of group (c, r) at λ, g_c(λ) (r = 0: the spectrum
    /// s_c) or g_c(λ)·T_cr (r ≥ 1: the modulation w_cr); both residuals (log and linear) share it.
    fn normal_equations(&self, p: &[f64], st: &State) -> (DMatrix<f64>, DVector<f64>) {
        let (rows, w) = (self.rows, self.rows.w);
        let nc = self.layout.comps.len();
        let tr = self.total_rank;
        let n = self.layout.len;
        let mut a = DMatrix::<f64>::zeros(n, n);
        let mut grad = DVector::<f64>::zeros(n);
        let mut w2 = vec![0.0; w];
        let mut reff = vec![0.0; w];
        // Groups (c, r) in parameter order: component, its spectral vector's offset, and the
        // tables of that rank.
        let mut groups: Vec<(usize, usize, Option<usize>)> = Vec::new();
        for (c, (s, ranks)) in self.layout.comps.iter().enumerate() {
            for (r, (m, _)) in ranks.iter().enumerate() {
                groups.push((c, r, if r == 0 { Some(*s) } else { *m }));
            }
        }
        let ng = groups.len();
        let mut taps: Vec<Vec<(usize, f64)>> = vec![Vec::with_capacity(16); ng];
        let mut gv = vec![0.0; ng * w];
        let mut hv = vec![0.0; ng * w];
        let mut v = vec![0.0; w];
        // The spectral × spectral terms per group pair (g1, g2) and wavelength, and the table ×
        // spectral terms per table parameter, group g2 and wavelength, summed apart (below).
        let mut spectral = vec![0.0; ng * ng * w];
        let mut mixed = vec![0.0; n * ng * w];
        for x in 0..rows.len() {
            for l in 0..w {
                let i = x * w + l;
                let ph = st.ph[i];
                let al = self.w_log / (ph + self.eps);
                let rl = self.w_log * ((ph + self.eps).ln() - self.ln_v[i]);
                let rn = self.w_lin * (ph - rows.values[i]);
                w2[l] = al * al + self.w_lin * self.w_lin;
                reff[l] = al * rl + self.w_lin * rn;
            }
            let tx = &st.t[x * tr..(x + 1) * tr];
            let mut gi = 0;
            for ((_, ranks), spec) in self.layout.comps.iter().zip(&self.layout.specs) {
                for (r, (m, tables)) in ranks.iter().enumerate() {
                    let c = groups[gi].0;
                    taps[gi].clear();
                    for (&o, f) in tables.iter().zip(&spec.features) {
                        let (tp, cnt) = &rows.taps[x][f.code() as usize - 1];
                        for &(j, wt) in &tp[..*cnt] {
                            if wt != 0.0 {
                                taps[gi].push((o + j, wt));
                            }
                        }
                    }
                    for l in 0..w {
                        let gc = st.g[(x * nc + c) * w + l];
                        gv[gi * w + l] = gc * m.map_or(1.0, |m| p[m + l]);
                        hv[gi * w + l] = if r == 0 { gc } else { gc * tx[gi] };
                    }
                    gi += 1;
                }
            }
            for g1 in 0..ng {
                let (gv1, hv1) = (&gv[g1 * w..(g1 + 1) * w], &hv[g1 * w..(g1 + 1) * w]);
                let q1 = groups[g1].2.expect("every group has a spectral vector");
                let sg: f64 = (0..w).map(|l| reff[l] * gv1[l]).sum();
                for &(pi, b) in &taps[g1] {
                    grad[pi] += sg * b;
                }
                for l in 0..w {
                    grad[q1 + l] += reff[l] * hv1[l];
                }
                for g2 in 0..ng {
                    let (gv2, hv2) = (&gv[g2 * w..(g2 + 1) * w], &hv[g2 * w..(g2 + 1) * w]);
                    let q2 = groups[g2].2.expect("every group has a spectral vector");
                    // table × table
                    let s: f64 = (0..w).map(|l| w2[l] * gv1[l] * gv2[l]).sum();
                    if s != 0.0 {
                        for &(p1, b1) in &taps[g1] {
                            for &(p2, b2) in &taps[g2] {
                                if p1 >= p2 {
                                    a[(p1, p2)] += s * b1 * b2;
                                }
                            }
                        }
                    }
                    // spectral × spectral (same wavelength only)
                    if q1 >= q2 {
                        let to = &mut spectral[(g1 * ng + g2) * w..(g1 * ng + g2 + 1) * w];
                        for l in 0..w {
                            to[l] += w2[l] * hv1[l] * hv2[l];
                        }
                    }
                    // table (g1) × spectral (g2)
                    for l in 0..w {
                        v[l] = w2[l] * gv1[l] * hv2[l];
                    }
                    for &(p1, b1) in &taps[g1] {
                        let to = &mut mixed[(p1 * ng + g2) * w..(p1 * ng + g2 + 1) * w];
                        for l in 0..w {
                            to[l] += v[l] * b1;
                        }
                    }
                }
            }
        }
        // The mixed and spectral blocks into the lower triangle, then its mirror above
        // (`Cholesky::new` reads the lower alone). Each entry holds the same terms added in the
        // same order as when every row added into the matrix itself (the encoder's output
        // did not change by a bit); summed apart, the row loop's additions run over
        // consecutive wavelengths instead of scattering over the matrix (a Cornell encode
        // 7.9 s → 6.8 s). The mixed block's rows of spectral parameters are zeros that land on
        // spectral × spectral entries, so the spectral block is written after it.
        for p1 in 0..n {
            for (g2, group2) in groups.iter().enumerate() {
                let q2 = group2.2.expect("every group has a spectral vector");
                let from = &mixed[(p1 * ng + g2) * w..(p1 * ng + g2 + 1) * w];
                for (l, &x) in from.iter().enumerate() {
                    let q = q2 + l;
                    a[(p1.max(q), p1.min(q))] = x;
                }
            }
        }
        for (g1, group1) in groups.iter().enumerate() {
            let q1 = group1.2.expect("every group has a spectral vector");
            for (g2, group2) in groups.iter().enumerate() {
                let q2 = group2.2.expect("every group has a spectral vector");
                if q1 >= q2 {
                    for l in 0..w {
                        a[(q1 + l, q2 + l)] = spectral[(g1 * ng + g2) * w + l];
                    }
                }
            }
        }
        a.fill_upper_triangle_with_lower_triangle();
        let pv = DVector::from_column_slice(p);
        grad += &self.penalty * &pv;
        (a + &self.penalty, grad)
    }
}

/// The deterministic starting point (`EVALUATION.md`, "How the encoder fits", "Factor model").
fn initial(rows: &Rows, layout: &Layout, wavelengths: &[f64]) -> Vec<f64> {
    let w = rows.w;
    let mut p = vec![0.0; layout.len];
    let off: Vec<usize> = (0..rows.len())
        .filter(|&x| rows.features[x].h > 15.0)
        .collect();
    let pick: Vec<usize> = if off.is_empty() {
        (0..rows.len()).collect()
    } else {
        off
    };
    let mut mean = vec![0.0; w];
    for &x in &pick {
        for (m, v) in mean.iter_mut().zip(&rows.values[x * w..(x + 1) * w]) {
            *m += v / pick.len() as f64;
        }
    }
    let overall = mean.iter().sum::<f64>() / w as f64;
    let floor = (1e-3 * overall).max(1e-12);
    let mspec: Vec<f64> = mean.iter().map(|&v| v.max(floor)).collect();
    let flat = (mspec.iter().sum::<f64>() / w as f64).ln();
    let (lo, hi) = (wavelengths[0], wavelengths[w - 1]);
    let t = |l: f64| {
        if hi > lo {
            2.0 * (l - lo) / (hi - lo) - 1.0
        } else {
            0.0
        }
    };
    for (c, ((s, ranks), spec)) in layout.comps.iter().zip(&layout.specs).enumerate() {
        for l in 0..w {
            p[s + l] = if c == 0 { mspec[l].ln() } else { flat };
        }
        // A specular component starts as a peak falling linearly in θh, each later one 4× sharper:
        // the broad haze and the sharp spike start apart.
        if c > 0 {
            if let Some(k) = spec.features.iter().position(|f| *f == Feature::HalfAngle) {
                let o = ranks[0].1[k];
                for (j, &node) in Axis::H.nodes.iter().enumerate() {
                    p[o + j] = 3.0 - node / 3.0 * 4f64.powi(c as i32 - 1);
                }
            }
        }
        // Ranks ≥ 1: modulation = Legendre polynomial P_r over the wavelength range (a start
        // at zero modulation and zero table is a saddle the fit never leaves).
        for (r, (m, _)) in ranks.iter().enumerate().skip(1) {
            let m = m.expect("rank ≥ 1 has a modulation");
            for (l, &lam) in wavelengths.iter().enumerate() {
                p[m + l] = legendre(r, t(lam));
            }
        }
    }
    p
}

fn legendre(n: usize, x: f64) -> f64 {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return p0;
    }
    for k in 1..n {
        let p2 = ((2 * k + 1) as f64 * x * p1 - k as f64 * p0) / (k + 1) as f64;
        p0 = p1;
        p1 = p2;
    }
    p1
}

/// Levenberg–Marquardt from `p0`: returns the parameters and the final objective.
fn levenberg_marquardt(pb: &Problem, p0: Vec<f64>, max_iterations: usize) -> Vec<f64> {
    let mut p = p0;
    let mut st = pb.state(&p);
    let mut damping = 1e-3;
    for _ in 0..max_iterations {
        let (a, grad) = pb.normal_equations(&p, &st);
        let diag: Vec<f64> = (0..a.nrows()).map(|i| a[(i, i)]).collect();
        let mut accepted = None;
        for _ in 0..25 {
            let mut m = a.clone();
            for (i, d) in diag.iter().enumerate() {
                m[(i, i)] += damping * (d + 1e-12);
            }
            let Some(ch) = m.cholesky() else {
                damping *= 10.0;
                continue;
            };
            let step = ch.solve(&(-&grad));
            let q: Vec<f64> = p.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
            if q.iter().any(|v| !v.is_finite()) {
                damping *= 4.0;
                continue;
            }
            let sq = pb.state(&q);
            if sq.objective < st.objective {
                accepted = Some((q, sq));
                damping = (damping / 3.0).max(1e-9);
                break;
            }
            damping *= 4.0;
        }
        let Some((q, sq)) = accepted else { break };
        let gain = (st.objective - sq.objective) / st.objective.max(1e-300);
        p = q;
        st = sq;
        if gain < 1e-6 {
            break;
        }
    }
    p
}

/// Fits one smoothness strength on the samples `keep` selects.
fn fit_once(
    set: &SampleSet,
    keep: &dyn Fn(usize, usize) -> bool,
    opts: &FactorOptions,
    eps: f64,
    mu: f64,
) -> Option<FactorModel> {
    let rows = Rows::of(set, keep);
    if rows.len() == 0 {
        return None;
    }
    let pb = Problem::new(&rows, &opts.components, eps, mu);
    let p0 = initial(&rows, &pb.layout, &set.wavelengths);
    let p = levenberg_marquardt(&pb, p0, opts.max_iterations);
    Some(pb.layout.model(&p, rows.ranges(), opts.precision))
}

/// Evaluates `model` at the samples `keep` selects, adding to `sums`.
pub fn score(
    model: &FactorModel,
    set: &SampleSet,
    keep: &dyn Fn(usize, usize) -> bool,
    eps: f64,
    sums: &mut ErrorSums,
) {
    let w = set.wavelengths.len();
    let mut t = vec![0.0; model.total_rank()];
    for (i, s) in set.incidences.iter().enumerate() {
        let wi = dir_from_deg(s.theta_i, s.phi_i);
        for (d, dir) in s.directions.iter().enumerate() {
            if !keep(i, d) {
                continue;
            }
            let f = FeatureValues::of(wi, dir_from_deg(dir[0], dir[1])).clamped(&model.ranges);
            model.angular(&f, &mut t);
            for l in 0..w {
                sums.add(model.value(&t, l, 0.0), s.values[d * w + l], eps);
            }
        }
    }
}

/// Fits the factor model to `set`, choosing the smoothness by inner cross-validation. None when
/// the set cannot be fitted (no samples).
pub fn fit_factor(set: &SampleSet, opts: &FactorOptions) -> Option<FactorFit> {
    let eps = log_epsilon(set);
    let all = |_: usize, _: usize| true;
    let mut inner = Vec::new();
    let mu = if opts.smoothness.len() <= 1 || opts.inner_folds < 2 {
        opts.smoothness.first().copied().unwrap_or(1e-2)
    } else {
        let k = opts.inner_folds;
        // The inner folds' own shuffle (salted so they differ from validate's outer folds).
        let ranks = fold_ranks(set, INNER_FOLD_SALT);
        let held = |f: usize, i: usize, d: usize| ranks[i][d] % k == f;
        // The (μ, fold) fits are independent: fitted side by side, then scored in their order,
        // so the choice does not depend on the thread count.
        let jobs: Vec<(f64, usize)> = (opts.smoothness.iter())
            .flat_map(|&mu| (0..k).map(move |f| (mu, f)))
            .collect();
        let fits: Vec<Option<FactorModel>> = jobs
            .par_iter()
            .map(|&(mu, f)| fit_once(set, &|i, d| !held(f, i, d), opts, eps, mu))
            .collect();
        let mut best: Option<(f64, f64)> = None;
        for (c, &mu) in opts.smoothness.iter().enumerate() {
            let mut per = vec![ErrorSums::default(); set.incidences.len()];
            for f in 0..k {
                if let Some(m) = &fits[c * k + f] {
                    for (i, sums) in per.iter_mut().enumerate() {
                        score(m, set, &|j, d| j == i && held(f, j, d), eps, sums);
                    }
                }
            }
            let mut sums = ErrorSums::default();
            per.iter().for_each(|p| sums.merge(p));
            let s = sums.log().powi(2) + sums.rel().powi(2);
            inner.push((mu, per));
            // Ties go to the larger μ (the smoother model), which comes first.
            if best.is_none_or(|b| s < b.0) {
                best = Some((s, mu));
            }
        }
        best.map_or(opts.smoothness[0], |b| b.1)
    };
    let model = fit_once(set, &all, opts, eps, mu)?;
    Some(FactorFit {
        model,
        smoothness: mu,
        inner,
    })
}
