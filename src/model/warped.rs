//! Warped tables (`WARP`, format 1.4; the wavelet transform 1.5): a measurement kept on the
//! parameterisation it was acquired in (Dupuy & Jakob 2018, the RGL material database),
//! transform-coded.
//!
//! What is stored, exactly as the file stores it (`spec/FORMAT.md` §3.10): the NDF at M nodes,
//! the σ normalisation, and per stored incidence i and spectral term k an R × R table given by
//! its quantised coefficients (integers, one step per table) in one of two separable
//! transforms: the orthonormal 2-D DCT-II, or the CDF 5/3 wavelet (three lifting levels per
//! axis, each coefficient scaled to a unit-norm synthesis vector). What the numbers mean
//! (the VNDF warp rebuilt from the NDF, the value of a query): `spec/EVALUATION.md`, "Warped
//! tables". This module holds the data, its invariants and the transform both sides share; the
//! decoder's resident form is `decode::warped`, the fitting `encode::warped`.

use crate::model::Precision;
use std::f64::consts::PI;

/// Largest table side R.
pub const MAX_GRID: usize = 64;
/// Smallest VNDF grid side G (with 2 the only rows are φm = ±π).
pub const MIN_WARP_GRID: usize = 3;
/// Largest VNDF grid side G.
pub const MAX_WARP_GRID: usize = 256;
/// Most NDF nodes M.
pub const MAX_NDF: usize = 4096;
/// Most table values N·K·R² and most warp nodes N·G² in one file.
pub const MAX_WARP_VALUES: u64 = 1 << 24;
/// Largest magnitude of a stored integer: z ∈ [−2³⁰, 2³⁰ − 1].
pub const MAX_LEVEL: i64 = 1 << 30;

/// Lifting levels of the wavelet transform per axis (fewer where a side runs out first).
pub const WAVELET_LEVELS: usize = 3;

/// The separable transform a file's tables are coded in (`spec/FORMAT.md` §3.10, the high four
/// bits of `layout`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableTransform {
    /// Code 0 (1.4): orthonormal DCT-II, coefficients in diagonal order. Best where a table
    /// is smooth everywhere (a film whose colour changes slowly with angle).
    Dct,
    /// Code 1 (1.5): CDF 5/3 wavelet, [`WAVELET_LEVELS`] levels per axis, coefficients in band
    /// order. Best where features are local (a one-column specular spike, the run of zeros
    /// beyond the horizon): their cost stays where they are instead of spreading over every
    /// frequency (a 64 × 64 film: 15.8 → 7.2 kB of payload at 1%).
    Wavelet53,
}

impl TableTransform {
    /// The transform's code (the high four bits of `layout`): 0 DCT, 1 wavelet.
    pub fn code(self) -> u8 {
        match self {
            TableTransform::Dct => 0,
            TableTransform::Wavelet53 => 1,
        }
    }

    /// The transform with this code; None for an unknown code.
    pub fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(TableTransform::Dct),
            1 => Some(TableTransform::Wavelet53),
            _ => None,
        }
    }

    /// The n × n synthesis basis: row a (`basis[a·n + x]`) is the vector coefficient a
    /// contributes per unit along a table axis; a table is Σ_a Σ_b C(a, b)·row_a ⊗ row_b
    /// ([`idct2`]).
    pub fn synthesis(self, n: usize) -> Vec<f64> {
        match self {
            TableTransform::Dct => dct_basis(n),
            TableTransform::Wavelet53 => wavelet_synthesis(n),
        }
    }

    /// The n × n analysis basis: the inverse of [`TableTransform::synthesis`] (its transpose
    /// for the orthonormal DCT), as the forward transform [`dct2`] takes it.
    pub fn analysis(self, n: usize) -> Vec<f64> {
        match self {
            TableTransform::Dct => dct_basis(n),
            TableTransform::Wavelet53 => wavelet_analysis(n),
        }
    }

    /// The file's order of an R × R table's coefficients: position p holds row-major index
    /// `order[p]` = a·R + b.
    pub fn order(self, r: usize) -> Vec<usize> {
        match self {
            TableTransform::Dct => diagonal_order(r),
            TableTransform::Wavelet53 => band_order(r),
        }
    }
}

