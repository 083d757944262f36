//! Where a query falls among the stored incidences: its incident direction in the records'
//! frame, how the stored incidences are arranged (a θ line, a θ×φ grid, or scattered), and the
//! records to blend with their weights (`spec/EVALUATION.md`, "Between stored incidences").

use super::resident::Rec;
use crate::model::angles::{dir_from_deg, dot, rotate_about_z, unit_lanes};
use crate::model::lanes::Real;
use crate::model::material::Material;

/// A query's incident direction turned into the frame its records are stored in: for isotropic
/// files rotated about z so that its azimuth is 0 (`spec/EVALUATION.md`, "Reconstruction",
/// step 3).
#[derive(Debug, Clone, Copy)]
pub(crate) struct QueryFrame {
    /// θ and φ of the incident direction in that frame, degrees.
    pub theta: f64,
    pub phi: f64,
    /// The unit incident vector in that frame.
    pub wi: [f64; 3],
    /// (cos ψ, sin ψ) of the rotation by −ψ into the frame; None when there is none.
    pub rotation: Option<(f64, f64)>,
}

impl QueryFrame {
    /// A vector of the local frame in the records' frame.
    #[inline(always)]
    pub fn in_frame(self, v: [f64; 3]) -> [f64; 3] {
        match self.rotation {
            Some(rotation) => rotate_about_z(v, rotation),
            None => v,
        }
    }

    /// A vector of the records' frame back in the local frame.
    #[inline]
    pub fn out_of_frame(self, v: [f64; 3]) -> [f64; 3] {
        match self.rotation {
            Some((c, s)) => [c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]],
            None => v,
        }
    }
}

/// A single-precision vector widened and normalised with one reciprocal (a division per
/// component costs more); None when it is zero or not finite.
#[inline(always)]
pub(crate) fn unit(v: [f32; 3]) -> Option<[f64; 3]> {
    let (u, ok) = unit_lanes([v[0] as f64, v[1] as f64, v[2] as f64]);
    ok.then_some(u)
}

/// [`unit`] for a direction that must lie on or above the surface: None also below it (ρ = 0
/// there).
#[inline(always)]
pub(crate) fn unit_above(v: [f32; 3]) -> Option<[f64; 3]> {
    unit(v).filter(|u| u[2] >= 0.0)
}

/// How stored incidences are arranged, which decides how a query is interpolated.
#[derive(Debug, Clone)]
pub(crate) enum Lattice {
    /// Isotropic files: records in increasing θi, all at φi = 0; linear in θ.
    Theta(Axis),
    /// Every combination of some θ values and some φ values: bilinear, φ wrapping at 360°.
    /// The record of (θ_i, φ_j) is record i·phis.len() + j (the file's order).
    Grid { thetas: Axis, phis: Axis },
    /// Scattered incidences: the nearest stored one.
    Nearest,
}

/// Up to four records and their weights (summing to 1).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Blend {
    pub n: usize,
    pub rec: [usize; 4],
    pub w: [f64; 4],
}

impl Blend {
    pub(crate) fn one(r: usize) -> Self {
        Blend {
            n: 1,
            rec: [r, 0, 0, 0],
            w: [1.0, 0.0, 0.0, 0.0],
        }
    }
    pub(crate) fn push(&mut self, r: usize, w: f64) {
        if w <= 0.0 {
            return;
        }
        if let Some(i) = self.rec[..self.n].iter().position(|&x| x == r) {
            self.w[i] += w;
        } else {
            self.rec[self.n] = r;
            self.w[self.n] = w;
            self.n += 1;
        }
    }
}

/// Strictly increasing stored angles along one axis of the incidence lattice.
#[derive(Debug, Clone)]
pub(crate) struct Axis {
    pub(crate) xs: Vec<f64>,
    /// (n − 1)/(last − first): the cell of an evenly spaced axis (the usual one) is guessed with
    /// one multiplication, then checked; a search settles anything else.
    inv_step: f64,
    /// 1/(x_{i+1} − x_i) when every cell has the same width (exactly), else 0: the fraction is
    /// then a multiplication (equal to the division to rounding).
    inv_width: f64,
}

