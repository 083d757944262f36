//! The continuous marginal/conditional warp of a bilinear density on [0, 1]² (the
//! parameterisation of Dupuy & Jakob 2018: each incidence's VNDF table is such a density), run
//! forward to place the stored grid nodes and backward to evaluate between them.

pub(super) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Bilinear interpolation of `g[y * w + x]` over [0, 1]², nodes at i/(n−1) (Mitsuba's
/// unnormalised `Marginal2D::eval`). Needs w, h ≥ 2 and g.len() ≥ w·h.
pub(super) fn bilerp(g: &[f32], w: usize, h: usize, x: f64, y: f64) -> f64 {
    let fx = x.clamp(0.0, 1.0) * (w - 1) as f64;
    let fy = y.clamp(0.0, 1.0) * (h - 1) as f64;
    let ix = (fx.floor() as usize).min(w - 2);
    let iy = (fy.floor() as usize).min(h - 2);
    let (tx, ty) = (fx - ix as f64, fy - iy as f64);
    let v = |yy: usize, xx: usize| g[yy * w + xx] as f64;
    lerp(
        lerp(v(iy, ix), v(iy, ix + 1), tx),
        lerp(v(iy + 1, ix), v(iy + 1, ix + 1), tx),
        ty,
    )
}

/// The τ ∈ [0, 1] with ∫₀^τ lerp(v0, v1, t) dt = a, for a linear density on one patch.
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

/// Continuous marginal/conditional warp of a bilinearly interpolated density `d[y][x]` on
/// [0, 1]²: `sample` maps the unit square onto the density (rows from the marginal over y,
/// then x from the conditional at that y), `invert` is its inverse. All tables normalised.
#[derive(Debug, Clone)]
pub(super) struct Warp2 {
    w: usize,
    h: usize,
    d: Vec<f64>,
    /// cond[y*w + j]: ∫₀^{x_j} d(x, y_row) dx.
    cond: Vec<f64>,
    /// rows[y] = cond[y*w + w-1].
    rows: Vec<f64>,
    /// marg[i] = ∫₀^{y_i} rows(y) dy (rows linear in y).
    marg: Vec<f64>,
}

impl Warp2 {
    /// Needs w, h ≥ 2, data.len() == w·h, values finite and ≥ 0 (checked by the loader);
    /// fails if the density integrates to zero.
    pub(super) fn new(data: &[f32], w: usize, h: usize) -> Option<Warp2> {
        let d: Vec<f64> = data.iter().map(|&v| v as f64).collect();
        let (sx, sy) = (0.5 / (w - 1) as f64, 0.5 / (h - 1) as f64);
        let mut cond = vec![0.0; w * h];
        let mut rows = vec![0.0; h];
        for y in 0..h {
            let mut acc = 0.0;
            for x in 1..w {
                acc += sx * (d[y * w + x - 1] + d[y * w + x]);
                cond[y * w + x] = acc;
            }
            rows[y] = acc;
        }
        let mut marg = vec![0.0; h];
        for y in 1..h {
            marg[y] = marg[y - 1] + sy * (rows[y - 1] + rows[y]);
        }
        let total = marg[h - 1];
        if !(total.is_finite() && total > 0.0) {
            return None;
        }
        let inv = 1.0 / total;
        let scale = |v: &mut Vec<f64>| v.iter_mut().for_each(|x| *x *= inv);
        let (mut d, mut cond, mut rows, mut marg) = (d, cond, rows, marg);
        scale(&mut d);
        scale(&mut cond);
        scale(&mut rows);
        scale(&mut marg);
        Some(Warp2 {
            w,
            h,
            d,
            cond,
            rows,
            marg,
        })
    }

    /// First interval k ∈ [0, n−2] whose upper CDF value reaches s.
    fn interval(n: usize, s: f64, cdf_at: impl Fn(usize) -> f64) -> usize {
        let (mut lo, mut hi) = (0usize, n - 1); // search k+1 in [1, n-1]
        while lo + 1 < hi {
            let mid = (lo + hi) / 2; // candidate upper node
            if cdf_at(mid) < s {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // hi is the first upper node with cdf ≥ s (or n−1)
        (hi - 1).min(n - 2)
    }

    pub(super) fn sample(&self, sx: f64, sy: f64) -> (f64, f64) {
        let (w, h) = (self.w, self.h);
        let (sx, sy) = (sx.clamp(0.0, 1.0), sy.clamp(0.0, 1.0));
        let row = Self::interval(h, sy, |k| self.marg[k]);
        let (r0, r1) = (self.rows[row], self.rows[row + 1]);
        let ty = solve_segment((sy - self.marg[row]) * (h - 1) as f64, r0, r1);
        let target = sx * lerp(r0, r1, ty);
        let crow = |j: usize| lerp(self.cond[row * w + j], self.cond[(row + 1) * w + j], ty);
        let col = Self::interval(w, target, crow);
        let dd = |yy: usize, xx: usize| self.d[yy * w + xx];
        let c0 = lerp(dd(row, col), dd(row + 1, col), ty);
        let c1 = lerp(dd(row, col + 1), dd(row + 1, col + 1), ty);
        let tx = solve_segment((target - crow(col)) * (w - 1) as f64, c0, c1);
        (
            (col as f64 + tx) / (w - 1) as f64,
            (row as f64 + ty) / (h - 1) as f64,
        )
    }

    pub(super) fn invert(&self, ux: f64, uy: f64) -> (f64, f64) {
        let (w, h) = (self.w, self.h);
        let fx = ux.clamp(0.0, 1.0) * (w - 1) as f64;
        let fy = uy.clamp(0.0, 1.0) * (h - 1) as f64;
        let px = (fx.floor() as usize).min(w - 2);
        let py = (fy.floor() as usize).min(h - 2);
        let (tx, ty) = (fx - px as f64, fy - py as f64);
        let dd = |yy: usize, xx: usize| self.d[yy * w + xx];
        let c0 = lerp(dd(py, px), dd(py + 1, px), ty);
        let c1 = lerp(dd(py, px + 1), dd(py + 1, px + 1), ty);
        let within_x = tx * (c0 + 0.5 * (c1 - c0) * tx) / (w - 1) as f64;
        let before_x = lerp(self.cond[py * w + px], self.cond[(py + 1) * w + px], ty);
        let (r0, r1) = (self.rows[py], self.rows[py + 1]);
        let row_total = lerp(r0, r1, ty);
        let sx = if row_total > 0.0 {
            (before_x + within_x) / row_total
        } else {
            0.0
        };
        let sy = self.marg[py] + ty * (r0 + 0.5 * (r1 - r0) * ty) / (h - 1) as f64;
        (sx.clamp(0.0, 1.0), sy.clamp(0.0, 1.0))
    }
}