/// How a `WARP` chunk's integers are coded (`spec/FORMAT.md` §3.10, "Payload").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PayloadCoding {
    /// zlib of zigzag LEB128 varints (format 1.4 and 1.5).
    Deflate,
    /// The context-adaptive binary range coder (format 1.6, `layout` bit 3): 19–34% fewer
    /// bytes on the shipped RGL measurements.
    Range,
}

/// The model of a `WARP` chunk: isotropic tables over HEAD's N incidences and K terms.
#[derive(Debug, Clone, PartialEq)]
pub struct WarpedModel {
    /// The transform the tables are coded in.
    pub transform: TableTransform,
    /// How the file codes the tables' integers.
    pub coding: PayloadCoding,
    /// Table side R (2..=64).
    pub grid: usize,
    /// VNDF grid side G (3..=256).
    pub warp_grid: usize,
    /// σ normalisation c (finite, > 0).
    pub sigma_scale: f32,
    /// How the NDF values are stored (each exactly representable in it).
    pub ndf_precision: Precision,
    /// The NDF at M nodes x_j = j/(M−1) of u_x (1/sr).
    pub ndf: Vec<f32>,
    /// q(i, k) at i·K + k.
    pub steps: Vec<f32>,
    /// n(i, k, a, b): table (i, k) at (i·K + k)·R², its R² integers in row-major coefficient
    /// order (a·R + b), *not* the file's order (the format module reorders).
    pub levels: Vec<i32>,
    /// Format 1.7 (`layout` arrangement 2): per incidence, whether its tables' coefficients are
    /// the difference to the previous incidence's (`predicted[i]`, never for i = 0). Empty in a
    /// file without the flags (arrangement 1), where every table stands alone. Neighbouring
    /// incidences of a measurement share most of their shape (RGL files repeat their last
    /// one), so the difference is often far smaller than the table.
    pub predicted: Vec<bool>,
}