impl Axis {
    fn new(xs: Vec<f64>) -> Self {
        let n = xs.len();
        let inv_step = if n > 1 {
            (n - 1) as f64 / (xs[n - 1] - xs[0])
        } else {
            0.0
        };
        let uniform = n > 1 && xs.windows(2).all(|p| p[1] - p[0] == xs[1] - xs[0]);
        let inv_width = if uniform { 1.0 / (xs[1] - xs[0]) } else { 0.0 };
        Axis {
            xs,
            inv_step,
            inv_width,
        }
    }

    fn first(&self) -> f64 {
        self.xs[0]
    }

    fn last(&self) -> f64 {
        self.xs[self.xs.len() - 1]
    }

    /// Index i and fraction t with xs[i] ≤ x ≤ xs[i+1] (x clamped to the range).
    #[inline(always)]
    pub(crate) fn bracket(&self, x: f64) -> (usize, f64) {
        let xs = &self.xs;
        if xs.len() == 1 || x.is_nan() || x <= xs[0] {
            return (0, 0.0);
        }
        let last = xs.len() - 1;
        if x >= xs[last] {
            return (last - 1, 1.0);
        }
        // x > xs[0] here: as u32 converts in fewer instructions than as usize.
        let g = (((x - xs[0]) * self.inv_step) as u32 as usize).min(last - 1);
        let i = if xs[g] <= x && x < xs[g + 1] {
            g
        } else {
            xs.partition_point(|&v| v <= x) - 1
        };
        if self.inv_width > 0.0 {
            (i, (x - xs[i]) * self.inv_width)
        } else {
            (i, (x - xs[i]) / (xs[i + 1] - xs[i]))
        }
    }

    /// The records a query at `x` on a θ line blends: (first, None) for record `first` alone
    /// (at or beyond a stored θ), (first, Some(t)) for records first and first + 1 with weights
    /// (1 − t, t). Every route places a query on a θ line through this.
    #[inline(always)]
    pub(crate) fn neighbours(&self, x: f64) -> (usize, Option<f64>) {
        let (i, t) = self.bracket(x);
        if self.xs.len() == 1 || t <= 0.0 {
            (i, None)
        } else if 1.0 - t <= 0.0 {
            (i + 1, None)
        } else {
            (i, Some(t))
        }
    }
}

/// The incidence a query is evaluated at, as its horizontal length and height: its own (`r`,
/// `z`) inside the stored θ range, the end's sine and cosine where `below` (the first end) or
/// `above` (the last) holds (`ends`: each end's θ, sin θ, cos θ). Written once over [`Real`]:
/// one query and the kernel's lanes clamp through it.
#[inline(always)]
pub(crate) fn clamp_incidence<R: Real>(
    below: R::Mask,
    above: R::Mask,
    r: R,
    z: R,
    ends: &[(f64, f64, f64); 2],
) -> (R, R) {
    let [(_, s0, c0), (_, s1, c1)] = *ends;
    let pick = |lo: f64, hi: f64, own: R| {
        R::select(below, R::splat(lo), R::select(above, R::splat(hi), own))
    };
    (pick(s0, s1, r), pick(c0, c1, z))
}

/// Where polar angles `theta` (degrees) fall outside the stored range `ends`: below its first
/// end, above its last.
#[inline(always)]
pub(crate) fn outside<R: Real>(theta: R, ends: &[(f64, f64, f64); 2]) -> (R::Mask, R::Mask) {
    (R::splat(ends[0].0).gt(theta), theta.gt(R::splat(ends[1].0)))
}

