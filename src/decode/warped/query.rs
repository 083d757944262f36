//! A query of warped tables, written once over [`WarpSource`] (`spec/EVALUATION.md`, "Warped
//! tables"): the half vector's inverse VNDF warp blended between the two stored incidences
//! around θ, the tables bilinear at the warped point, D/(4σ)/cos θ; and importance sampling
//! (a warped point from the tables' spectrum-averaged values, then the VNDF warp forward).
//!
//! The warps are the continuous marginal/conditional warps of bilinear densities on nodes, with
//! every density, conditional integral, row total and marginal blended between the two slices
//! as Mitsuba's `Marginal2D` blends its parameter slices. Nothing here is tabulated per node on
//! G × G grids: the VNDF's conditional integrals come from [`Row::cond`] (O(1)), the values'
//! from the tables along the row.

use super::source::{mark_column, MARKS};
use super::source::{TableView, WarpSource};
use super::vndf::{row_total, Column, Row};
use crate::decode::records::lattice::QueryFrame;
use crate::model::angles::azimuth_rotation;
use crate::model::warped::{half_vector, jacobian, lerp_nodes, HORIZON_COS, POLE_HALF_XY};
use std::f64::consts::{FRAC_PI_2, PI};

/// The share of cosine-weighted hemisphere sampling in the proposal (as for records): the
/// density stays positive wherever cos θo > 0.
pub(crate) const COSINE_SHARE: f64 = crate::decode::sampling::sample::MIN_COSINE_WEIGHT;

/// The blend of two stored incidences: `a` weighted 1 − t, `b` weighted t.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Slices {
    pub a: usize,
    pub b: usize,
    pub t: f64,
}

impl Slices {
    /// x of slice a blended with y of slice b.
    #[inline(always)]
    fn mix(&self, x: f64, y: f64) -> f64 {
        x + (y - x) * self.t
    }
}

#[inline(always)]
pub(crate) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// The cell of x ∈ [0, 1] (clamped) on n nodes and the position within it.
#[inline(always)]
fn cell(x: f64, n: usize) -> (usize, f64) {
    let f = x.clamp(0.0, 1.0) * (n - 1) as f64;
    // f ≥ 0 (or NaN, which `as` turns into 0): truncation is the floor, without a call.
    let i = (f as usize).min(n - 2);
    (i, f - i as f64)
}