impl WarpedModel {
    /// Checks the invariants of §3.10 that do not depend on byte layout, for `n` incidences and
    /// `k` terms.
    pub fn validate(&self, n: usize, k: usize) -> Result<(), String> {
        let (r, g, m) = (self.grid, self.warp_grid, self.ndf.len());
        if !(2..=MAX_GRID).contains(&r) {
            return Err(format!("warped tables of side {r} (2 to {MAX_GRID})"));
        }
        if !(MIN_WARP_GRID..=MAX_WARP_GRID).contains(&g) {
            return Err(format!(
                "a VNDF grid of side {g} ({MIN_WARP_GRID} to {MAX_WARP_GRID})"
            ));
        }
        if !(2..=MAX_NDF).contains(&m) {
            return Err(format!("{m} NDF nodes (2 to {MAX_NDF})"));
        }
        if (n as u64) * (k as u64) * (r * r) as u64 > MAX_WARP_VALUES {
            return Err(format!(
                "{n} incidences × {k} terms × {r}² table values exceed {MAX_WARP_VALUES}"
            ));
        }
        if (n as u64) * (g * g) as u64 > MAX_WARP_VALUES {
            return Err(format!(
                "{n} incidences × {g}² VNDF nodes exceed {MAX_WARP_VALUES}"
            ));
        }
        if !(self.sigma_scale.is_finite() && self.sigma_scale > 0.0) {
            return Err(format!("sigma_scale {} is not > 0", self.sigma_scale));
        }
        if let Some((j, v)) = self
            .ndf
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(format!("NDF node {j} is {v}, not a finite value ≥ 0"));
        }
        if self.ndf_precision == Precision::F16
            && self
                .ndf
                .iter()
                .any(|&v| half::f16::from_f32(v).to_f32().to_bits() != v.to_bits())
        {
            return Err("an NDF value not representable in its f16 precision".into());
        }
        if !self.ndf.iter().any(|&v| v > 0.0) {
            return Err("the NDF is zero everywhere".into());
        }
        if self.steps.len() != n * k {
            return Err(format!(
                "{} quantisation steps for {n} incidences × {k} terms",
                self.steps.len()
            ));
        }
        if let Some((j, q)) = self
            .steps
            .iter()
            .enumerate()
            .find(|(_, q)| !(q.is_finite() && **q >= 0.0))
        {
            return Err(format!(
                "quantisation step {j} is {q}, not a finite value ≥ 0"
            ));
        }
        if self.levels.len() != n * k * r * r {
            return Err(format!(
                "{} table coefficients for {n} × {k} tables of {r}²",
                self.levels.len()
            ));
        }
        if let Some(z) = self
            .levels
            .iter()
            .find(|&&z| !(-MAX_LEVEL..MAX_LEVEL).contains(&(z as i64)))
        {
            return Err(format!("a table coefficient {z} outside ±2³⁰"));
        }
        if !self.predicted.is_empty() {
            if self.predicted.len() != n {
                return Err(format!(
                    "{} prediction flags for {n} incidences",
                    self.predicted.len()
                ));
            }
            if self.predicted[0] {
                return Err("the first incidence predicted (it has none before it)".into());
            }
            if self.coding != PayloadCoding::Range {
                return Err("prediction flags in a payload that is not range-coded".into());
            }
        }
        Ok(())
    }

    /// Bytes held on the heap by a boxed model: the box and its vectors (capacities).
    pub fn boxed_heap_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + 4 * (self.ndf.capacity() + self.steps.capacity() + self.levels.capacity())
            + self.predicted.capacity()
    }

    /// Whether incidence i's coefficients are the difference to incidence i − 1's.
    pub fn is_predicted(&self, i: usize) -> bool {
        self.predicted.get(i).copied().unwrap_or(false)
    }

    /// Number of tables N·K.
    pub fn tables(&self) -> usize {
        self.steps.len()
    }

    /// The coefficients of every table (same layout as `levels`), in binary64: q(i, k)·n, plus
    /// table (i − 1, k)'s coefficients where incidence i is predicted (`spec/FORMAT.md` §3.10).
    pub fn coefficients(&self) -> Vec<f64> {
        let rr = self.grid * self.grid;
        let k = self
            .steps
            .len()
            .checked_div(self.predicted.len())
            .unwrap_or(0);
        let mut coef = vec![0.0; self.levels.len()];
        for (t, &q) in self.steps.iter().enumerate() {
            let predicted = k > 0 && t >= k && self.is_predicted(t / k);
            for p in 0..rr {
                let before = predicted.then(|| coef[(t - k) * rr + p]);
                coef[t * rr + p] = coefficient(q, self.levels[t * rr + p], before);
            }
        }
        coef
    }

    /// The decoded tables, N·K of R² values each (row-major, rows along s_y), in binary64.
    pub fn decode_tables(&self) -> Vec<f64> {
        let r = self.grid;
        let basis = self.transform.synthesis(r);
        let coef = self.coefficients();
        let mut out = vec![0.0; coef.len()];
        for (c, o) in coef.chunks_exact(r * r).zip(out.chunks_exact_mut(r * r)) {
            idct2(&basis, r, c, o);
        }
        out
    }
}

/// One coefficient as the file defines it (`spec/FORMAT.md` §3.10): q·n in binary64, plus the
/// previous incidence's coefficient `before` in a predicted incidence. The encoder rebuilds
/// with it too, so that what it measures is bit for bit what a decoder gets.
pub fn coefficient(q: f32, n: i32, before: Option<f64>) -> f64 {
    let own = q as f64 * n as f64;
    before.map_or(own, |b| own + b)
}

