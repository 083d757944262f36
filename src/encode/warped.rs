//! The warped-table encoder (`spec/FORMAT.md` §3.10, `spec/EVALUATION.md`, "Warped tables"):
//! a measurement given on its own VNDF-warped grid (RGL files) is kept there, spectra on a
//! per-material principal basis, each term's table transform-coded with one quantisation step
//! chosen so that the worst stored incidence stays within the error budget.
//!
//! Why: per-incidence SH backgrounds with analytic lobes, and the factor model, stop at 5–40% on
//! dense measurements whose peaks are one sample wide on any regular angular grid; on the warped
//! grid the same peaks span many nodes, the tables are smooth, and the error falls steadily as
//! bytes grow, so any budget can be met (`docs/guide/warped-tables.md`).
//!
//! The error is measured where the file stores the measurement, over an incidence's R × R
//! nodes and every wavelength (an RGB source: every colour channel), in table units (the
//! measurement's value before the NDF/(4σ cos θo) factor): the larger of the relative L2 and
//! the relative L1 error (`encode::table_error` says why both). The worst stored incidence is
//! held to the budget.

use crate::encode::basis::sign_fixed;
use crate::encode::table_error::{Metric, Target};
use crate::error::{Error, Result};
use crate::model::basis_storage::{BasisStorage, QUANTISED_EXPONENTS};
use crate::model::material::{IncidentRecord, Material};
use crate::model::spectral::{BasisTable, SpectralBasis, SpectralSpace};
use crate::model::warped::{coefficient, dct2, idct2, PayloadCoding, TableTransform};
use crate::model::warped::{WarpedModel, MAX_LEVEL};
use crate::model::Precision;
use half::f16;
use nalgebra::{DMatrix, SymmetricEigen};

/// A measurement on its warped grid, as an input reader hands it over.
#[derive(Debug, Clone)]
pub struct WarpedInput {
    /// Stored incidences θi in degrees, strictly increasing, within [0, 90].
    pub thetas_deg: Vec<f32>,
    /// Wavelengths of the spectra, nm, strictly increasing.
    pub wavelengths: Vec<f32>,
    /// Table side R.
    pub grid: usize,
    /// VNDF grid side G the warp is rebuilt on.
    pub warp_grid: usize,
    /// The NDF at M nodes x_j = j/(M−1) of u_x.
    pub ndf: Vec<f32>,
    /// The measurement's own σ at the same M nodes (to find the σ normalisation), if it has
    /// one; else the normalisation is 1.
    pub sigma: Option<Vec<f32>>,
    /// Spectra at every node: incidence-major, then row (s_y), column (s_x), then wavelength.
    pub spectra: Vec<f64>,
    /// Where the spectra stand in for D < W numbers that are the measurement (an RGB file made
    /// spectral), the linear map from a spectrum to them (D rows of W); errors are then
    /// measured there, and exactly D terms are stored, solved so that the map of each
    /// rebuilt spectrum is the measurement's (the quantised tables aside).
    pub metric: Option<Metric>,
    /// With a metric, the measured values themselves (D per node, node-major), when the
    /// spectra only approximate them (an RGB colour a spectral upsampling cannot reach): the
    /// tables then reproduce these, not the spectra's map.
    pub measured: Option<Vec<f64>>,
}

/// What the warped encoder is asked for.
#[derive(Debug, Clone)]
pub struct WarpedOptions {
    /// The budget: the error of the worst stored incidence, the larger of its relative L2 and
    /// relative L1 errors (0.01 = 1%; the module's doc).
    pub max_error: f64,
    /// Spectral terms; `None`: the smallest count whose projection leaves ≤ ¼ of the budget.
    pub terms: Option<usize>,
    /// The tables' transform; `None`: whichever gives the smaller file (`Some(Dct)` writes a
    /// file that 1.4 decoders read).
    pub transform: Option<TableTransform>,
    /// How the integers are coded: the range coder (format 1.6, the default), or DEFLATE for
    /// files that 1.4 and 1.5 decoders read.
    pub coding: PayloadCoding,
    /// Let an incidence's tables be coded as the difference to the previous incidence's where
    /// that takes fewer bytes (format 1.7, range-coded payloads only; `false` writes a file
    /// that 1.6 decoders read).
    pub predict: bool,
    /// Raise each incidence's budget to the measurement's estimated noise there
    /// ([`crate::encode::noise`]) where that is higher: what a default budget does, so that
    /// no bytes go to coding noise. An explicit budget leaves it off and means what it says.
    pub noise_floor: bool,
}

