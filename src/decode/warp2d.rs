//! The continuous marginal/conditional warp of a bilinearly interpolated density on [0, 1]²,
//! one per stored incidence, blended between two of them as Mitsuba's `Marginal2D` blends its
//! parameter slices (`spec/EVALUATION.md`, "Warped tables", "The warp"). Warped tables use two:
//! the VNDF's (G × G, placing the tables' nodes) and the tables' own spectrum-averaged values'
//! (R × R, for importance sampling).

/// The blend of two slices: index `a` weighted 1 − t, `b` weighted t.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Slices {
    pub a: usize,
    pub b: usize,
    pub t: f64,
}

impl Slices {
    #[inline]
    fn mix(&self, v: &[f64], stride: usize, at: usize) -> f64 {
        let x = v[self.a * stride + at];
        let y = v[self.b * stride + at];
        x + (y - x) * self.t
    }
}

/// Normalised densities on n × n nodes (rows along y) of several slices, with their
/// conditional integrals, row totals and marginals.
#[derive(Debug, Clone)]
pub(crate) struct Warp {
    n: usize,
    p: Vec<f64>,
    cond: Vec<f64>,
    row: Vec<f64>,
    marg: Vec<f64>,
}

impl Warp {
    /// Builds the warp of each slice of `densities` (n² non-negative values each, unnormalised);
    /// `None` when a slice's total (the trapezoid integral of its bilinear interpolation) is not
    /// positive and finite.
    pub(crate) fn new(n: usize, densities: &[f64]) -> Option<Self> {
        let slices = densities.len() / (n * n);
        let (mut p, mut cond) = (Vec::with_capacity(densities.len()), Vec::new());
        cond.reserve(densities.len());
        let (mut row, mut marg) = (
            Vec::with_capacity(slices * n),
            Vec::with_capacity(slices * n),
        );
        let half = 0.5 / (n - 1) as f64;
        for d in densities.chunks_exact(n * n) {
            let total = total(d, n);
            if !(total > 0.0 && total.is_finite()) {
                return None;
            }
            let inv = 1.0 / total;
            let start = p.len();
            p.extend(d.iter().map(|v| v * inv));
            let d = &p[start..];
            let mut rows = vec![0.0; n];
            for b in 0..n {
                let mut acc = 0.0;
                cond.push(0.0);
                for a in 1..n {
                    acc += half * (d[b * n + a - 1] + d[b * n + a]);
                    cond.push(acc);
                }
                rows[b] = acc;
            }
            let mut mg = 0.0;
            marg.push(0.0);
            for b in 1..n {
                mg += half * (rows[b - 1] + rows[b]);
                marg.push(mg);
            }
            row.extend_from_slice(&rows);
        }
        Some(Warp {
            n,
            p,
            cond,
            row,
            marg,
        })
    }

    pub(crate) fn heap_bytes(&self) -> usize {
        8 * (self.p.capacity() + self.cond.capacity() + self.row.capacity() + self.marg.capacity())
    }

    /// The cell of x ∈ [0, 1] (clamped) on n nodes and the position within it.
    #[inline]
    fn cell(&self, x: f64) -> (usize, f64) {
        let f = x.clamp(0.0, 1.0) * (self.n - 1) as f64;
        let i = (f.floor() as usize).min(self.n - 2);
        (i, f - i as f64)
    }

    /// The inverse warp: a point u of the density's square → the uniform point s.
    #[inline]
    pub(crate) fn invert(&self, sl: Slices, ux: f64, uy: f64) -> (f64, f64) {
        let (n, nn) = (self.n, self.n * self.n);
        let n1 = (n - 1) as f64;
        let (a, tx) = self.cell(ux);
        let (b, ty) = self.cell(uy);
        let p = |bb: usize, aa: usize| sl.mix(&self.p, nn, bb * n + aa);
        let c0 = lerp(p(b, a), p(b + 1, a), ty);
        let c1 = lerp(p(b, a + 1), p(b + 1, a + 1), ty);
        let before = lerp(
            sl.mix(&self.cond, nn, b * n + a),
            sl.mix(&self.cond, nn, (b + 1) * n + a),
            ty,
        );
        let within = tx * (c0 + 0.5 * (c1 - c0) * tx) / n1;
        let (r0, r1) = (sl.mix(&self.row, n, b), sl.mix(&self.row, n, b + 1));
        let total = lerp(r0, r1, ty);
        let sx = if total > 0.0 {
            (before + within) / total
        } else {
            0.0
        };
        let sy = sl.mix(&self.marg, n, b) + ty * (r0 + 0.5 * (r1 - r0) * ty) / n1;
        (sx.clamp(0.0, 1.0), sy.clamp(0.0, 1.0))
    }

    /// The blended, normalised density at (x, y).
    #[inline]
    pub(crate) fn density(&self, sl: Slices, x: f64, y: f64) -> f64 {
        let (n, nn) = (self.n, self.n * self.n);
        bilerp(n, x, y, |b, a| sl.mix(&self.p, nn, b * n + a))
    }