/// The orthonormal DCT-II matrix of side n: `basis[a·n + x] = α(a)·cos(π(2x + 1)a / 2n)`.
pub fn dct_basis(n: usize) -> Vec<f64> {
    let mut b = vec![0.0; n * n];
    for a in 0..n {
        let alpha = if a == 0 {
            (1.0 / n as f64).sqrt()
        } else {
            (2.0 / n as f64).sqrt()
        };
        for x in 0..n {
            b[a * n + x] = alpha * (PI * (2 * x + 1) as f64 * a as f64 / (2 * n) as f64).cos();
        }
    }
    b
}

/// Forward 2-D transform of `x` (n × n, row-major) into `c[a·n + b]` (a: row coefficient) with
/// an analysis basis (`basis[a·n + x]`): the DCT-II with [`dct_basis`], or any
/// [`TableTransform::analysis`].
pub fn dct2(basis: &[f64], n: usize, x: &[f64], c: &mut [f64]) {
    // Rows first (t[r][b] = Σ_x basis[b][x]·x[r][x]), then columns.
    let mut t = vec![0.0; n * n];
    for r in 0..n {
        for b in 0..n {
            t[r * n + b] = (0..n).map(|k| basis[b * n + k] * x[r * n + k]).sum();
        }
    }
    for a in 0..n {
        for b in 0..n {
            c[a * n + b] = (0..n).map(|r| basis[a * n + r] * t[r * n + b]).sum();
        }
    }
}

/// Inverse of [`dct2`] given the synthesis basis (the orthonormal DCT-III with [`dct_basis`],
/// or any [`TableTransform::synthesis`]), in the order of the spec's formula: for each row r,
/// Σ_a `basis[a][r]`·Σ_b `basis[b][c]`·C(a, b).
pub fn idct2(basis: &[f64], n: usize, c: &[f64], x: &mut [f64]) {
    // t[a][col] = Σ_b basis[b][col]·C[a][b]
    let mut t = vec![0.0; n * n];
    for a in 0..n {
        for col in 0..n {
            t[a * n + col] = (0..n).map(|b| basis[b * n + col] * c[a * n + b]).sum();
        }
    }
    for r in 0..n {
        for col in 0..n {
            x[r * n + col] = (0..n).map(|a| basis[a * n + r] * t[a * n + col]).sum();
        }
    }
}

/// The file's diagonal order of an R × R table's frequencies: position p of the stream holds
/// row-major index `order[p]` = a·R + b, sorted by a + b, then by a.
pub fn diagonal_order(r: usize) -> Vec<usize> {
    let mut idx: Vec<(usize, usize)> = (0..r).flat_map(|a| (0..r).map(move |b| (a, b))).collect();
    idx.sort_by_key(|&(a, b)| (a + b, a));
    idx.into_iter().map(|(a, b)| a * r + b).collect()
}

/// Index j of a length-n signal under whole-sample symmetric extension (x₋ⱼ = xⱼ,
/// x_{n−1+j} = x_{n−1−j}), for −n < j < 2n − 1.
#[inline]
fn mirrored(j: isize, n: usize) -> usize {
    if j < 0 {
        (-j) as usize
    } else if j as usize >= n {
        2 * (n - 1) - j as usize
    } else {
        j as usize
    }
}

/// Where sample j of a level of length n goes in [low band | high band]: the even samples
/// first (⌈n/2⌉ of them), then the odd ones.
#[inline]
fn band_slot(j: usize, n: usize) -> usize {
    if j.is_multiple_of(2) {
        j / 2
    } else {
        n.div_ceil(2) + j / 2
    }
}

/// One level of the CDF 5/3 lifting on `x` (length n ≥ 2) with whole-sample symmetric
/// extension (x₋₁ = x₁, x_n = x_{n−2}): predict, each odd sample minus half its two even
/// neighbours; update, each even sample plus a quarter of its two odd neighbours; then the
/// even samples (⌈n/2⌉, low band) before the odd ones (⌊n/2⌋, high band).
pub fn lift53_forward(x: &mut [f64], scratch: &mut [f64]) {
    let n = x.len();
    let at = |j: usize, d: isize| mirrored(j as isize + d, n);
    for j in (1..n).step_by(2) {
        x[j] -= 0.5 * (x[j - 1] + x[at(j, 1)]);
    }
    for j in (0..n).step_by(2) {
        x[j] += 0.25 * (x[at(j, -1)] + x[at(j, 1)]);
    }
    for j in 0..n {
        scratch[band_slot(j, n)] = x[j];
    }
    x.copy_from_slice(&scratch[..n]);
}

