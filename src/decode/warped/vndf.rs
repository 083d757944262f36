//! The VNDF of warped tables without its G × G grids (`spec/EVALUATION.md`, "Warped tables",
//! "The VNDF of stored incidence i"; `spec/GPU_LAYOUT.md`, "Warped tables section").
//!
//! The density at node (a, b) for incidence θ is p[b][a] = f_a·max(0, α_b·sin θm_a + cos θ·cos
//! θm_a), with f_a = D(x_a)·sin θm_a·π x_a·2π and α_b = sin θ·cos φ_b (ωi has no y component).
//! Along a row b the bracket falls monotonically in θm when α_b < 0 and never changes sign
//! otherwise, so the positive nodes of a row are a leading run of `positive` nodes, and the
//! row's conditional integral (the trapezoid sums of `cond[b][a]`) is separable there:
//!
//! ```text
//! cond[b][a] = α_b·U[a] + cos θ·V[a]                                   (a < positive)
//!            = α_b·U[q] + cos θ·V[q] + p[b][q]/(2(G−1)),   q = positive − 1   (a ≥ positive)
//! ```
//!
//! with U and V the trapezoid prefix sums of f·sin θm and f·cos θm over the columns. Per
//! incidence a decoder so keeps G positive-run lengths and G marginal values instead of G² of
//! each table (8 incidences at G = 128: 6 KiB instead of 1 MiB), and the totals that σ needs
//! cost O(G log G) each instead of O(G²). The values are the spec's up to the rounding of a
//! different summation order (about 10⁻¹⁵ relative).

use crate::model::warped::{half_vector, jacobian, ndf_at};
use std::f64::consts::PI;

/// What a column a of the VNDF grid contributes, for any incidence and row.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Column {
    /// f_a = D(x_a)·sin θm·π x_a·2π.
    pub f: f64,
    /// sin θm and cos θm of the column's half vectors (θm = x_a²·π/2).
    pub sin: f64,
    pub cos: f64,
    /// U[a] and V[a]: Σ_{a' < a} (f·sin θm at a' and a' + 1)/(2(G−1)), likewise with cos θm.
    pub u: f64,
    pub v: f64,
}

/// The columns of a G × G VNDF grid for an NDF (G ≥ 2).
pub(crate) fn columns(ndf: &[f32], g: usize) -> Vec<Column> {
    let step = 1.0 / (g - 1) as f64;
    let half = 0.5 / (g - 1) as f64;
    let mut out: Vec<Column> = Vec::with_capacity(g);
    for a in 0..g {
        let x = a as f64 * step;
        let (h, st) = half_vector(x, 0.0);
        let mut c = Column {
            f: ndf_at(ndf, x) * jacobian(x, st),
            sin: st,
            cos: h[2],
            u: 0.0,
            v: 0.0,
        };
        if let Some(prev) = out.last() {
            c.u = prev.u + half * (prev.f * prev.sin + c.f * c.sin);
            c.v = prev.v + half * (prev.f * prev.cos + c.f * c.cos);
        }
        out.push(c);
    }
    out
}

/// cos φ_b of the grid's rows, φ_b = 2π·y_b − π with y_b = b/(G−1).
pub(crate) fn row_cosines(g: usize) -> Vec<f64> {
    let step = 1.0 / (g - 1) as f64;
    // As `half_vector` forms φm.
    (0..g)
        .map(|b| (2.0 * PI * (b as f64 * step) - PI).cos())
        .collect()
}

/// The bracket ωi·m of a row at a column: α·sin θm + cos θ·cos θm.
#[inline(always)]
pub(crate) fn bracket(alpha: f64, cos_theta: f64, c: &Column) -> f64 {
    alpha * c.sin + cos_theta * c.cos
}

