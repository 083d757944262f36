//! Evaluation and sampling of warped tables (`spec/EVALUATION.md`, "Warped tables"): the
//! tables decoded once at open, the VNDF warp of every stored incidence and the σ nodes rebuilt
//! from the stored NDF, then per query the inverse warp of the half vector, blended between the
//! two stored incidences around θi as Mitsuba's `measured` plugin blends its slices.

use super::draw::{uniforms, Sample, MIN_COSINE_WEIGHT};
use super::lattice::{upper, QueryFrame};
use super::warp2d::{bilerp, total, Slices, Warp};
use crate::model::angles::azimuth_rotation;
use crate::model::warped::{half_vector, jacobian, lerp_nodes, ndf_at, WarpedModel};
use std::f64::consts::{FRAC_PI_2, PI};

/// The share of cosine-weighted hemisphere sampling in the proposal (as for records:
/// [`MIN_COSINE_WEIGHT`]): the density stays positive wherever cos θo > 0.
const COSINE_SHARE: f64 = MIN_COSINE_WEIGHT;

/// A warped-table material ready for queries.
#[derive(Debug, Clone)]
pub(crate) struct WarpedEval {
    /// Table side R and terms K.
    r: usize,
    k: usize,
    /// Stored incidences θ_i (radians), increasing.
    theta: Vec<f64>,
    ndf: Vec<f32>,
    /// σ at the M nodes x_j = j/(M−1) of √(θ/(π/2)).
    sigma: Vec<f64>,
    /// Tables (i, k) at (i·K + k)·R², row-major (rows along s_y). Binary64, as the spec asks of
    /// evaluation: in binary32 the inverse warp near the horizon moved values by up to 2·10⁻⁴.
    tables: Vec<f64>,
    /// Per stored incidence, the VNDF warp (G × G): where the tables' nodes lie.
    vndf: Warp,
    /// Per stored incidence, the warp of the tables' spectrum-averaged values (R × R, clamped
    /// at 0): importance sampling draws a node there first, as Mitsuba's `measured` draws from
    /// its luminance table, then maps it through the VNDF warp.
    values: Warp,
}

/// The per-node factor D(x_a)·sin θm·π x_a·2π and the half vectors of a G × G grid.
struct Grid {
    factor: Vec<f64>,
    /// The half vectors' x and z components (y is not needed), apart so that
    /// [`Grid::density`] runs in vector lanes.
    mx: Vec<f64>,
    mz: Vec<f64>,
    g: usize,
}

impl Grid {
    fn new(ndf: &[f32], g: usize) -> Self {
        let mut factor = Vec::with_capacity(g * g);
        let (mut mx, mut mz) = (Vec::with_capacity(g * g), Vec::with_capacity(g * g));
        let step = 1.0 / (g - 1) as f64;
        for b in 0..g {
            for a in 0..g {
                let (x, y) = (a as f64 * step, b as f64 * step);
                let (h, st) = half_vector(x, y);
                factor.push(ndf_at(ndf, x) * jacobian(x, st));
                mx.push(h[0]);
                mz.push(h[2]);
            }
        }
        Grid { factor, mx, mz, g }
    }

    /// The unnormalised VNDF density at incidence θ (radians) into `p`; returns its total
    /// (trapezoid rule, rows of a then over b).
    fn density(&self, theta: f64, p: &mut [f64]) -> f64 {
        let (s, c) = theta.sin_cos();
        for (((v, mx), mz), f) in p.iter_mut().zip(&self.mx).zip(&self.mz).zip(&self.factor) {
            *v = f * (s * mx + c * mz).max(0.0);
        }
        total(p, self.g)
    }
}

/// The VNDF totals I(θ) of `spec/EVALUATION.md`, "Warped tables", for an NDF on a G × G grid
/// at each θ (radians): what σ is c times (the encoder finds c from a measurement's own σ).
#[cfg(feature = "encode")]
pub(crate) fn vndf_totals(ndf: &[f32], g: usize, thetas: &[f64]) -> Vec<f64> {
    let grid = Grid::new(ndf, g);
    let mut p = vec![0.0; g * g];
    thetas.iter().map(|&t| grid.density(t, &mut p)).collect()
}