/// The inverse of [`lift53_forward`]: interleave, undo the update, undo the prediction.
pub fn lift53_inverse(x: &mut [f64], scratch: &mut [f64]) {
    let n = x.len();
    for j in 0..n {
        scratch[j] = x[band_slot(j, n)];
    }
    x.copy_from_slice(&scratch[..n]);
    let at = |j: usize, d: isize| mirrored(j as isize + d, n);
    for j in (0..n).step_by(2) {
        x[j] -= 0.25 * (x[at(j, -1)] + x[at(j, 1)]);
    }
    for j in (1..n).step_by(2) {
        x[j] += 0.5 * (x[j - 1] + x[at(j, 1)]);
    }
}

/// The lengths the levels of a side n work on: n, then ⌈·/2⌉ of the previous while it is at
/// least 2, at most [`WAVELET_LEVELS`] of them.
fn wavelet_lengths(n: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut m = n;
    while out.len() < WAVELET_LEVELS && m >= 2 {
        out.push(m);
        m = m.div_ceil(2);
    }
    out
}

/// The multi-level forward transform of a vector (each level on the previous low band, the
/// coefficients coarse first: [low | coarsest high | … | finest high]), unscaled.
pub fn wavelet_forward(x: &mut [f64]) {
    let mut scratch = vec![0.0; x.len()];
    for m in wavelet_lengths(x.len()) {
        lift53_forward(&mut x[..m], &mut scratch);
    }
}

/// The inverse of [`wavelet_forward`].
pub fn wavelet_inverse(x: &mut [f64]) {
    let mut scratch = vec![0.0; x.len()];
    for m in wavelet_lengths(x.len()).into_iter().rev() {
        lift53_inverse(&mut x[..m], &mut scratch);
    }
}

/// The wavelet's synthesis basis of side n, each row unit norm: row a is the inverse transform
/// of the unit vector e_a divided by its Euclidean norm (so that one quantisation step costs
/// about the same error in every coefficient).
pub fn wavelet_synthesis(n: usize) -> Vec<f64> {
    let mut b = vec![0.0; n * n];
    for a in 0..n {
        let row = &mut b[a * n..(a + 1) * n];
        row[a] = 1.0;
        wavelet_inverse(row);
        let norm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
        row.iter_mut().for_each(|v| *v /= norm);
    }
    b
}

/// The wavelet's analysis basis of side n: row a (`[a·n + x]`) is the forward transform's
/// coefficient a of the unit vector e_x, times the norm that [`wavelet_synthesis`] divides by,
/// so that the two are inverses.
pub fn wavelet_analysis(n: usize) -> Vec<f64> {
    let mut norms = vec![0.0; n];
    for (a, norm) in norms.iter_mut().enumerate() {
        let mut e = vec![0.0; n];
        e[a] = 1.0;
        wavelet_inverse(&mut e);
        *norm = e.iter().map(|v| v * v).sum::<f64>().sqrt();
    }
    let mut b = vec![0.0; n * n];
    for x in 0..n {
        let mut e = vec![0.0; n];
        e[x] = 1.0;
        wavelet_forward(&mut e);
        for a in 0..n {
            b[a * n + x] = e[a] * norms[a];
        }
    }
    b
}

/// The band of each coefficient of a side n: 0 for the last low band, 1 for the coarsest high
/// band, …, the number of levels for the finest.
pub fn wavelet_bands(n: usize) -> Vec<usize> {
    let lengths = wavelet_lengths(n);
    let levels = lengths.len();
    let mut band = vec![0; n];
    for (j, &m) in lengths.iter().enumerate() {
        // Level j splits [0, m) into [0, ⌈m/2⌉) and the high band [⌈m/2⌉, m).
        for b in band.iter_mut().take(m).skip(m.div_ceil(2)) {
            *b = levels - j;
        }
    }
    band
}