/// Default budget of the warped encoder.
pub const DEFAULT_MAX_ERROR: f64 = 0.01;
/// Most spectral terms chosen automatically.
pub const MAX_AUTO_TERMS: usize = 12;

/// The result: the material (records empty, `WARP` filled) and what was measured.
#[derive(Debug, Clone)]
pub struct WarpedEncoded {
    /// The encoded material: empty records, the tables in [`Material::warped`].
    pub material: Material,
    /// The error of each stored incidence (table units): the larger of relative L2 and L1.
    pub errors: Vec<f64>,
    /// The error of the spectral projection alone, worst incidence.
    pub projection_error: f64,
    /// The quantisation step used (one for every table).
    pub step: f64,
    /// Whether the budget was met.
    pub met: bool,
    /// The measurement's estimated noise at each stored incidence, relative like `errors`
    /// ([`crate::encode::noise::noise_floor`]; 0 where the grid is too small to tell).
    pub noise: Vec<f64>,
    /// The budget each stored incidence was coded to: `max_error`, or its noise where
    /// [`WarpedOptions::noise_floor`] raised it.
    pub budgets: Vec<f64>,
}

/// Encodes a warped measurement. Fails only on inputs that break the layout's rules; a budget
/// that cannot be met is reported in `met` (the most accurate tables are then returned).
pub fn encode_warped(input: &WarpedInput, opts: &WarpedOptions) -> Result<WarpedEncoded> {
    let (n, r, w) = (input.thetas_deg.len(), input.grid, input.wavelengths.len());
    let nodes = n * r * r;
    if n == 0 || w == 0 || input.spectra.len() != nodes * w {
        return Err(Error::Input(format!(
            "warped tables: {} values for {n} incidences of {r}² nodes and {w} wavelengths",
            input.spectra.len()
        )));
    }
    if !(opts.max_error.is_finite() && opts.max_error > 0.0) {
        return Err(Error::Parameter(format!(
            "an error budget of {} (give a positive fraction)",
            opts.max_error
        )));
    }
    let x = &input.spectra;
    // What errors are measured on: the spectra, or their map by the metric.
    let (y, dy) = match &input.metric {
        None => (x.clone(), w),
        Some(m)
            if input
                .measured
                .as_ref()
                .is_some_and(|v| v.len() == nodes * m.rows) =>
        {
            (input.measured.clone().unwrap_or_default(), m.rows)
        }
        Some(m) => {
            let mut y = vec![0.0; nodes * m.rows];
            for (s, o) in x.chunks_exact(w).zip(y.chunks_exact_mut(m.rows)) {
                m.apply(s, o);
            }
            (y, m.rows)
        }
    };
    let target = Target::new(&y, dy, input.metric.as_ref(), w, r);
    let noise = crate::encode::noise::noise_floor(&y, n, r, dy, &target.norms);
    let budgets: Vec<f64> = noise
        .iter()
        .map(|&e| {
            if opts.noise_floor {
                opts.max_error.max(e)
            } else {
                opts.max_error
            }
        })
        .collect();
    let least_budget = budgets.iter().cloned().fold(f64::INFINITY, f64::min);
    let grid = match opts.coding {
        PayloadCoding::Deflate => BasisGrid::F16,
        // An RGB file's spectra are a stand-in whose colours come back exactly whatever the
        // basis (the coefficients are solved in the metric): 8 bits of each function's largest
        // value do. A spectral measurement keeps f16's 11.
        PayloadCoding::Range => BasisGrid::Quantised {
            bits: if input.metric.is_some() { 8 } else { 11 },
        },
    };
    let basis_all = principal_basis(x, w, grid);
    let max_k = w.min(opts.terms.unwrap_or(MAX_AUTO_TERMS)).max(1);
    // With a metric of D rows, D terms solved in the metric: its values come back exactly.
    let forced = input.metric.as_ref().map(|m| m.rows.min(w));
    let mut k = forced.unwrap_or_else(|| opts.terms.map_or(1, |t| t.clamp(1, w)));
    let (mut basis, mut coef, mut projection_error);
    loop {
        basis = basis_all[..k * w].to_vec();
        coef = match &input.metric {
            Some(m) if k == m.rows => {
                (basis, coef) = reachable_span(&target, m, &basis, &input.wavelengths, opts, grid)?;
                coef
            }
            _ => project(x, &basis, k, w),
        };
        let errs = target.errors(&coef, &basis, k);
        projection_error = errs.iter().cloned().fold(0.0, f64::max);
        if forced.is_some()
            || opts.terms.is_some()
            || projection_error <= 0.25 * least_budget
            || k >= max_k
        {
            break;
        }
        k += 1;
    }
    // Each transform codes the same tables; the file keeps the one that comes out smaller.
    // What the file holds beside the tables, whichever transform codes them (σ's scale costs a
    // VNDF total per NDF node: computed once).
    let (ndf_precision, ndf) = ndf_stored(&input.ndf);
    let shell = WarpedModel {
        transform: TableTransform::Dct,
        coding: opts.coding,
        grid: r,
        warp_grid: input.warp_grid,
        sigma_scale: sigma_scale(input),
        ndf_precision,
        ndf,
        steps: Vec::new(),
        levels: Vec::new(),
        predicted: Vec::new(),
    };
    let predict = opts.predict && opts.coding == PayloadCoding::Range;
    let code = |transform| {
        let tables = Tables {
            transform,
            synthesis: transform.synthesis(r),
            target: &target,
            coef: &coef,
            basis: &basis,
            k,
            n,
        };
        tables.code(&budgets, predict.then_some(&shell))
    };
    let chosen = match opts.transform {
        Some(t) => code(t),
        None => {
            let (dct, wavelet) = (code(TableTransform::Dct), code(TableTransform::Wavelet53));
            let key = |c: &Coded| (!c.met, crate::format::warp_payload_len(&c.model(&shell), k));
            // Budget met first, then bytes; the DCT (readable by 1.4 decoders) kept on a tie.
            if key(&wavelet) < key(&dct) {
                wavelet
            } else {
                dct
            }
        }
    };
    let step = chosen.steps.iter().cloned().fold(0f32, f32::max);
    let (met, errors) = (chosen.met, chosen.errors);
    let model = WarpedModel {
        transform: chosen.transform,
        steps: chosen.steps,
        levels: chosen.levels,
        predicted: chosen.predicted,
        ..shell
    };
    let table_values: Vec<f64> = basis.clone();
    let wl: Vec<f64> = input.wavelengths.iter().map(|&v| v as f64).collect();
    let spectral = SpectralSpace {
        basis: SpectralBasis::Tabulated,
        terms: k,
        lambda_min: wl[0],
        lambda_max: wl[w - 1],
        table: Some(BasisTable {
            nodes: wl,
            storage: grid.storage(&table_values, w),
            values: table_values,
        }),
    };
    let material = Material {
        version_minor: crate::format::VERSION_MINOR_WARP,
        spectral,
        sh_level: 0,
        isotropic: true,
        wavelengths: input.wavelengths.clone(),
        records: input
            .thetas_deg
            .iter()
            .map(|&t| IncidentRecord::empty(t, 0.0))
            .collect(),
        metadata: None,
        sample_positions: None,
        factor: None,
        held_out: None,
        warped: Some(Box::new(model)),
    };
    // The version it is written as, so that the material reads back equal.
    let mut material = material;
    material.version_minor = crate::format::written_version(&material).0;
    material
        .validate()
        .map_err(|e| Error::Input(format!("warped tables: {e}")))?;
    Ok(WarpedEncoded {
        material,
        errors,
        projection_error,
        step: step as f64,
        met,
        noise,
        budgets,
    })
}

