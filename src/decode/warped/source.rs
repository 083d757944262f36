//! What evaluating and sampling warped tables reads at random, behind one trait, so that one
//! text of the formulas (`super::query`) serves both forms a decoder can hold: [`ExactTables`]
//! (binary64, the values `spec/EVALUATION.md` defines) and `super::compact::CompactTables`
//! (the GPU layout's warped-tables section: tables packed to the precision the file stores,
//! the rest in f32).
//!
//! Both are built from the same open-time quantities ([`ExactTables::new`]), so they hold the
//! same numbers up to the compact form's stated rounding.

use super::vndf::{self, Column};
use crate::model::warped::WarpedModel;
use std::f64::consts::FRAC_PI_2;

/// The sizes of a warped-table material.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Dims {
    /// Stored incidences N, spectral terms K, table side R, VNDF grid side G, NDF nodes M.
    pub n: usize,
    pub k: usize,
    pub r: usize,
    pub g: usize,
    pub m: usize,
}

/// What evaluation reads of a stored incidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Incidence {
    /// θ_i (radians) and its sine and cosine.
    pub theta: f64,
    pub sin: f64,
    pub cos: f64,
    /// 1/I_i: the VNDF's normalisation.
    pub vndf_scale: f64,
    /// The values' density (importance sampling's first step): 1 over its total, and the floor
    /// added to every node (10⁻³ of the slice's mean clamped value, or 1).
    pub values_scale: f64,
    pub values_floor: f64,
}

/// A row b of a stored incidence's VNDF: its marginal (normalised) and its run of positive
/// columns ([`vndf::positive_run`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct VndfRow {
    pub marg: f64,
    pub positive: usize,
}

/// How many interior columns of a values row keep their conditional integral
/// ([`ValuesRow::marks`]): sampling then walks at most a quarter of a row.
pub(crate) const MARKS: usize = crate::decode::gpu_layout::words::codes::WARP_MARKS as usize;

/// The columns whose conditional integrals a values row keeps: ⌊j(R−1)/4⌋ for j = 1, 2, 3.
#[inline(always)]
pub(crate) fn mark_column(r: usize, j: usize) -> usize {
    j * (r - 1) / (MARKS + 1)
}

/// A row of a stored incidence's values' density: its normalised total, marginal, and the
/// conditional integrals at [`mark_column`] j = 1..=3.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ValuesRow {
    pub total: f64,
    pub marg: f64,
    pub marks: [f64; MARKS],
}

/// One table's values at random.
pub(crate) trait TableView: Copy {
    /// The value at node r·R + c.
    fn at(&self, node: usize) -> f64;
    /// The values at nodes j and j + 1 (a row's neighbours, which bilinear interpolation
    /// reads together).
    #[inline(always)]
    fn pair(&self, j: usize) -> (f64, f64) {
        (self.at(j), self.at(j + 1))
    }
}

impl TableView for &[f64] {
    #[inline(always)]
    fn at(&self, node: usize) -> f64 {
        self[node]
    }
}

/// Random access to a warped-table material's data.
pub(crate) trait WarpSource {
    /// A table's values ([`WarpSource::table`]).
    type Table<'a>: TableView
    where
        Self: 'a;
    fn dims(&self) -> Dims;
    /// θ_i in radians.
    fn theta(&self, i: usize) -> f64;
    fn incidence(&self, i: usize) -> Incidence;
    /// D at NDF node j, and σ at node j (x_j = j/(M−1) of √(θ/(π/2))).
    fn ndf(&self, j: usize) -> f64;
    fn sigma(&self, j: usize) -> f64;
    fn column(&self, a: usize) -> Column;
    /// cos φ_b of VNDF row b.
    fn cos_phi(&self, b: usize) -> f64;
    fn vndf_row(&self, i: usize, b: usize) -> VndfRow;
    /// Table t = i·K + k.
    fn table(&self, t: usize) -> Self::Table<'_>;
    fn values_row(&self, i: usize, b: usize) -> ValuesRow;
    /// The mean of basis function k over the file's wavelengths.
    fn basis_mean(&self, k: usize) -> f64;
}