impl WarpedEval {
    /// Prepares a validated model for `thetas_deg` (HEAD's θi) and `k` terms. `None` when a
    /// stored incidence's VNDF or a σ node is zero (the reader refuses such files).
    pub(crate) fn new(
        w: &WarpedModel,
        thetas_deg: &[f32],
        k: usize,
        basis_means: &[f64],
    ) -> Option<Self> {
        let (g, n, m) = (w.warp_grid, thetas_deg.len(), w.ndf.len());
        let theta: Vec<f64> = thetas_deg
            .iter()
            .map(|&t| (t as f64).to_radians())
            .collect();
        let grid = Grid::new(&w.ndf, g);
        let mut scratch = vec![0.0; g * g];
        let mut sigma = Vec::with_capacity(m);
        for j in 0..m {
            let x = j as f64 / (m - 1) as f64;
            let total = grid.density(x * x * FRAC_PI_2, &mut scratch);
            let s = w.sigma_scale as f64 * total;
            if !(s > 0.0 && s.is_finite()) {
                return None;
            }
            sigma.push(s);
        }
        let mut densities = vec![0.0; n * g * g];
        for (&t, d) in theta.iter().zip(densities.chunks_exact_mut(g * g)) {
            grid.density(t, d);
        }
        let vndf = Warp::new(g, &densities)?;
        drop(densities);
        let tables = w.decode_tables();
        // Spectrum-averaged table values per node (the basis means weigh the terms), at 0 where
        // negative, plus a floor of 10⁻³ of the slice's mean so that no node the VNDF reaches
        // is left out of sampling (the cosine share covers the rest).
        let rr = w.grid * w.grid;
        let mut averaged = vec![0.0; n * rr];
        for (i, slice) in averaged.chunks_exact_mut(rr).enumerate() {
            for (p, v) in slice.iter_mut().enumerate() {
                let sum: f64 = (0..k)
                    .map(|t| tables[(i * k + t) * rr + p] * basis_means[t])
                    .sum();
                *v = sum.max(0.0);
            }
            let mean = slice.iter().sum::<f64>() / rr as f64;
            let floor = if mean > 0.0 { 1e-3 * mean } else { 1.0 };
            slice.iter_mut().for_each(|v| *v += floor);
        }
        let values = Warp::new(w.grid, &averaged)?;
        Some(WarpedEval {
            r: w.grid,

            k,
            theta,
            ndf: w.ndf.clone(),
            sigma,
            tables,
            vndf,
            values,
        })
    }

    pub(crate) fn heap_bytes(&self) -> usize {
        8 * (self.theta.capacity() + self.sigma.capacity() + self.tables.capacity())
            + 4 * self.ndf.capacity()
            + self.vndf.heap_bytes()
            + self.values.heap_bytes()
    }

    /// The stored incidences around θ (radians) and the weight of the upper one.
    #[inline]
    fn slices(&self, theta: f64) -> Slices {
        let n = self.theta.len();
        if n == 1 {
            return Slices { a: 0, b: 0, t: 0.0 };
        }
        let th = theta.clamp(self.theta[0], self.theta[n - 1]);
        let mut i = 0;
        while i + 2 < n && self.theta[i + 1] <= th {
            i += 1;
        }
        let t = (th - self.theta[i]) / (self.theta[i + 1] - self.theta[i]);
        Slices {
            a: i,
            b: i + 1,
            t: t.clamp(0.0, 1.0),
        }
    }

    /// The frame turned about z so that the tables' direction `wi` has azimuth 0 (none at the
    /// pole), and that direction's θ in radians.
    #[inline]
    fn frame(wi: [f64; 3]) -> (QueryFrame, f64) {
        let (r, c, s) = azimuth_rotation(wi);
        let theta = r.atan2(wi[2]);
        let q = QueryFrame {
            theta: theta.to_degrees(),
            phi: 0.0,
            wi: [r, 0.0, wi[2]],
            rotation: Some((c, s)),
        };
        (q, theta)
    }