/// The tables of one transform, quantised.
struct Coded {
    transform: TableTransform,
    steps: Vec<f32>,
    levels: Vec<i32>,
    /// Per incidence, whether it is coded as the difference to the one before (empty: the
    /// file carries no flags).
    predicted: Vec<bool>,
    errors: Vec<f64>,
    met: bool,
}

impl Coded {
    /// The model of these tables, the rest (grid, NDF, σ scale) from `shell`.
    fn model(&self, shell: &WarpedModel) -> WarpedModel {
        WarpedModel {
            transform: self.transform,
            steps: self.steps.clone(),
            levels: self.levels.clone(),
            predicted: self.predicted.clone(),
            ..shell.clone()
        }
    }
}

/// The tables to code: the fitted coefficients `coef` (K per node, node-major) of N stored
/// incidences, with what measures their error.
struct Tables<'a> {
    transform: TableTransform,
    /// The transform's synthesis basis at side R, computed once.
    synthesis: Vec<f64>,
    target: &'a Target<'a>,
    coef: &'a [f64],
    basis: &'a [f64],
    k: usize,
    n: usize,
}

/// One incidence's K tables quantised at one step.
struct Quantised {
    step: f32,
    levels: Vec<i32>,
    /// The coefficients a decoder rebuilds (the prediction included).
    rebuilt: Vec<f64>,
    error: f64,
}