/// The file's band order of an R × R wavelet table: the pairs (a, b) sorted by band(a) +
/// band(b), then band(a), then band(b), then a, then b (coarse before fine).
pub fn band_order(r: usize) -> Vec<usize> {
    let band = wavelet_bands(r);
    let mut idx: Vec<(usize, usize)> = (0..r).flat_map(|a| (0..r).map(move |b| (a, b))).collect();
    idx.sort_by_key(|&(a, b)| (band[a] + band[b], band[a], band[b], a, b));
    idx.into_iter().map(|(a, b)| a * r + b).collect()
}

/// Where the half vector h = ωi + ωo of a query is taken on the pole (`spec/EVALUATION.md`,
/// "Warped tables", Value step 1): when √(h_x² + h_y²) is at most this, u = (0, 1/2) (θm = 0,
/// φm = 0) whatever the rounding residue of h_x and h_y. At the mirror direction every φm names
/// the same half vector while the tables' column s_x = 0 varies along u_y, so without the rule
/// the value there was that of whatever azimuth atan2 returned for the residue (up to 9% apart
/// between conforming decoders; issue 43). Binary64 residues of directions made from angles are
/// ~10⁻¹⁶; a pair this close to the mirror is the mirror.
pub const POLE_HALF_XY: f64 = 1e-9;

/// The least cosine of the light's direction a warped table divides by (Value step 5): ρ =
/// … / max(cos θ, 2⁻¹⁰). The measurement's ρ grows as 1/cos θ toward the horizon (ρ·cos θ stays
/// finite); a decoder that returned 10¹³ at 90° set a trap for f32 sums, MIS weights and albedo
/// integrals. Below 89.94° (cos θ > 2⁻¹⁰) nothing changes; beyond, ρ·cos θ falls linearly to 0 at
/// the horizon. 2⁻¹⁰ is exact in binary32 and binary64.
pub const HORIZON_COS: f64 = 1.0 / 1024.0;

/// Half vector parameter → unit half vector: θm = u_x²·π/2, φm = 2π·u_y − π.
#[inline]
pub fn half_vector(ux: f64, uy: f64) -> ([f64; 3], f64) {
    let theta = ux * ux * std::f64::consts::FRAC_PI_2;
    let phi = 2.0 * PI * uy - PI;
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    ([st * cp, st * sp, ct], st)
}

/// The Jacobian of u ↦ m: sin θm · π u_x · 2π.
#[inline]
pub fn jacobian(ux: f64, sin_theta: f64) -> f64 {
    sin_theta * PI * ux * 2.0 * PI
}

/// D(x): the NDF nodes linearly interpolated at x ∈ [0, 1] (clamped).
#[inline]
pub fn ndf_at(ndf: &[f32], x: f64) -> f64 {
    lerp_nodes(ndf.len(), x, |i| ndf[i] as f64)
}

