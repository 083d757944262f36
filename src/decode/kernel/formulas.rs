//! The kernel's steps over lanes that are its own: the frame step and the collapse of a
//! record's stored values at the wavelength's basis values. The lobe formulas are
//! `model::lobes`'s, written once for one number and for lanes.

use crate::model::angles::{azimuth_rotation, polar_lanes, rotate_about_z, unit_lanes};
use crate::model::lanes::{Lanes, Mask};

/// The most lobes a record on the kernel's route holds.
pub(super) const LINE_LOBES: usize = 2;
/// A record's lobe amplitudes at one wavelength: per lobe position, its variants' (one for a
/// cosine power, four otherwise), four slots each.
pub(super) const AMPS: usize = 4 * LINE_LOBES;
/// A record as the kernel reads it: offsets of its SH rows and of each lobe position's
/// amplitudes (into `vals`) and parameters (into `params`, `ln_params`), its terms, SH count
/// and each lobe position's variant count (0: no lobe there).
#[derive(Debug, Clone, Copy)]
pub(super) struct KernelRecord {
    pub sh: u32,
    pub amp: [u32; LINE_LOBES],
    pub par: [u32; LINE_LOBES],
    pub terms: u8,
    pub p: u8,
    pub nv: [u8; LINE_LOBES],
}

/// A pair's vectors after the frame step: valid when both are unit-normalisable and on or above
/// the surface; the incident vector's horizontal length and height, its θ (degrees), and the
/// outgoing vector rotated into the records' frame.
#[derive(Debug, Clone, Copy)]
pub(super) struct Frame<const N: usize> {
    pub valid: Mask<N>,
    pub r: Lanes<N>,
    pub z: Lanes<N>,
    pub theta: Lanes<N>,
    pub wo: [Lanes<N>; 3],
}

impl<const N: usize> Frame<N> {
    /// Lane j alone.
    #[inline(always)]
    pub(super) fn lane(&self, j: usize) -> Frame<1> {
        let l = |v: Lanes<N>| Lanes([v.0[j]]);
        Frame {
            valid: Mask([self.valid.0[j]]),
            r: l(self.r),
            z: l(self.z),
            theta: l(self.theta),
            wo: self.wo.map(l),
        }
    }
}

/// Lanes gathered from one-lane frames.
#[inline(always)]
pub(super) fn gather<const N: usize>(f: [&Frame<1>; N]) -> Frame<N> {
    let l = |g: fn(&Frame<1>) -> Lanes<1>| Lanes(std::array::from_fn(|j| g(f[j]).0[0]));
    Frame {
        valid: Mask(std::array::from_fn(|j| f[j].valid.0[0])),
        r: l(|f| f.r),
        z: l(|f| f.z),
        theta: l(|f| f.theta),
        wo: [l(|f| f.wo[0]), l(|f| f.wo[1]), l(|f| f.wo[2])],
    }
}

/// The frame step for N pairs (`lattice::unit_above`, then `Incidences::query_frame`'s rotation, in
/// lanes).
#[inline(always)]
pub(super) fn frame<const N: usize>(wi: [[f32; 3]; N], wo: [[f32; 3]; N]) -> Frame<N> {
    let (wi, vi) = unit_above_lanes(wi);
    let (wo, vo) = unit_above_lanes(wo);
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
/// vector is on or above the surface (`lattice::unit_above`).
#[inline(always)]
fn unit_above_lanes<const N: usize>(v: [[f32; 3]; N]) -> ([Lanes<N>; 3], Mask<N>) {
    let v: [Lanes<N>; 3] = std::array::from_fn(|c| Lanes(std::array::from_fn(|j| v[j][c] as f64)));
    let (u, ok) = unit_lanes(v);
    (u, ok.and(u[2].ge(Lanes::splat(0.0))))
}

/// Record k's SH coefficients at basis values `b` into `a` (as many as fit):
/// ã_j = Σ_k B_k·a_kj, k in order from 0.
#[inline(always)]
pub(super) fn collapse_sh(vals: &[f32], k: &KernelRecord, b: &[f64], a: &mut [f64]) {
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
pub(super) fn collapse_amps(vals: &[f32], k: &KernelRecord, b: &[f64], amps: &mut [f64; AMPS]) {
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