impl Tables<'_> {
    /// Transforms and quantises the tables (i, k) in `self.transform`: per stored incidence,
    /// the largest step (bisection in log q) whose error meets its budget (`budgets[i]`), so
    /// that every incidence ends near its budget and none spends bytes below it. With `predict`
    /// (the model's other fields, to count bytes with), each incidence after the first is also
    /// coded as the difference to the previous incidence's rebuilt coefficients, and keeps
    /// whichever of the two codes in fewer payload bytes.
    fn code(&self, budgets: &[f64], predict: Option<&WarpedModel>) -> Coded {
        let (k, n) = (self.k, self.n);
        let rr = self.target.r * self.target.r;
        let freq = self.frequencies();
        let mut coded = Coded {
            transform: self.transform,
            steps: Vec::with_capacity(n * k),
            levels: Vec::with_capacity(n * k * rr),
            predicted: Vec::new(),
            errors: Vec::with_capacity(n),
            met: true,
        };
        let mut rebuilt: Vec<f64> = Vec::new();
        for i in 0..n {
            let f = &freq[i * k * rr..(i + 1) * k * rr];
            // The previous incidence's levels are final: the coder's context reads them.
            let previous = (i > 0).then(|| &coded.levels[(i - 1) * k * rr..]);
            let (direct, met) = self.quantise_incidence(i, f, None, previous, budgets[i]);
            let mut best = (direct, false, met);
            if let (Some(shell), true) = (predict, i > 0) {
                let (diff, diff_met) =
                    self.quantise_incidence(i, f, Some(&rebuilt), previous, budgets[i]);
                // Bytes of the payload up to this incidence with each candidate.
                let bytes = |q: &Quantised, flag: bool| {
                    let mut model = coded.model(shell);
                    model.steps.extend(std::iter::repeat_n(q.step, k));
                    model.levels.extend_from_slice(&q.levels);
                    model.predicted.resize(i, false);
                    model.predicted.push(flag);
                    crate::format::warp_payload_len(&model, k)
                };
                // The budget met first, then bytes; standing alone kept on a tie.
                if (!diff_met, bytes(&diff, true)) < (!met, bytes(&best.0, false)) {
                    best = (diff, true, diff_met);
                }
            }
            let (q, flag, met) = best;
            coded.steps.extend(std::iter::repeat_n(q.step, k));
            coded.levels.extend_from_slice(&q.levels);
            if predict.is_some() {
                coded.predicted.push(flag);
            }
            coded.errors.push(q.error);
            coded.met &= met;
            rebuilt = q.rebuilt;
        }
        coded
    }

    /// The forward transform of every table, (i·K + k)·R² + a·R + b.
    fn frequencies(&self) -> Vec<f64> {
        let (r, k) = (self.target.r, self.k);
        let rr = r * r;
        let analysis = self.transform.analysis(r);
        let mut freq = vec![0.0; self.n * k * rr];
        let mut table = vec![0.0; rr];
        for i in 0..self.n {
            for t in 0..k {
                for (p, v) in table.iter_mut().enumerate() {
                    *v = self.coef[(i * rr + p) * k + t];
                }
                dct2(
                    &analysis,
                    r,
                    &table,
                    &mut freq[(i * k + t) * rr..(i * k + t + 1) * rr],
                );
            }
        }
        freq
    }

    /// Incidence i's K tables (`f`, their coefficients) at the largest step meeting `budget`,
    /// coded alone or, with `prediction`, as the difference to those coefficients; and whether
    /// the budget was met (if not, the finest step).
    fn quantise_incidence(
        &self,
        i: usize,
        f: &[f64],
        prediction: Option<&[f64]>,
        previous: Option<&[i32]>,
        budget: f64,
    ) -> (Quantised, bool) {
        let (r, k) = (self.target.r, self.k);
        let rr = r * r;
        let residual: Vec<f64> = match prediction {
            Some(p) => f.iter().zip(p).map(|(a, b)| a - b).collect(),
            None => f.to_vec(),
        };
        let largest = residual.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let q_min = (largest / (MAX_LEVEL as f64 - 1.0)).max(f64::MIN_POSITIVE);
        let at = |q: f64| -> Quantised {
            let step = q as f32;
            let levels = quantise(&residual, q, previous, r, k);
            let rebuilt: Vec<f64> = levels
                .iter()
                .enumerate()
                .map(|(j, &z)| coefficient(step, z, prediction.map(|p| p[j])))
                .collect();
            let mut c = vec![0.0; rr * k];
            let mut table = vec![0.0; rr];
            for t in 0..k {
                idct2(
                    &self.synthesis,
                    r,
                    &rebuilt[t * rr..(t + 1) * rr],
                    &mut table,
                );
                for p in 0..rr {
                    c[p * k + t] = table[p];
                }
            }
            let error = self.target.error_of(i, &c, self.basis, k);
            Quantised {
                step,
                levels,
                rebuilt,
                error,
            }
        };
        let (mut lo, mut hi) = (q_min.ln(), (largest.max(1e-30) * 4.0).ln());
        let mut best = at(lo.exp());
        if best.error > budget {
            return (best, false);
        }
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            let candidate = at(mid.exp());
            if candidate.error <= budget {
                lo = mid;
                best = candidate;
            } else {
                hi = mid;
            }
            if hi - lo < 0.003 {
                break;
            }
        }
        (best, true)
    }
}

