//! The kernel's steps over lanes that are its own: the frame step and the collapse of a
//! record's stored values at the wavelength's basis values. The lobe formulas are
//! `model::lobes`'s, written once for one number and for lanes.

use super::{Frame, KRec, AMPS};
use crate::model::angles::{azimuth_rotation, polar_lanes, rotate_about_z, unit_lanes};
use crate::model::lanes::{Lanes, Mask};

/// The frame step for N pairs (`lattice::upper`, then `Evaluator::query_frame`'s rotation, in
/// lanes).
#[inline(always)]
pub(super) fn frame<const N: usize>(wi: [[f32; 3]; N], wo: [[f32; 3]; N]) -> Frame<N> {
    let (wi, vi) = unit_upper(wi);
    let (wo, vo) = unit_upper(wo);
    let (r, c, s) = azimuth_rotation(wi);
    Frame {
        valid: vi.and(vo),
        r,
        z: wi[2],
        theta: polar_lanes(r, wi[2]),
        wo: rotate_about_z(wo, (c, s)),
    }
}

/// N binary32 vectors widened and normalised (`lattice::unit`), and where that worked and the
/// vector is on or above the surface (`lattice::upper`).
#[inline(always)]
fn unit_upper<const N: usize>(v: [[f32; 3]; N]) -> ([Lanes<N>; 3], Mask<N>) {
    let v: [Lanes<N>; 3] = std::array::from_fn(|c| Lanes(std::array::from_fn(|j| v[j][c] as f64)));
    let (u, ok) = unit_lanes(v);
    (u, ok.and(u[2].ge(Lanes::splat(0.0))))
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