/// The number of leading columns whose bracket is positive in a row with α = sin θ·cos φ_b, for
/// `cos_theta` = cos θ (> 0 for every θ ≤ π/2 in binary64). With α ≥ 0 every column is
/// positive; otherwise the bracket falls with θm and the first column with a bracket ≤ 0 is
/// found by bisection.
pub(crate) fn positive_run(cols: &[Column], alpha: f64, cos_theta: f64) -> usize {
    let g = cols.len();
    if cos_theta.is_nan() || cos_theta <= 0.0 {
        // Not for θ ≤ π/2 (whose binary64 cosine is at least 6.1·10⁻¹⁷): no column is counted,
        // and an incidence whose rows are all empty has total 0, which the caller refuses.
        return 0;
    }
    if alpha >= 0.0 {
        return g;
    }
    // Column 0 (θm = 0) has bracket cos θ > 0; find the first column at or below 0.
    let (mut lo, mut hi) = (0usize, g);
    while lo + 1 < hi {
        let mid = (lo + hi) / 2;
        if bracket(alpha, cos_theta, &cols[mid]) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// A row of one incidence as evaluation reads it: α, cos θ, its positive run, the
/// incidence's normalisation 1/I and the row's total (normalised: the conditional integral
/// from the end of the positive run on).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Row {
    pub alpha: f64,
    pub cos_theta: f64,
    pub positive: usize,
    pub scale: f64,
    pub total: f64,
}

impl Row {
    /// The normalised density at column a, whose quantities are `c`: `scale`·f_a·bracket, 0
    /// beyond the positive run.
    #[inline(always)]
    pub fn density(&self, a: usize, c: &Column) -> f64 {
        if a < self.positive {
            self.scale * (c.f * bracket(self.alpha, self.cos_theta, c).max(0.0))
        } else {
            0.0
        }
    }

    /// The normalised conditional integral at column a (quantities `c`): the trapezoid sum of
    /// the row's densities over columns 0..=a, which stays at the row's total from the end of
    /// the positive run on.
    #[inline(always)]
    pub fn cond(&self, a: usize, c: &Column) -> f64 {
        if a < self.positive {
            self.scale * (self.alpha * c.u + self.cos_theta * c.v)
        } else {
            self.total
        }
    }
}

/// A row's total before normalisation, Σ_a w_a p[b][a]: its conditional integral at the last
/// positive column q plus the half segment from q to the first non-positive one,
/// α·U[q] + cos θ·V[q] + p[b][q]/(2(G−1)) (0 for an empty run).
/// `col` gives the quantities of the grid's columns, of which the last is `last` (G − 1).
#[inline(always)]
pub(crate) fn row_total(
    alpha: f64,
    cos_theta: f64,
    positive: usize,
    last: usize,
    col: impl Fn(usize) -> Column,
) -> f64 {
    if positive == 0 {
        return 0.0;
    }
    let c = &col(positive - 1);
    let sum = alpha * c.u + cos_theta * c.v;
    if positive > last {
        sum
    } else {
        let half = 0.5 / last as f64;
        sum + half * (c.f * bracket(alpha, cos_theta, c).max(0.0))
    }
}

/// Incidence θ's rows (radians): per row its positive run and its total before normalisation,
/// for `cols` and `cos_phi` of one grid.
pub(crate) fn rows<'a>(
    cols: &'a [Column],
    cos_phi: &'a [f64],
    theta: f64,
) -> impl ExactSizeIterator<Item = (usize, f64)> + 'a {
    let (s, c) = theta.sin_cos();
    cos_phi.iter().map(move |&cp| {
        let positive = positive_run(cols, s * cp, c);
        (
            positive,
            row_total(s * cp, c, positive, cols.len() - 1, |a| cols[a]),
        )
    })
}

/// The total I(θ) of the VNDF at θ (radians): the trapezoid rule over the rows of their totals.
pub(crate) fn total(cols: &[Column], cos_phi: &[f64], theta: f64) -> f64 {
    let g = cols.len();
    let (end, inner) = (0.5 / (g - 1) as f64, 1.0 / (g - 1) as f64);
    rows(cols, cos_phi, theta)
        .enumerate()
        .map(|(b, (_, row))| if b == 0 || b == g - 1 { end } else { inner } * row)
        .sum()
}

/// The VNDF totals I(θ) of `spec/EVALUATION.md`, "Warped tables", for an NDF on a G × G grid
/// at each θ (radians): what σ is c times (the encoder finds c from a measurement's own σ).
#[cfg(feature = "encode")]
pub(crate) fn vndf_totals(ndf: &[f32], g: usize, thetas: &[f64]) -> Vec<f64> {
    let (cols, cos_phi) = (columns(ndf, g), row_cosines(g));
    thetas.iter().map(|&t| total(&cols, &cos_phi, t)).collect()
}