/// How the basis rows are rounded: to what `SBAS` will store, since the tables are fitted to
/// the basis as stored.
#[derive(Debug, Clone, Copy)]
enum BasisGrid {
    /// Each value to `f16` (`SBAS` precision 2; files before 1.6).
    F16,
    /// Each row to multiples of a power of two, `bits` below its largest magnitude (`SBAS`
    /// precision 3, format 1.6).
    Quantised { bits: i32 },
}

impl BasisGrid {
    /// The exponent of a row on the quantised grid (0 for a row of zeros).
    fn exponent(row: &[f64], bits: i32) -> i32 {
        let largest = row.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if largest > 0.0 {
            (largest.log2().ceil() as i32 - bits)
                .clamp(*QUANTISED_EXPONENTS.start(), *QUANTISED_EXPONENTS.end())
        } else {
            0
        }
    }

    /// Rounds each row of `values` (rows of `w`) to the grid.
    fn round(self, values: &mut [f64], w: usize) {
        for row in values.chunks_mut(w.max(1)) {
            match self {
                BasisGrid::F16 => row.iter_mut().for_each(|v| *v = f16::from_f64(*v).to_f64()),
                BasisGrid::Quantised { bits } => {
                    let step = 2f64.powi(Self::exponent(row, bits));
                    row.iter_mut().for_each(|v| *v = (*v / step).round() * step);
                }
            }
        }
    }