    /// The forward warp: a uniform point (sx, sy) → a point of the density's square.
    pub(crate) fn sample(&self, sl: Slices, sx: f64, sy: f64) -> (f64, f64) {
        let (n, nn) = (self.n, self.n * self.n);
        let n1 = (n - 1) as f64;
        let (sx, sy) = (sx.clamp(0.0, 1.0), sy.clamp(0.0, 1.0));
        let marg = |b: usize| sl.mix(&self.marg, n, b);
        let b = interval(n, sy, marg);
        let (r0, r1) = (sl.mix(&self.row, n, b), sl.mix(&self.row, n, b + 1));
        let ty = solve_segment((sy - marg(b)) * n1, r0, r1);
        let target = sx * lerp(r0, r1, ty);
        let crow = |a: usize| {
            lerp(
                sl.mix(&self.cond, nn, b * n + a),
                sl.mix(&self.cond, nn, (b + 1) * n + a),
                ty,
            )
        };
        let a = interval(n, target, crow);
        let p = |bb: usize, aa: usize| sl.mix(&self.p, nn, bb * n + aa);
        let c0 = lerp(p(b, a), p(b + 1, a), ty);
        let c1 = lerp(p(b, a + 1), p(b + 1, a + 1), ty);
        let tx = solve_segment((target - crow(a)) * n1, c0, c1);
        ((a as f64 + tx) / n1, (b as f64 + ty) / n1)
    }
}

/// The trapezoid integral of n × n nodes over [0, 1]² (rows of a, then over b): the integral of
/// their bilinear interpolation.
pub(crate) fn total(d: &[f64], n: usize) -> f64 {
    let w = |i: usize| {
        if i == 0 || i == n - 1 {
            0.5 / (n - 1) as f64
        } else {
            1.0 / (n - 1) as f64
        }
    };
    // Four rows at a time, each summed in order from −0.0 as `Iterator::sum` does: the same
    // roundings as one row after another, but four independent chains instead of one (no
    // allocation: warped decoders are opened where renderers load scenes).
    if n == 0 {
        return -0.0;
    }
    let quads = d[..n * n].chunks_exact(4 * n);
    let rest = quads.remainder();
    let mut sum = -0.0;
    for (q, quad) in quads.enumerate() {
        let mut acc = [-0.0f64; 4];
        for a in 0..n {
            let wa = w(a);
            for (r, acc) in acc.iter_mut().enumerate() {
                *acc += wa * quad[r * n + a];
            }
        }
        for (r, acc) in acc.into_iter().enumerate() {
            sum += w(4 * q + r) * acc;
        }
    }
    let first = n - rest.len() / n;
    for (r, row) in rest.chunks_exact(n).enumerate() {
        sum += w(first + r) * (0..n).map(|a| w(a) * row[a]).sum::<f64>();
    }
    sum
}

/// Bilinear interpolation of n × n nodes `at(row, column)` (rows along y) at (x, y) ∈ [0, 1]²,
/// clamped to the square; at 1 the last cell is used.
#[inline]
pub(crate) fn bilerp(n: usize, x: f64, y: f64, at: impl Fn(usize, usize) -> f64) -> f64 {
    let cell = |v: f64| {
        let f = v.clamp(0.0, 1.0) * (n - 1) as f64;
        let i = (f.floor() as usize).min(n - 2);
        (i, f - i as f64)
    };
    let (a, tx) = cell(x);
    let (b, ty) = cell(y);
    lerp(
        lerp(at(b, a), at(b, a + 1), tx),
        lerp(at(b + 1, a), at(b + 1, a + 1), tx),
        ty,
    )
}

#[inline]
pub(crate) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_and_invert_are_inverses_and_the_density_integrates_to_one() {
        let n = 5;
        let d: Vec<f64> = (0..2 * n * n).map(|i| 0.2 + ((i * 7) % 5) as f64).collect();
        let w = Warp::new(n, &d).unwrap();
        let sl = Slices { a: 0, b: 1, t: 0.3 };
        for &(sx, sy) in &[(0.1, 0.2), (0.5, 0.5), (0.93, 0.07), (0.0, 1.0)] {
            let (ux, uy) = w.sample(sl, sx, sy);
            let (bx, by) = w.invert(sl, ux, uy);
            assert!(
                (bx - sx).abs() < 1e-9 && (by - sy).abs() < 1e-9,
                "{sx},{sy}"
            );
        }
        let m = 400;
        let mut acc = 0.0;
        for i in 0..m {
            for j in 0..m {
                let (x, y) = ((i as f64 + 0.5) / m as f64, (j as f64 + 0.5) / m as f64);
                acc += w.density(sl, x, y) / (m * m) as f64;
            }
        }
        assert!((acc - 1.0).abs() < 1e-3, "{acc}");
    }
}

#[cfg(test)]
mod total_tests {
    #[test]
    fn total_matches_the_row_by_row_sum() {
        let reference = |d: &[f64], n: usize| -> f64 {
            let w = |i: usize| {
                if i == 0 || i == n - 1 {
                    0.5 / (n - 1) as f64
                } else {
                    1.0 / (n - 1) as f64
                }
            };
            (0..n)
                .map(|b| w(b) * (0..n).map(|a| w(a) * d[b * n + a]).sum::<f64>())
                .sum()
        };
        let mut x = 0.123_f64;
        assert_eq!(super::total(&[], 0).to_bits(), (-0.0f64).to_bits());
        for n in 1..20 {
            let d: Vec<f64> = (0..n * n)
                .map(|_| {
                    x = (x * 997.0 + 0.31).fract();
                    x * x * 1e3
                })
                .collect();
            assert_eq!(
                super::total(&d, n).to_bits(),
                reference(&d, n).to_bits(),
                "n = {n}"
            );
            let zeros = vec![-0.0; n * n];
            assert_eq!(
                super::total(&zeros, n).to_bits(),
                reference(&zeros, n).to_bits()
            );
        }
    }
}