    /// The blended table values v_k times D(u_x)/(4σ(θv))/cos θi: the spectral coefficients of
    /// ρ at unit vectors `wi` (toward the light), `wo` (toward the viewer), z ≥ 0, into `c` (K
    /// values). The tables are indexed by the viewing direction, as RGL files and Mitsuba's
    /// `measured` plugin index them (`spec/EVALUATION.md`, "Warped tables"): the roles of the two
    /// vectors are exchanged here. False (and `c` zero) where ρ is 0 (cos θi = 0, or
    /// ωi + ωo = 0).
    #[inline]
    pub(crate) fn coefficients(&self, wi: [f64; 3], wo: [f64; 3], c: &mut [f64]) -> bool {
        let c = &mut c[..self.k];
        c.fill(0.0);
        // The tables' own direction (the viewer's) first, the light's second.
        let (q, theta_i) = Self::frame(wo);
        let (wi, wo) = (q.wi, q.in_frame(wi));
        if wo[2] <= 0.0 {
            return false;
        }
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        if len.is_nan() || len <= 0.0 {
            return false;
        }
        let m = [h[0] / len, h[1] / len, h[2] / len];
        let theta_m = (m[0] * m[0] + m[1] * m[1]).sqrt().atan2(m[2]);
        let phi_m = m[1].atan2(m[0]);
        let ux = (theta_m / FRAC_PI_2).sqrt();
        let mut uy = (phi_m + PI) / (2.0 * PI);
        uy -= uy.floor();
        let sl = self.slices(theta_i);
        let (sx, sy) = self.vndf.invert(sl, ux, uy);
        let xi = (theta_i.max(0.0) / FRAC_PI_2).sqrt();
        let sigma = lerp_nodes(self.sigma.len(), xi, |j| self.sigma[j]);
        let f = ndf_at(&self.ndf, ux) / (4.0 * sigma) / wo[2];
        let rr = self.r * self.r;
        for (k, ck) in c.iter_mut().enumerate() {
            let ta = &self.tables[(sl.a * self.k + k) * rr..][..rr];
            let tb = &self.tables[(sl.b * self.k + k) * rr..][..rr];
            let va = bilerp(self.r, sx, sy, |b, a| ta[b * self.r + a]);
            let vb = bilerp(self.r, sx, sy, |b, a| tb[b * self.r + a]);
            *ck = (va + (vb - va) * sl.t) * f;
        }
        true
    }

    /// [`WarpedEval::coefficients`] in a stack buffer handed to `put` (all zero where ρ is 0).
    #[inline]
    pub(crate) fn with_coefficients(&self, wi: [f64; 3], wo: [f64; 3], put: impl FnOnce(&[f64])) {
        const SMALL: usize = 16;
        if self.k <= SMALL {
            let mut c = [0.0f64; SMALL];
            self.coefficients(wi, wo, &mut c);
            put(&c[..self.k]);
        } else {
            let mut c = [0.0f64; crate::model::material::MAX_TERMS];
            self.coefficients(wi, wo, &mut c);
            put(&c[..self.k]);
        }
    }