    /// How a file stores rows rounded to this grid. The exponents are taken from the rounded
    /// rows: rounding can lower a row's largest value to the power of two below, whose
    /// exponent is one less and still divides every value.
    fn storage(self, values: &[f64], w: usize) -> BasisStorage {
        match self {
            BasisGrid::F16 => BasisStorage::Float(Precision::F16),
            BasisGrid::Quantised { bits } => BasisStorage::Quantised {
                exponents: values
                    .chunks(w.max(1))
                    .map(|row| Self::exponent(row, bits) as i8)
                    .collect(),
            },
        }
    }
}

/// Orthonormal principal directions of the node spectra (W values each), largest first, each
/// rounded to `grid` (what `SBAS` stores: the basis is fitted as stored) with its largest
/// component positive.
fn principal_basis(x: &[f64], w: usize, grid: BasisGrid) -> Vec<f64> {
    let mut cov = DMatrix::<f64>::zeros(w, w);
    for s in x.chunks_exact(w) {
        for a in 0..w {
            for b in a..w {
                cov[(a, b)] += s[a] * s[b];
            }
        }
    }
    for a in 0..w {
        for b in 0..a {
            cov[(a, b)] = cov[(b, a)];
        }
    }
    let mut out: Vec<f64> = principal_axes(cov).concat();
    grid.round(&mut out, w);
    out
}

/// The eigenvectors of a symmetric matrix, largest eigenvalue first, each with the
/// deterministic sign of the data-derived basis ([`sign_fixed`]).
fn principal_axes(cov: DMatrix<f64>) -> Vec<Vec<f64>> {
    let n = cov.nrows();
    let eig = SymmetricEigen::new(cov);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    order
        .iter()
        .map(|&j| sign_fixed(eig.eigenvectors.column(j).iter().cloned().collect()))
        .collect()
}

/// Least-squares coefficients (K per node, node-major) of every spectrum on the K basis rows.
fn project(x: &[f64], basis: &[f64], k: usize, w: usize) -> Vec<f64> {
    let b = DMatrix::from_row_slice(k, w, basis);
    let gram = &b * b.transpose();
    let inv = gram
        .clone()
        .try_inverse()
        .unwrap_or_else(|| DMatrix::identity(k, k));
    let mut out = Vec::with_capacity(x.len() / w * k);
    for s in x.chunks_exact(w) {
        let mut bx = vec![0.0; k];
        for (t, v) in bx.iter_mut().enumerate() {
            *v = (0..w).map(|l| basis[t * w + l] * s[l]).sum();
        }
        for t in 0..k {
            out.push((0..k).map(|u| inv[(t, u)] * bx[u]).sum());
        }
    }
    out
}

/// The span of `basis` (K = D rows) turned so that its coefficients are orthonormal
/// coordinates of the metric's values, along their principal directions: one quantisation step
/// then costs the same error in every term (an RGB file's colours decorrelated, as image codecs
/// turn RGB into luma and chroma). Rows rounded to `grid`, as `SBAS` stores them.
fn metric_orthonormal(
    y: &[f64],
    m: &Metric,
    basis: &[f64],
    k: usize,
    w: usize,
    grid: BasisGrid,
) -> Result<Vec<f64>> {
    let d = m.rows;
    let p = DMatrix::from_row_slice(d, w, &m.matrix);
    let b = DMatrix::from_row_slice(k, w, basis);
    let a = &p * b.transpose();
    let a_inv = a.try_inverse().ok_or_else(|| {
        Error::Input("warped tables: the spectral basis is degenerate under the metric".into())
    })?;
    let mut cov = DMatrix::<f64>::zeros(d, d);
    for v in y.chunks_exact(d) {
        for i in 0..d {
            for j in 0..d {
                cov[(i, j)] += v[i] * v[j];
            }
        }
    }
    let mut v = DMatrix::<f64>::zeros(d, d);
    for (col, axis) in principal_axes(cov).iter().enumerate() {
        for (i, &x) in axis.iter().enumerate() {
            v[(i, col)] = x;
        }
    }
    // B' = Vᵀ·A⁻ᵀ·B: then P·B'ᵀ = P·Bᵀ·A⁻¹·V = V, orthogonal.
    let turned = v.transpose() * a_inv.transpose() * b;
    let mut out = Vec::with_capacity(k * w);
    for t in 0..k {
        for l in 0..w {
            out.push(turned[(t, l)]);
        }
    }
    grid.round(&mut out, w);
    Ok(out)
}