/// Linear interpolation of `len` nodes at j/(len−1), x clamped to [0, 1].
#[inline]
pub fn lerp_nodes(len: usize, x: f64, at: impl Fn(usize) -> f64) -> f64 {
    let f = x.clamp(0.0, 1.0) * (len - 1) as f64;
    // f ≥ 0 (or NaN, which `as` turns into 0): truncation is the floor, without a call.
    let i = (f as usize).min(len - 2);
    let t = f - i as f64;
    at(i) + (at(i + 1) - at(i)) * t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dct_round_trip_and_orthonormality() {
        let n = 7;
        let b = dct_basis(n);
        let x: Vec<f64> = (0..n * n).map(|i| ((i * 37) % 11) as f64 - 3.5).collect();
        let mut c = vec![0.0; n * n];
        let mut y = vec![0.0; n * n];
        dct2(&b, n, &x, &mut c);
        idct2(&b, n, &c, &mut y);
        for (a, b) in x.iter().zip(&y) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        // Parseval: the transform keeps the sum of squares.
        let ex: f64 = x.iter().map(|v| v * v).sum();
        let ec: f64 = c.iter().map(|v| v * v).sum();
        assert!((ex - ec).abs() < 1e-9 * ex);
        // Only the DC coefficient: a constant table C/R.
        let mut c = vec![0.0; n * n];
        c[0] = 14.0;
        idct2(&b, n, &c, &mut y);
        assert!(y.iter().all(|v| (v - 2.0).abs() < 1e-12));
    }

    /// Worked by hand from the lifting steps: x = (1, 2, 3, 4). Level 1: d₁ = 2 − (1 + 3)/2 =
    /// 0, d₃ = 4 − (3 + 3)/2 = 1 (x₄ = x₂); s₀ = 1 + (0 + 0)/4 = 1, s₂ = 3 + (0 + 1)/4 = 3.25.
    /// Level 2 on (1, 3.25): d = 3.25 − (1 + 1)/2 = 2.25, s = 1 + (2.25 + 2.25)/4 = 2.125.
    #[test]
    fn the_wavelet_is_the_lifting_worked_by_hand() {
        let mut x = [1.0, 2.0, 3.0, 4.0];
        wavelet_forward(&mut x);
        assert_eq!(x, [2.125, 2.25, 0.0, 1.0]);
        wavelet_inverse(&mut x);
        assert_eq!(x, [1.0, 2.0, 3.0, 4.0]);
        // Odd length 5: level 1 (5 → 3 + 2), level 2 (3 → 2 + 1), level 3 (2 → 1 + 1).
        assert_eq!(wavelet_bands(5), vec![0, 1, 2, 3, 3]);
        assert_eq!(wavelet_bands(64)[..8], [0; 8]);
        assert_eq!(wavelet_bands(64)[8..16], [1; 8]);
        assert_eq!(wavelet_bands(64)[32..], [3; 32]);
        assert_eq!(wavelet_bands(2), vec![0, 1]);
    }

    #[test]
    fn wavelet_bases_are_inverses_with_unit_synthesis_rows() {
        for n in [2usize, 3, 5, 8, 31, 32, 64] {
            let (s, a) = (wavelet_synthesis(n), wavelet_analysis(n));
            for i in 0..n {
                let norm: f64 = s[i * n..(i + 1) * n].iter().map(|v| v * v).sum();
                assert!((norm - 1.0).abs() < 1e-12, "{n} {i}");
                for j in 0..n {
                    // Σ_x analysis[i][x]·synthesis[j][x] = δ_ij.
                    let d: f64 = (0..n).map(|x| a[i * n + x] * s[j * n + x]).sum();
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((d - want).abs() < 1e-12, "{n} {i} {j}: {d}");
                }
            }
            let mut o = band_order(n);
            assert_eq!(o[0], 0);
            o.sort();
            assert_eq!(o, (0..n * n).collect::<Vec<_>>());
        }
        // Round trip of a table through dct2/idct2 with the wavelet's bases.
        let n = 6;
        let x: Vec<f64> = (0..n * n).map(|i| ((i * 37) % 11) as f64 - 3.5).collect();
        let (mut c, mut y) = (vec![0.0; n * n], vec![0.0; n * n]);
        let t = TableTransform::Wavelet53;
        dct2(&t.analysis(n), n, &x, &mut c);
        idct2(&t.synthesis(n), n, &c, &mut y);
        for (a, b) in x.iter().zip(&y) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        // A constant table has its only coefficient at (0, 0).
        let ones = vec![1.0; n * n];
        dct2(&t.analysis(n), n, &ones, &mut c);
        assert!(c[1..].iter().all(|v| v.abs() < 1e-12), "{c:?}");
    }

    #[test]
    fn diagonal_order_is_a_permutation_by_frequency() {
        let o = diagonal_order(4);
        assert_eq!(&o[..6], &[0, 1, 4, 2, 5, 8]);
        let mut s = o.clone();
        s.sort();
        assert_eq!(s, (0..16).collect::<Vec<_>>());
    }
}
