//! The kernel's formulas over lanes: the frame step, the cosine power and the microfacet
//! geometry and variants, each lane the scalar formula of `spec/EVALUATION.md` ("Lobes") as
//! `model::lobes` computes it.

use super::{Frame, KRec, AMPS, MIN_COS};
use crate::model::angles::polar_lanes;
use crate::model::lanes::{Lanes, Mask};

/// The frame step for N pairs (`lattice::upper`, then `Evaluator::query_frame`'s rotation, in
/// lanes).
#[inline(always)]
pub(super) fn frame<const N: usize>(wi: [[f32; 3]; N], wo: [[f32; 3]; N]) -> Frame<N> {
    let (wi, vi) = unit_upper(wi);
    let (wo, vo) = unit_upper(wo);
    let r = (wi[0] * wi[0] + wi[1] * wi[1]).sqrt();
    let theta = polar_lanes(r, wi[2]);
    let positive = r.gt(Lanes::splat(0.0));
    let inv = 1.0 / Lanes::select(positive, r, Lanes::splat(1.0));
    let c = Lanes::select(positive, wi[0] * inv, Lanes::splat(1.0));
    let s = Lanes::select(positive, wi[1] * inv, Lanes::splat(0.0));
    Frame {
        valid: vi.and(vo),
        r,
        z: wi[2],
        theta,
        wo: [c * wo[0] + s * wo[1], -s * wo[0] + c * wo[1], wo[2]],
    }
}

/// N binary32 vectors widened and normalised with one reciprocal (`lattice::unit`), and where
/// that worked and the vector is on or above the surface (`lattice::upper`).
#[inline(always)]
fn unit_upper<const N: usize>(v: [[f32; 3]; N]) -> ([Lanes<N>; 3], Mask<N>) {
    let v: [Lanes<N>; 3] = std::array::from_fn(|c| Lanes(std::array::from_fn(|j| v[j][c] as f64)));
    let n = dot(v, v).sqrt();
    let ok = n.finite().and(n.gt(Lanes::splat(0.0)));
    let s = 1.0 / Lanes::select(ok, n, Lanes::splat(1.0));
    let u = v.map(|c| c * s);
    (u, ok.and(u[2].ge(Lanes::splat(0.0))))
}

#[inline(always)]
pub(super) fn dot<const N: usize>(a: [Lanes<N>; 3], b: [Lanes<N>; 3]) -> Lanes<N> {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// g^n for g = wo·peak capped at 1, as exp(n·ln g); 0 where g ≤ 0.
#[inline(always)]
pub(super) fn cosine_power<const N: usize>(
    n: Lanes<N>,
    wo: [Lanes<N>; 3],
    peak: [Lanes<N>; 3],
) -> Lanes<N> {
    let g = dot(wo, peak).min(Lanes::splat(1.0));
    let positive = g.gt(Lanes::splat(0.0));
    let v = (n * Lanes::select(positive, g, Lanes::splat(1.0)).ln()).exp();
    Lanes::select(positive, v, Lanes::splat(0.0))
}

/// What the microfacet variants share at one pair of directions, in lanes (the formulas of
/// `model::lobes::MicrofacetGeometry`); `ok` is false where wi + wo vanishes (every variant 0).
#[derive(Debug, Clone, Copy)]
pub(super) struct Geometry<const N: usize> {
    ok: Mask<N>,
    one_minus_ch: Lanes<N>,
    sin2_h: Lanes<N>,
    ci: Lanes<N>,
    co: Lanes<N>,
    vc: Lanes<N>,
    f: Lanes<N>,
}

impl<const N: usize> Geometry<N> {
    #[inline(always)]
    pub(super) fn new(wi: [Lanes<N>; 3], wo: [Lanes<N>; 3]) -> Self {
        let sum = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n2 = dot(sum, sum);
        let ok = n2.gt(Lanes::splat(0.0)).and(n2.finite());
        let inv = 1.0 / Lanes::select(ok, n2, Lanes::splat(1.0)).sqrt();
        let h = sum.map(|c| c * inv);
        let (zero, one, min) = (Lanes::splat(0.0), Lanes::splat(1.0), Lanes::splat(MIN_COS));
        let ch = h[2].max(zero).min(one);
        let cd = dot(wi, h).max(min).min(one);
        let ci = wi[2].max(min);
        let co = wo[2].max(min);
        let m = 2.0 * ch / cd;
        let vc = (m * co).min(m * ci).min(one) / (ci * co);
        let g = 1.0 - cd;
        let g2 = g * g;
        Geometry {
            ok,
            one_minus_ch: 1.0 - ch,
            sin2_h: 1.0 - ch * ch,
            ci,
            co,
            vc,
            f: g2 * g2 * g,
        }
    }

    /// [D·Vs, D·Vs·F, D·Vc, D·Vc·F] for parameters b, c, a.
    #[inline(always)]
    pub(super) fn variants(
        &self,
        b: Lanes<N>,
        c: Lanes<N>,
        a: Lanes<N>,
        sin2: bool,
    ) -> [Lanes<N>; 4] {
        let x = if sin2 { self.sin2_h } else { self.one_minus_ch };
        let d = (-c * (1.0 + b * x).ln()).exp();
        let (ci, co) = (self.ci, self.co);
        let a2 = a * a;
        let vs = 1.0
            / (co * (a2 + (1.0 - a2) * ci * ci).sqrt() + ci * (a2 + (1.0 - a2) * co * co).sqrt());
        let zero = Lanes::splat(0.0);
        [d * vs, d * vs * self.f, d * self.vc, d * self.vc * self.f]
            .map(|v| Lanes::select(self.ok, v, zero))
    }
}

/// Record k's SH coefficients at basis values `b` into `a` (as many as fit):
/// ã_j = Σ_k B_k·a_kj, k in order from 0.
#[inline(always)]
pub(super) fn collapse_sh(vals: &[f32], k: &KRec, b: &[f64], a: &mut [f64]) {
    let (stride, t) = (k.p as usize, (k.terms as usize).min(b.len()));
    let p = stride.min(a.len());
    let a = &mut a[..p];
    a.fill(0.0);
    for (i, &bk) in b[..t].iter().enumerate() {
        let at = k.sh as usize + i * stride;
        for (x, &v) in a.iter_mut().zip(&vals[at..at + p]) {
            *x += bk * v as f64;
        }
    }
}

/// Record k's lobe amplitudes at basis values `b`, per lobe position its variants', each
/// Σ_k B_k·v_k in order from k = 0.
#[inline(always)]
pub(super) fn collapse_amps(vals: &[f32], k: &KRec, b: &[f64], amps: &mut [f64; AMPS]) {
    let t = (k.terms as usize).min(b.len());
    for (li, amps) in amps.chunks_exact_mut(4).enumerate() {
        let nv = (k.nv[li] as usize).min(4);
        let at = k.amp[li] as usize;
        for (v, row) in amps[..nv]
            .iter_mut()
            .zip(vals[at..at + nv * t].chunks_exact(t.max(1)))
        {
            let mut d = 0.0;
            for (&bk, &x) in b.iter().zip(row) {
                d += bk * x as f64;
            }
            *v = d;
        }
    }
}