/// Smooth spectral primaries (centre nm, width σ nm) whose spans the encoder tries after the
/// data's own: each holds a wider gamut than sRGB with non-negative spectra.
const WIDE_GAMUT_PRIMARIES: [([f64; 3], f64); 5] = [
    ([440.0, 520.0, 610.0], 40.0),
    ([440.0, 520.0, 610.0], 30.0),
    ([460.0, 530.0, 620.0], 30.0),
    ([440.0, 520.0, 610.0], 20.0),
    ([460.0, 530.0, 620.0], 20.0),
];

/// The span of D spectra (and the nodes' coefficients on it, [`metric_orthonormal`] and
/// [`project_in_metric`]) for a metric of D rows. The coefficients are the measured values
/// turned, whatever the span; the span decides only which spectra the values become, and so
/// whether a spectrum the decoder clamps at 0 still gives its value back. An RGB file's most
/// saturated colours lie outside sRGB (a negative channel, on 3–54% of the nodes of a purple
/// film), and the principal spectra of their Jakob–Hanika upsampling reach them only through
/// negative lobes. So the data's own span is kept when clamping costs it at most a twentieth of
/// the budget on every incidence, and otherwise the first span of smooth wide-gamut primaries
/// that does, or the one that costs least.
fn reachable_span(
    target: &Target,
    m: &Metric,
    principal: &[f64],
    wavelengths: &[f32],
    opts: &WarpedOptions,
    grid: BasisGrid,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let (k, w) = (m.rows, wavelengths.len());
    let gaussians = |(centres, width): &([f64; 3], f64)| -> Vec<f64> {
        centres
            .iter()
            .take(k)
            .flat_map(|c| {
                wavelengths
                    .iter()
                    .map(move |&l| (-0.5 * ((l as f64 - c) / width).powi(2)).exp())
            })
            .collect()
    };
    let worst_of = |span: &[f64]| -> Result<(f64, Vec<f64>, Vec<f64>)> {
        let basis = metric_orthonormal(target.y, m, span, k, w, grid)?;
        let coef = project_in_metric(target.y, m, &basis, k, w)?;
        let worst = target
            .errors(&coef, &basis, k)
            .into_iter()
            .fold(0.0, f64::max);
        Ok((worst, basis, coef))
    };
    let enough = opts.max_error / 20.0;
    let mut best = worst_of(principal)?;
    if best.0 > enough && k == 3 {
        for primaries in &WIDE_GAMUT_PRIMARIES {
            // A span the metric cannot invert is skipped: the data's own is kept then.
            let Ok(tried) = worst_of(&gaussians(primaries)) else {
                continue;
            };
            if tried.0 < best.0 {
                best = tried;
            }
            if best.0 <= enough {
                break;
            }
        }
    }
    Ok((best.1, best.2))
}

/// Coefficients (K = D per node) whose rebuilt spectra map exactly onto `y` under the metric:
/// c = (P·Bᵀ)⁻¹·y.
fn project_in_metric(y: &[f64], m: &Metric, basis: &[f64], k: usize, w: usize) -> Result<Vec<f64>> {
    let p = DMatrix::from_row_slice(m.rows, w, &m.matrix);
    let b = DMatrix::from_row_slice(k, w, basis);
    let pb = &p * b.transpose();
    let inv = pb.try_inverse().ok_or_else(|| {
        Error::Input("warped tables: the spectral basis is degenerate under the metric".into())
    })?;
    let mut out = Vec::with_capacity(y.len());
    for v in y.chunks_exact(m.rows) {
        for t in 0..k {
            out.push((0..m.rows).map(|u| inv[(t, u)] * v[u]).sum());
        }
    }
    Ok(out)
}