/// The first interval k ∈ [0, n−2] whose upper CDF value reaches s.
#[inline]
fn interval(n: usize, s: f64, cdf_at: impl Fn(usize) -> f64) -> usize {
    let (mut lo, mut hi) = (0usize, n - 1);
    while lo + 1 < hi {
        let mid = (lo + hi) / 2;
        if cdf_at(mid) < s {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (hi - 1).min(n - 2)
}

/// τ ∈ [0, 1] with ∫₀^τ lerp(v0, v1, t) dt = a.
#[inline]
fn solve_segment(a: f64, v0: f64, v1: f64) -> f64 {
    let a = a.max(0.0);
    let disc = (v0 * v0 + 2.0 * a * (v1 - v0)).max(0.0);
    let den = v0 + disc.sqrt();
    if den > 0.0 {
        (2.0 * a / den).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The stored incidences around θ (radians) and the weight of the upper one.
#[inline]
pub(crate) fn slices<S: WarpSource>(s: &S, theta: f64) -> Slices {
    let n = s.dims().n;
    if n == 1 {
        return Slices { a: 0, b: 0, t: 0.0 };
    }
    let th = theta.clamp(s.theta(0), s.theta(n - 1));
    let mut i = 0;
    let mut hi = s.theta(1);
    while i + 2 < n && hi <= th {
        i += 1;
        hi = s.theta(i + 1);
    }
    let lo = s.theta(i);
    Slices {
        a: i,
        b: i + 1,
        t: ((th - lo) / (hi - lo)).clamp(0.0, 1.0),
    }
}

/// Rows b and b + 1 of stored incidence i's VNDF (their cos φ `cp0`, `cp1`), as [`Row`]
/// evaluates them.
#[inline(always)]
fn vndf_rows<S: WarpSource>(s: &S, i: usize, b: usize, cp0: f64, cp1: f64) -> (Row, Row) {
    let inc = s.incidence(i);
    let last = s.dims().g - 1;
    let row = |bb: usize, cp: f64| {
        let (alpha, positive) = (inc.sin * cp, s.vndf_row(i, bb).positive);
        let total = row_total(alpha, inc.cos, positive, last, |a| s.column(a));
        Row {
            alpha,
            cos_theta: inc.cos,
            positive,
            scale: inc.vndf_scale,
            total: inc.vndf_scale * total,
        }
    };
    (row(b, cp0), row(b + 1, cp1))
}

/// The four rows a cell of the blended VNDF reads: rows b and b + 1 of slices a and b.
#[derive(Clone, Copy)]
struct CellRows {
    lo: [Row; 2],
    hi: [Row; 2],
}

impl CellRows {
    #[inline(always)]
    fn new<S: WarpSource>(s: &S, sl: Slices, b: usize) -> Self {
        let (cp0, cp1) = (s.cos_phi(b), s.cos_phi(b + 1));
        let (a0, a1) = vndf_rows(s, sl.a, b, cp0, cp1);
        let (b0, b1) = if sl.b == sl.a {
            (a0, a1)
        } else {
            vndf_rows(s, sl.b, b, cp0, cp1)
        };
        CellRows {
            lo: [a0, b0],
            hi: [a1, b1],
        }
    }

    /// The blended density at column a (quantities `c`) of the lower and upper row.
    #[inline(always)]
    fn densities(&self, sl: Slices, a: usize, c: &Column) -> (f64, f64) {
        (
            sl.mix(self.lo[0].density(a, c), self.lo[1].density(a, c)),
            sl.mix(self.hi[0].density(a, c), self.hi[1].density(a, c)),
        )
    }

    /// The blended conditional integral at column a (quantities `c`) of the lower and upper
    /// row.
    #[inline(always)]
    fn conds(&self, sl: Slices, a: usize, c: &Column) -> (f64, f64) {
        (
            sl.mix(self.lo[0].cond(a, c), self.lo[1].cond(a, c)),
            sl.mix(self.hi[0].cond(a, c), self.hi[1].cond(a, c)),
        )
    }

    /// The blended conditional integral at column a, rows blended by ty.
    #[inline(always)]
    fn cond<S: WarpSource>(&self, s: &S, sl: Slices, a: usize, ty: f64) -> f64 {
        let (lo, hi) = self.conds(sl, a, &s.column(a));
        lerp(lo, hi, ty)
    }

    /// The blended totals of the lower and upper row.
    #[inline(always)]
    fn totals(&self, sl: Slices) -> (f64, f64) {
        (
            sl.mix(self.lo[0].total, self.lo[1].total),
            sl.mix(self.hi[0].total, self.hi[1].total),
        )
    }
}

/// The blended VNDF's marginal at row b.
#[inline(always)]
fn vndf_marg<S: WarpSource>(s: &S, sl: Slices, b: usize) -> f64 {
    sl.mix(s.vndf_row(sl.a, b).marg, s.vndf_row(sl.b, b).marg)
}

/// The inverse VNDF warp: a point u of the half vectors' square → the warped point s, and
/// the blended VNDF density at u (the same cell's nodes).
#[inline]
pub(crate) fn vndf_invert<S: WarpSource>(s: &S, sl: Slices, ux: f64, uy: f64) -> (f64, f64, f64) {
    let g = s.dims().g;
    let n1 = (g - 1) as f64;
    let (a, tx) = cell(ux, g);
    let (b, ty) = cell(uy, g);
    let rows = CellRows::new(s, sl, b);
    let (col0, col1) = (s.column(a), s.column(a + 1));
    let (d00, d01) = rows.densities(sl, a, &col0);
    let (d10, d11) = rows.densities(sl, a + 1, &col1);
    let (c0, c1) = (lerp(d00, d01, ty), lerp(d10, d11, ty));
    let (b0, b1) = rows.conds(sl, a, &col0);
    let before = lerp(b0, b1, ty);
    let within = tx * (c0 + 0.5 * (c1 - c0) * tx) / n1;
    let (r0, r1) = rows.totals(sl);
    let total = lerp(r0, r1, ty);
    let sx = if total > 0.0 {
        (before + within) / total
    } else {
        0.0
    };
    let sy = vndf_marg(s, sl, b) + ty * (r0 + 0.5 * (r1 - r0) * ty) / n1;
    (sx.clamp(0.0, 1.0), sy.clamp(0.0, 1.0), lerp(c0, c1, tx))
}

/// The forward VNDF warp: a uniform point (sx, sy) → a point u of the half vectors' square.
fn vndf_sample<S: WarpSource>(s: &S, sl: Slices, sx: f64, sy: f64) -> (f64, f64) {
    let g = s.dims().g;
    let n1 = (g - 1) as f64;
    let (sx, sy) = (sx.clamp(0.0, 1.0), sy.clamp(0.0, 1.0));
    let b = interval(g, sy, |bb| vndf_marg(s, sl, bb));
    let rows = CellRows::new(s, sl, b);
    let (r0, r1) = rows.totals(sl);
    let ty = solve_segment((sy - vndf_marg(s, sl, b)) * n1, r0, r1);
    let target = sx * lerp(r0, r1, ty);
    let a = interval(g, target, |aa| rows.cond(s, sl, aa, ty));
    let (d00, d01) = rows.densities(sl, a, &s.column(a));
    let (d10, d11) = rows.densities(sl, a + 1, &s.column(a + 1));
    let (c0, c1) = (lerp(d00, d01, ty), lerp(d10, d11, ty));
    let tx = solve_segment((target - rows.cond(s, sl, a, ty)) * n1, c0, c1);
    ((a as f64 + tx) / n1, (b as f64 + ty) / n1)
}

/// How many terms' table views [`SliceValues`] keeps at hand (files with more read each
/// view when used).
const CACHED_TERMS: usize = 4;

/// The values' density of one stored incidence: its tables' views and basis means.
struct SliceValues<'a, S: WarpSource + 'a> {
    s: &'a S,
    i: usize,
    k: usize,
    views: [S::Table<'a>; CACHED_TERMS],
    means: [f64; CACHED_TERMS],
    scale: f64,
    floor: f64,
}

impl<'a, S: WarpSource> SliceValues<'a, S> {
    #[inline(always)]
    fn new(s: &'a S, i: usize) -> Self {
        let k = s.dims().k;
        let inc = s.incidence(i);
        let last = k.saturating_sub(1);
        SliceValues {
            s,
            i,
            k,
            views: std::array::from_fn(|j| s.table(i * k + j.min(last))),
            means: std::array::from_fn(|j| s.basis_mean(j.min(last))),
            scale: inc.values_scale,
            floor: inc.values_floor,
        }
    }

    /// The normalised density at a node: the tables' spectrum-averaged value there, clamped
    /// at 0, plus the incidence's floor.
    #[inline(always)]
    fn at(&self, node: usize) -> f64 {
        let mut v = 0.0;
        if self.k <= CACHED_TERMS {
            for j in 0..self.k {
                v += self.views[j].at(node) * self.means[j];
            }
        } else {
            for j in 0..self.k {
                v += self.s.table(self.i * self.k + j).at(node) * self.s.basis_mean(j);
            }
        }
        self.scale * (v.max(0.0) + self.floor)
    }

    /// [`SliceValues::at`] at nodes j and j + 1.
    #[inline(always)]
    fn pair(&self, j: usize) -> (f64, f64) {
        let (mut v0, mut v1) = (0.0, 0.0);
        if self.k <= CACHED_TERMS {
            for t in 0..self.k {
                let (x0, x1) = self.views[t].pair(j);
                v0 += x0 * self.means[t];
                v1 += x1 * self.means[t];
            }
        } else {
            return (self.at(j), self.at(j + 1));
        }
        (
            self.scale * (v0.max(0.0) + self.floor),
            self.scale * (v1.max(0.0) + self.floor),
        )
    }
}

/// The blended, normalised values' density at the warped point (x, y).
#[inline]
fn values_density<S: WarpSource>(s: &S, sl: Slices, x: f64, y: f64) -> f64 {
    let r = s.dims().r;
    let (va, vb) = (SliceValues::new(s, sl.a), SliceValues::new(s, sl.b));
    let (a, tx) = cell(x, r);
    let (b, ty) = cell(y, r);
    let (n00, n10) = (b * r + a, (b + 1) * r + a);
    let mix = |(x0, x1): (f64, f64), (y0, y1): (f64, f64)| (sl.mix(x0, y0), sl.mix(x1, y1));
    let (v00, v01) = mix(va.pair(n00), vb.pair(n00));
    let (v10, v11) = mix(va.pair(n10), vb.pair(n10));
    lerp(lerp(v00, v01, tx), lerp(v10, v11, tx), ty)
}

/// The forward warp of the values' density: a uniform point → a warped point. The row by its
/// stored marginal; the column by walking the row's nodes (its conditional integrals are not
/// stored).
fn values_sample<S: WarpSource>(s: &S, sl: Slices, sx: f64, sy: f64) -> (f64, f64) {
    let r = s.dims().r;
    let n1 = (r - 1) as f64;
    let (sx, sy) = (sx.clamp(0.0, 1.0), sy.clamp(0.0, 1.0));
    let marg = |bb: usize| sl.mix(s.values_row(sl.a, bb).marg, s.values_row(sl.b, bb).marg);
    let b = interval(r, sy, marg);
    let total = |bb: usize| sl.mix(s.values_row(sl.a, bb).total, s.values_row(sl.b, bb).total);
    let (r0, r1) = (total(b), total(b + 1));
    let ty = solve_segment((sy - marg(b)) * n1, r0, r1);
    let target = sx * lerp(r0, r1, ty);
    let (va, vb) = (SliceValues::new(s, sl.a), SliceValues::new(s, sl.b));
    // The blended density at column a of the two rows, blended by ty.
    let at = |a: usize| {
        let (lo, hi) = (b * r + a, (b + 1) * r + a);
        lerp(
            sl.mix(va.at(lo), vb.at(lo)),
            sl.mix(va.at(hi), vb.at(hi)),
            ty,
        )
    };
    // Start at the last kept column whose blended conditional integral is below the target.
    let (lo_a, lo_b) = (s.values_row(sl.a, b), s.values_row(sl.b, b));
    let (hi_a, hi_b) = (s.values_row(sl.a, b + 1), s.values_row(sl.b, b + 1));
    let (mut a, mut before) = (0, 0.0);
    for j in 0..MARKS {
        let m = lerp(
            sl.mix(lo_a.marks[j], lo_b.marks[j]),
            sl.mix(hi_a.marks[j], hi_b.marks[j]),
            ty,
        );
        if m >= target {
            break;
        }
        (a, before) = (mark_column(r, j + 1), m);
    }
    // Then the first column a ≤ R − 2 whose segment's upper integral reaches the target.
    let half = 0.5 / n1;
    let (mut c0, mut c1) = (at(a), at(a + 1));
    while a + 2 < r {
        let next = before + half * (c0 + c1);
        if next >= target {
            break;
        }
        (a, before, c0) = (a + 1, next, c1);
        c1 = at(a + 1);
    }
    let tx = solve_segment((target - before) * n1, c0, c1);
    ((a as f64 + tx) / n1, (b as f64 + ty) / n1)
}

/// A table bilinear in the cell whose lower row starts at node n00 (the upper at n10), at
/// (tx, ty) within it.
#[inline(always)]
fn table_bilerp<T: TableView>(t: T, n00: usize, n10: usize, tx: f64, ty: f64) -> f64 {
    let ((v00, v01), (v10, v11)) = (t.pair(n00), t.pair(n10));
    lerp(lerp(v00, v01, tx), lerp(v10, v11, tx), ty)
}

/// The frame turned about z so that the tables' direction `wi` has azimuth 0 (none at the
/// pole), and that direction's θ in radians.
#[inline]
fn frame(wi: [f64; 3]) -> (QueryFrame, f64) {
    let (r, c, s) = azimuth_rotation(wi);
    let theta = r.atan2(wi[2]);
    let q = QueryFrame {
        // Not read here (the frame's rotation and vector are).
        theta: 0.0,
        phi: 0.0,
        wi: [r, 0.0, wi[2]],
        rotation: Some((c, s)),
    };
    (q, theta)
}

/// The half-vector parameter u of unit m: (√(θm/(π/2)), (φm + π)/(2π) in [0, 1)).
#[inline(always)]
fn half_parameter(m: [f64; 3]) -> (f64, f64, f64) {
    let sin_m = (m[0] * m[0] + m[1] * m[1]).sqrt();
    let theta_m = sin_m.atan2(m[2]);
    let ux = (theta_m / FRAC_PI_2).sqrt();
    let mut uy = (m[1].atan2(m[0]) + PI) / (2.0 * PI);
    // uy ∈ [0, 1] (atan2 ∈ [−π, π]): uy − ⌊uy⌋ without a call.
    if uy >= 1.0 {
        uy -= 1.0;
    }
    (ux, uy, sin_m)
}

/// The blended table values v_k times D(u_x)/(4σ(θv))/max(cos θi, 2⁻¹⁰): the spectral
/// coefficients of ρ at unit vectors `wi` (toward the light), `wo` (toward the viewer), z ≥ 0,
/// into `c` (K values). The tables are indexed by the viewing direction, as RGL files and
/// Mitsuba's `measured` plugin index them (`spec/EVALUATION.md`, "Warped tables"): the roles of
/// the two vectors are exchanged here. A half vector within [`POLE_HALF_XY`] of the pole is the
/// pole. False (and `c` zero) only for a non-finite input.
#[inline]
pub(crate) fn coefficients<S: WarpSource>(
    s: &S,
    wi: [f64; 3],
    wo: [f64; 3],
    c: &mut [f64],
) -> bool {
    let d = s.dims();
    let c = &mut c[..d.k];
    c.fill(0.0);
    // The tables' own direction (the viewer's) first, the light's second.
    let (q, theta_i) = frame(wo);
    let (wi, wo) = (q.wi, q.in_frame(wi));
    // On the horizon (z = 0) evaluated normally; below it (only by a NaN's way) nothing.
    if wo[2].is_nan() || wo[2] < 0.0 {
        return false;
    }
    let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    let h_xy = (h[0] * h[0] + h[1] * h[1]).sqrt();
    // The mirror direction (and both directions opposite on the horizon, h = 0): the pole.
    let (ux, uy) = if h_xy <= POLE_HALF_XY {
        (0.0, 0.5)
    } else {
        let len = (h_xy * h_xy + h[2] * h[2]).sqrt();
        if len.is_nan() {
            return false;
        }
        let (ux, uy, _) = half_parameter([h[0] / len, h[1] / len, h[2] / len]);
        (ux, uy)
    };
    let sl = slices(s, theta_i);
    let (sx, sy, _) = vndf_invert(s, sl, ux, uy);
    let xi = (theta_i.max(0.0) / FRAC_PI_2).sqrt();
    let sigma = lerp_nodes(d.m, xi, |j| s.sigma(j));
    let f = lerp_nodes(d.m, ux, |j| s.ndf(j)) / (4.0 * sigma) / wo[2].max(HORIZON_COS);
    let r = d.r;
    let (a, tx) = cell(sx, r);
    let (b, ty) = cell(sy, r);
    let (n00, n10) = (b * r + a, (b + 1) * r + a);
    for (k, ck) in c.iter_mut().enumerate() {
        let va = table_bilerp(s.table(sl.a * d.k + k), n00, n10, tx, ty);
        let vb = table_bilerp(s.table(sl.b * d.k + k), n00, n10, tx, ty);
        *ck = (va + (vb - va) * sl.t) * f;
    }
    true
}

/// Draws ωo for unit `wi` (z ≥ 0, the direction the sampler is given: the tables' own) from `u`
/// ∈ [0, 1)²: with probability [`COSINE_SHARE`] a cosine-weighted direction, else the reflection
/// of a half vector drawn from the blended VNDF warp at a warped point drawn from the values'
/// density, mirrored to the upper hemisphere (z → −z) when it falls below (so every draw
/// counts; [`pdf`] adds both ways of reaching a direction). `None` only for a degenerate draw
/// (on the horizon).
pub(crate) fn sample<S: WarpSource>(s: &S, wi: [f64; 3], u: [f64; 2]) -> Option<[f64; 3]> {
    let (q, theta_i) = frame(wi);
    let wi2 = q.wi;
    let mut local = if u[0] < COSINE_SHARE {
        let u0 = u[0] / COSINE_SHARE;
        let rad = u0.sqrt();
        let phi = 2.0 * PI * u[1];
        [rad * phi.cos(), rad * phi.sin(), (1.0 - u0).max(0.0).sqrt()]
    } else {
        let u0 = ((u[0] - COSINE_SHARE) / (1.0 - COSINE_SHARE)).min(1.0);
        let sl = slices(s, theta_i);
        let (sx, sy) = values_sample(s, sl, u0, u[1]);
        let (ux, uy) = vndf_sample(s, sl, sx, sy);
        let (m, _) = half_vector(ux, uy);
        let d = 2.0 * (wi2[0] * m[0] + wi2[2] * m[2]);
        [d * m[0] - wi2[0], d * m[1], d * m[2] - wi2[2]]
    };
    local[2] = local[2].abs();
    if local[2].is_nan() || local[2] <= 0.0 {
        return None;
    }
    Some(q.out_of_frame(local))
}

/// The density (1/sr) with which [`sample`] draws unit `wo` (z ≥ 0) for unit `wi`: the cosine
/// share, plus the tables' share at `wo` and at its mirror image below the horizon.
pub(crate) fn pdf<S: WarpSource>(s: &S, wi: [f64; 3], wo: [f64; 3]) -> f64 {
    let (q, theta_i) = frame(wi);
    let (wi, wo) = (q.wi, q.in_frame(wo));
    if wo[2] <= 0.0 {
        return 0.0;
    }
    let sl = slices(s, theta_i);
    let below = [wo[0], wo[1], -wo[2]];
    let tables = reflected_density(s, sl, wi, wo) + reflected_density(s, sl, wi, below);
    COSINE_SHARE * wo[2] / PI + (1.0 - COSINE_SHARE) * tables
}

/// The density over ωo (any unit vector, the tables' frame) of reflecting `wi` about a half
/// vector drawn from the blended warps: p_v(s)·p(u)/J(u)/(4 ωo·m), 0 where m is below the
/// horizon or faces away from ωo.
fn reflected_density<S: WarpSource>(s: &S, sl: Slices, wi: [f64; 3], wo: [f64; 3]) -> f64 {
    let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
    if len.is_nan() || len <= 0.0 || h[2] < 0.0 {
        return 0.0;
    }
    let m = [h[0] / len, h[1] / len, h[2] / len];
    let (ux, uy, sin_m) = half_parameter(m);
    let jac = jacobian(ux, sin_m);
    let dot = wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2];
    if jac > 0.0 && dot > 0.0 {
        let (sx, sy, vndf) = vndf_invert(s, sl, ux, uy);
        values_density(s, sl, sx, sy) * vndf / jac / (4.0 * dot)
    } else {
        0.0
    }
}