/// A warped-table material in binary64: the tables decoded, the VNDF's columns, rows and
/// totals, σ, and the values' density, as `spec/EVALUATION.md` defines them.
#[derive(Debug, Clone)]
pub(crate) struct ExactTables {
    pub(super) dims: Dims,
    pub(super) incidences: Vec<Incidence>,
    pub(super) ndf: Vec<f32>,
    pub(super) sigma: Vec<f64>,
    pub(super) columns: Vec<Column>,
    pub(super) cos_phi: Vec<f64>,
    /// N·G rows, incidence-major.
    pub(super) vndf_rows: Vec<VndfRow>,
    /// N·K tables of R² values, row-major (rows along s_y).
    pub(super) tables: Vec<f64>,
    /// N·R rows, incidence-major.
    pub(super) values_rows: Vec<ValuesRow>,
    pub(super) basis_means: Vec<f64>,
}

impl ExactTables {
    /// Prepares a validated model for `thetas_deg` (HEAD's θi) and `k` terms. `None` when a
    /// stored incidence's VNDF or a σ node is zero (the reader refuses such files).
    pub(crate) fn new(
        w: &WarpedModel,
        thetas_deg: &[f32],
        k: usize,
        basis_means: &[f64],
    ) -> Option<Self> {
        let dims = Dims {
            n: thetas_deg.len(),
            k,
            r: w.grid,
            g: w.warp_grid,
            m: w.ndf.len(),
        };
        let (cols, cos_phi) = (vndf::columns(&w.ndf, dims.g), vndf::row_cosines(dims.g));
        let mut sigma = Vec::with_capacity(dims.m);
        for j in 0..dims.m {
            let x = j as f64 / (dims.m - 1) as f64;
            let s = w.sigma_scale as f64 * vndf::total(&cols, &cos_phi, x * x * FRAC_PI_2);
            if !(s > 0.0 && s.is_finite()) {
                return None;
            }
            sigma.push(s);
        }
        let mut incidences = Vec::with_capacity(dims.n);
        let mut vndf_rows = Vec::with_capacity(dims.n * dims.g);
        let mut raw = Vec::with_capacity(dims.g);
        for &t in thetas_deg {
            let theta = (t as f64).to_radians();
            raw.clear();
            raw.extend(vndf::rows(&cols, &cos_phi, theta));
            let scale = 1.0 / trapezoid(raw.iter().map(|r| r.1))?;
            let marg = marginals(raw.iter().map(|r| r.1 * scale));
            vndf_rows.extend(
                raw.iter()
                    .zip(marg)
                    .map(|(&(positive, _), marg)| VndfRow { marg, positive }),
            );
            let (sin, cos) = theta.sin_cos();
            incidences.push(Incidence {
                theta,
                sin,
                cos,
                vndf_scale: scale,
                values_scale: 0.0,
                values_floor: 0.0,
            });
        }
        let tables = w.decode_tables();
        let mut values_rows = Vec::with_capacity(dims.n * dims.r);
        let rr = dims.r * dims.r;
        for (i, inc) in incidences.iter_mut().enumerate() {
            let slice = &tables[i * k * rr..(i + 1) * k * rr];
            let (scale, floor, rows) =
                values_density(dims.r, |node| averaged(slice, rr, basis_means, node))?;
            inc.values_scale = scale;
            inc.values_floor = floor;
            values_rows.extend(rows);
        }
        Some(ExactTables {
            dims,
            incidences,
            ndf: w.ndf.clone(),
            sigma,
            columns: cols,
            cos_phi,
            vndf_rows,
            tables,
            values_rows,
            basis_means: basis_means.to_vec(),
        })
    }

    pub(crate) fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        size_of::<Incidence>() * self.incidences.capacity()
            + 4 * self.ndf.capacity()
            + 8 * (self.sigma.capacity()
                + self.cos_phi.capacity()
                + self.tables.capacity()
                + self.basis_means.capacity())
            + size_of::<Column>() * self.columns.capacity()
            + size_of::<VndfRow>() * self.vndf_rows.capacity()
            + size_of::<ValuesRow>() * self.values_rows.capacity()
    }
}