/// How far below one half a coefficient's fraction of a step must reach before it rounds up
/// (a dead zone), where a neighbour the range coder looks at (`spec/FORMAT.md` §3.10: the two
/// before it in its table, the same coefficient in the previous term's and the previous
/// incidence's table) is non-zero, and where all of them are zero. A non-zero value among
/// zeros costs the coder most (its zero flag in the all-zero context, then its magnitude), so
/// it must earn more of a step there. The bisection of q still holds every incidence to its
/// budget; measured on the shipped RGL files against the single 0.15 of DEFLATE's time, 1–7%
/// fewer bytes at every budget from 0.5% to 5%.
const DEAD_ZONE: f64 = 0.05;
/// The dead zone among zero neighbours (see [`DEAD_ZONE`]).
const DEAD_ZONE_ALONE: f64 = 0.25;

/// Quantises the K tables of one incidence (`freq`, row-major per table) to multiples of q,
/// rounding toward 0 unless a coefficient's fraction of a step reaches ½ + the dead zone of
/// its neighbourhood; `previous` is the previous incidence's levels, final already.
fn quantise(freq: &[f64], q: f64, previous: Option<&[i32]>, r: usize, k: usize) -> Vec<i32> {
    let lim = (MAX_LEVEL - 1) as f64;
    let rr = r * r;
    let mut out = vec![0i32; freq.len()];
    for t in 0..k {
        for p in 0..rr {
            let (a, b) = (p / r, p % r);
            let alone = (a == 0 || out[t * rr + p - r] == 0)
                && (b == 0 || out[t * rr + p - 1] == 0)
                && (t == 0 || out[(t - 1) * rr + p] == 0)
                && previous.is_none_or(|v| v[t * rr + p] == 0);
            let zone = if alone { DEAD_ZONE_ALONE } else { DEAD_ZONE };
            let v = freq[t * rr + p];
            let m = ((v / q).abs() + 0.5 - zone).floor().clamp(0.0, lim);
            out[t * rr + p] = m.copysign(v) as i32;
        }
    }
    out
}

/// The NDF as stored: `f16` when every value keeps its first three digits there (or is below a
/// millionth of the largest, where it weighs nothing), else `f32` as given.
fn ndf_stored(ndf: &[f32]) -> (Precision, Vec<f32>) {
    let largest = ndf.iter().cloned().fold(0f32, f32::max);
    let rounded: Vec<f32> = ndf.iter().map(|&v| f16::from_f32(v).to_f32()).collect();
    let fits = ndf.iter().zip(&rounded).all(|(&v, &h)| {
        h.is_finite() && ((h - v).abs() <= 1e-3 * v.abs() || v.abs() <= 1e-6 * largest)
    });
    if fits {
        (Precision::F16, rounded)
    } else {
        (Precision::F32, ndf.to_vec())
    }
}

/// The σ normalisation c: the median of σ(θ_j)/I(θ_j) over the measurement's own σ nodes, where
/// I is the VNDF total the decoder computes (1 without a σ).
fn sigma_scale(input: &WarpedInput) -> f32 {
    let Some(sigma) = &input.sigma else {
        return 1.0;
    };
    let m = sigma.len();
    let thetas: Vec<f64> = (0..m)
        .map(|j| {
            let x = j as f64 / (m - 1).max(1) as f64;
            x * x * std::f64::consts::FRAC_PI_2
        })
        .collect();
    let totals = crate::decode::vndf_totals(&input.ndf, input.warp_grid, &thetas);
    let mut ratios: Vec<f64> = sigma
        .iter()
        .zip(&totals)
        .filter_map(|(&s, &total)| {
            let s = s as f64;
            (total > 0.0 && s > 0.0 && s.is_finite()).then(|| s / total)
        })
        .collect();
    if ratios.is_empty() {
        return 1.0;
    }
    ratios.sort_by(f64::total_cmp);
    ratios[ratios.len() / 2] as f32
}