    /// Draws ωo for unit `wi` (z ≥ 0, the direction the sampler is given: the tables' own)
    /// from `u` ∈ [0, 1)²: with probability [`COSINE_SHARE`] a cosine-weighted direction, else
    /// the reflection of a half vector drawn from the blended VNDF warp, mirrored to the upper
    /// hemisphere (z → −z) when it falls below (so every draw counts; [`WarpedEval::pdf`] adds
    /// both ways of reaching a direction). `None` only for a degenerate draw (on the horizon).
    pub(crate) fn sample(&self, wi: [f64; 3], u: [f64; 2]) -> Option<[f64; 3]> {
        let (q, theta_i) = Self::frame(wi);
        let wi2 = q.wi;
        let mut local = if u[0] < COSINE_SHARE {
            let u0 = u[0] / COSINE_SHARE;
            let rad = u0.sqrt();
            let phi = 2.0 * PI * u[1];
            [rad * phi.cos(), rad * phi.sin(), (1.0 - u0).max(0.0).sqrt()]
        } else {
            let u0 = ((u[0] - COSINE_SHARE) / (1.0 - COSINE_SHARE)).min(1.0);
            let sl = self.slices(theta_i);
            let (sx, sy) = self.values.sample(sl, u0, u[1]);
            let (ux, uy) = self.vndf.sample(sl, sx, sy);
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

    /// The density (1/sr) with which [`WarpedEval::sample`] draws unit `wo` (z ≥ 0) for unit
    /// `wi`: the cosine share, plus the VNDF share at `wo` and at its mirror image below the
    /// horizon.
    pub(crate) fn pdf(&self, wi: [f64; 3], wo: [f64; 3]) -> f64 {
        let (q, theta_i) = Self::frame(wi);
        let (wi, wo) = (q.wi, q.in_frame(wo));
        if wo[2] <= 0.0 {
            return 0.0;
        }
        let sl = self.slices(theta_i);
        let below = [wo[0], wo[1], -wo[2]];
        let vndf = self.reflected_density(sl, wi, wo) + self.reflected_density(sl, wi, below);
        COSINE_SHARE * wo[2] / PI + (1.0 - COSINE_SHARE) * vndf
    }

    /// The density over ωo (any unit vector, the tables' frame) of reflecting `wi` about a half
    /// vector drawn from the blended warp: p(u)/J(u)/(4 ωo·m), 0 where m is below the horizon or
    /// faces away from ωo.
    fn reflected_density(&self, sl: Slices, wi: [f64; 3], wo: [f64; 3]) -> f64 {
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        if len.is_nan() || len <= 0.0 || h[2] < 0.0 {
            return 0.0;
        }
        let m = [h[0] / len, h[1] / len, h[2] / len];
        let sin_m = (m[0] * m[0] + m[1] * m[1]).sqrt();
        let theta_m = sin_m.atan2(m[2]);
        let ux = (theta_m / FRAC_PI_2).sqrt();
        let mut uy = (m[1].atan2(m[0]) + PI) / (2.0 * PI);
        uy -= uy.floor();
        let jac = jacobian(ux, sin_m);
        let dot = wo[0] * m[0] + wo[1] * m[1] + wo[2] * m[2];
        if jac > 0.0 && dot > 0.0 {
            // The density over u: the values' density at the warped point times the VNDF's.
            let (sx, sy) = self.vndf.invert(sl, ux, uy);
            self.values.density(sl, sx, sy) * self.vndf.density(sl, ux, uy) / jac / (4.0 * dot)
        } else {
            0.0
        }
    }
}

/// [`super::sampling::sample`] for warped tables (`spec/EVALUATION.md`, "Warped tables"): the density is
/// [`pdf_warped`] at the direction as returned.
pub(crate) fn sample_warped(w: &WarpedEval, wi: [f32; 3], u: [f32; 2]) -> Option<Sample> {
    let u = uniforms(u)?;
    let wi = upper(wi)?;
    let d = w.sample(wi, u)?;
    let wo = [d[0] as f32, d[1] as f32, d[2] as f32];
    let back = upper(wo)?;
    let pdf = w.pdf(wi, back) as f32;
    (pdf > 0.0 && pdf.is_finite()).then_some(Sample { wo, pdf })
}

/// [`super::sampling::pdf`] for warped tables.
pub(crate) fn pdf_warped(w: &WarpedEval, wi: [f32; 3], wo: [f32; 3]) -> f32 {
    let (Some(wi), Some(wo)) = (upper(wi), upper(wo)) else {
        return 0.0;
    };
    w.pdf(wi, wo) as f32
}