impl Lattice {
    pub(crate) fn of(m: &Material) -> Lattice {
        let recs = &m.records;
        if m.isotropic {
            return Lattice::Theta(Axis::new(recs.iter().map(|r| r.theta_i as f64).collect()));
        }
        let mut thetas: Vec<f64> = recs.iter().map(|r| r.theta_i as f64).collect();
        thetas.dedup(); // records are sorted by (θ, φ)
        let mut phis: Vec<f64> = recs.iter().map(|r| r.phi_i as f64).collect();
        phis.sort_by(f64::total_cmp);
        phis.dedup();
        if thetas.len() * phis.len() != recs.len() {
            return Lattice::Nearest;
        }
        for (i, t) in thetas.iter().enumerate() {
            for (j, p) in phis.iter().enumerate() {
                let r = &recs[i * phis.len() + j];
                if r.theta_i as f64 != *t || r.phi_i as f64 != *p {
                    return Lattice::Nearest;
                }
            }
        }
        Lattice::Grid {
            thetas: Axis::new(thetas),
            phis: Axis::new(phis),
        }
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        match self {
            Lattice::Theta(a) => a.xs.capacity() * 8,
            Lattice::Grid { thetas, phis } => (thetas.xs.capacity() + phis.xs.capacity()) * 8,
            Lattice::Nearest => 0,
        }
    }

    /// The records to blend for a query incidence (θ, φ in degrees) and the incidence they are
    /// evaluated at: θ clamped to the stored range, or a scattered file's nearest record's own.
    #[inline(always)]
    pub(crate) fn blend(&self, recs: &[Rec], theta: f64, phi: f64) -> (Blend, f64, f64) {
        match self {
            Lattice::Theta(thetas) => {
                let b = match thetas.neighbours(theta) {
                    (i, None) => Blend::one(i),
                    (i, Some(t)) => Blend {
                        n: 2,
                        rec: [i, i + 1, 0, 0],
                        w: [1.0 - t, t, 0.0, 0.0],
                    },
                };
                (b, theta.clamp(thetas.first(), thetas.last()), phi)
            }
            Lattice::Grid { thetas, phis } => {
                let (i, t) = thetas.bracket(theta);
                let i1 = (i + 1).min(thetas.xs.len() - 1);
                // φ cells wrap: between the last φ and the first + 360°.
                let np = phis.xs.len();
                let p = crate::model::angles::wrap_phi(phi);
                let (j0, j1, u) = if np == 1 {
                    (0, 0, 0.0)
                } else if p < phis.first() || p >= phis.last() {
                    let span = phis.first() + 360.0 - phis.last();
                    let d = (p - phis.last()).rem_euclid(360.0);
                    (np - 1, 0, d / span)
                } else {
                    let (j, u) = phis.bracket(p);
                    (j, j + 1, u)
                };
                let mut b = Blend {
                    n: 0,
                    rec: [0; 4],
                    w: [0.0; 4],
                };
                b.push(i * np + j0, (1.0 - t) * (1.0 - u));
                b.push(i * np + j1, (1.0 - t) * u);
                b.push(i1 * np + j0, t * (1.0 - u));
                b.push(i1 * np + j1, t * u);
                if b.n == 0 {
                    b = Blend::one(i * np + j0);
                }
                // One stored azimuth is clamped to like θ: its records are used whole, at
                // their own φ, as every other query outside the stored range is.
                let phi = if np == 1 { phis.first() } else { phi };
                (b, theta.clamp(thetas.first(), thetas.last()), phi)
            }
            Lattice::Nearest => {
                let q = dir_from_deg(theta, phi);
                let mut best = (f64::NEG_INFINITY, 0);
                for (i, r) in recs.iter().enumerate() {
                    let c = dot(q, dir_from_deg(r.theta_i as f64, r.phi_i as f64));
                    if c > best.0 {
                        best = (c, i);
                    }
                }
                let r = &recs[best.1];
                (Blend::one(best.1), r.theta_i as f64, r.phi_i as f64)
            }
        }
    }
}