impl WarpSource for ExactTables {
    type Table<'a> = &'a [f64];
    #[inline(always)]
    fn dims(&self) -> Dims {
        self.dims
    }
    #[inline(always)]
    fn theta(&self, i: usize) -> f64 {
        self.incidences[i].theta
    }
    #[inline(always)]
    fn incidence(&self, i: usize) -> Incidence {
        self.incidences[i]
    }
    #[inline(always)]
    fn ndf(&self, j: usize) -> f64 {
        self.ndf[j] as f64
    }
    #[inline(always)]
    fn sigma(&self, j: usize) -> f64 {
        self.sigma[j]
    }
    #[inline(always)]
    fn column(&self, a: usize) -> Column {
        self.columns[a]
    }
    #[inline(always)]
    fn cos_phi(&self, b: usize) -> f64 {
        self.cos_phi[b]
    }
    #[inline(always)]
    fn vndf_row(&self, i: usize, b: usize) -> VndfRow {
        self.vndf_rows[i * self.dims.g + b]
    }
    #[inline(always)]
    fn table(&self, t: usize) -> &[f64] {
        let rr = self.dims.r * self.dims.r;
        &self.tables[t * rr..(t + 1) * rr]
    }
    #[inline(always)]
    fn values_row(&self, i: usize, b: usize) -> ValuesRow {
        self.values_rows[i * self.dims.r + b]
    }
    #[inline(always)]
    fn basis_mean(&self, k: usize) -> f64 {
        self.basis_means[k]
    }
}

/// The spectrum-averaged value at a node of one incidence's K tables (`slice`, K·R² values),
/// clamped at 0: Σ_k mean_k·T_k.
pub(super) fn averaged(slice: &[f64], rr: usize, means: &[f64], node: usize) -> f64 {
    means
        .iter()
        .enumerate()
        .map(|(k, m)| slice[k * rr + node] * m)
        .sum::<f64>()
        .max(0.0)
}

/// The trapezoid rule over n nodes 0..n−1 on [0, 1] of `values`; None unless positive and
/// finite.
pub(super) fn trapezoid(values: impl ExactSizeIterator<Item = f64>) -> Option<f64> {
    let n = values.len();
    if n < 2 {
        return None;
    }
    let (end, inner) = (0.5 / (n - 1) as f64, 1.0 / (n - 1) as f64);
    let total: f64 = values
        .enumerate()
        .map(|(i, v)| if i == 0 || i == n - 1 { end } else { inner } * v)
        .sum();
    (total > 0.0 && total.is_finite()).then_some(total)
}

/// The marginal of normalised row totals: 0, then the trapezoid's running sum.
pub(super) fn marginals(rows: impl ExactSizeIterator<Item = f64>) -> Vec<f64> {
    let half = 0.5 / (rows.len().max(2) - 1) as f64;
    let mut out = Vec::with_capacity(rows.len());
    let mut prev = None;
    let mut acc = 0.0;
    for v in rows {
        if let Some(p) = prev {
            acc += half * (p + v);
        }
        out.push(acc);
        prev = Some(v);
    }
    out
}

/// The values' density of one incidence on R × R nodes from `value(node)` (the averaged,
/// clamped values): its floor (10⁻³ of the mean value, or 1 when the mean is not positive),
/// 1 over its total, and its normalised rows. None when the total is not positive and finite.
pub(super) fn values_density(
    r: usize,
    value: impl Fn(usize) -> f64,
) -> Option<(f64, f64, Vec<ValuesRow>)> {
    let mean = (0..r * r).map(&value).sum::<f64>() / (r * r) as f64;
    let floor = if mean > 0.0 { 1e-3 * mean } else { 1.0 };
    let raw: Vec<f64> = (0..r)
        .map(|b| trapezoid_sum(r, |a| value(b * r + a) + floor))
        .collect();
    let scale = 1.0 / trapezoid(raw.iter().copied())?;
    let marg = marginals(raw.iter().map(|v| v * scale));
    let half = 0.5 / (r - 1) as f64;
    let rows = raw
        .iter()
        .zip(marg)
        .enumerate()
        .map(|(b, (v, marg))| {
            // The conditional integral walked as sampling walks it, kept at the marks.
            let p = |a: usize| scale * (value(b * r + a) + floor);
            let mut marks = [0.0; MARKS];
            let (mut acc, mut j) = (0.0, 0);
            for a in 0..r - 1 {
                if j < MARKS && a == mark_column(r, j + 1) {
                    marks[j] = acc;
                    j += 1;
                }
                acc += half * (p(a) + p(a + 1));
            }
            ValuesRow {
                total: v * scale,
                marg,
                marks,
            }
        })
        .collect();
    Some((scale, floor, rows))
}

/// Σ_a w_a·value(a) over n nodes with the trapezoid's weights (1/(2(n−1)) at the ends).
fn trapezoid_sum(n: usize, value: impl Fn(usize) -> f64) -> f64 {
    let (end, inner) = (0.5 / (n - 1) as f64, 1.0 / (n - 1) as f64);
    (0..n)
        .map(|a| if a == 0 || a == n - 1 { end } else { inner } * value(a))
        .sum()
}
