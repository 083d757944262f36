//! What the kernel knows of a file on a θ line ([`Kernel`], settled when it is opened: each
//! record's offsets, each group's SH level and lobe operations) and one pair's computation
//! ([`Kernel::one`], [`Kernel::one_collapsed`]), which the batch's lanes repeat
//! (`super::lanes_batch`).

use super::formulas::{collapse_amps, collapse_sh, frame, Frame, KernelRecord};
use super::formulas::{AMPS, LINE_LOBES};
use super::width::Width;
use crate::decode::records::general::{SMALL_SH, SMALL_TERMS};
use crate::decode::records::lattice::{clamp_incidence, outside, Axis};
use crate::decode::records::resident::Resident;
use crate::model::lanes::Lanes;
use crate::model::lobes::{blend_peak, blend_shape, cosine_power, MicrofacetGeometry};
use crate::model::material::{LobeKind, Material};
use crate::model::sh::{sh_count, table_len, ShBasis, Y00};

/// Values a record occupies in a [`Collapsed`] table: its lobe amplitudes, then its SH
/// coefficients.
const COLLAPSED_STRIDE: usize = AMPS + SMALL_SH;
/// The values a [`Collapsed`] table holds: every record of a file with up to 17 records at
/// SH level 6 (more at lower levels). 8 KiB, on the stack of whoever holds it.
pub(crate) const COLLAPSED_VALUES: usize = 1024;
/// No amplitudes: the second slot of a group of one record.
pub(super) const NO_AMPS: [f64; AMPS] = [0.0; AMPS];

/// What the kernel knows of a file on a θ line.
#[derive(Debug, Clone)]
pub(crate) struct Kernel {
    /// Per record, where its values are (offsets into the resident arrays) and their sizes.
    pub(super) recs: Vec<KernelRecord>,
    /// Group r < n: record r alone; group n + r: records r and r + 1.
    pub(super) groups: Vec<Group>,
    /// The batch's widest lanes on this CPU.
    pub(super) width: Width,
}

/// What a kernel evaluation reads: the resident arrays and the θ axis of the stored records,
/// the stored θ range's ends with their sine and cosine (a query outside the range is evaluated
/// at the nearest end; the evaluator's, not a copy: renderers open thousands of materials).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stored<'a> {
    pub res: &'a Resident,
    pub axis: &'a Axis,
    pub ends: &'a [(f64, f64, f64); 2],
}

/// Every record of a file with its spectral terms applied at one wavelength (what
/// [`crate::Decoder::at`] keeps): record r's amplitudes and SH coefficients from
/// r·[`COLLAPSED_STRIDE`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Collapsed {
    values: [f64; COLLAPSED_VALUES],
}

impl Collapsed {
    /// Record r's lobe amplitudes (as [`collapse_amps`] gives them; none past the table).
    #[inline(always)]
    pub(crate) fn amps(&self, r: usize) -> &[f64; AMPS] {
        self.values
            .get(r * COLLAPSED_STRIDE..r * COLLAPSED_STRIDE + AMPS)
            .and_then(|a| a.try_into().ok())
            .unwrap_or(&NO_AMPS)
    }

    /// Record r's SH coefficients ã_j (as [`collapse_sh`] gives them; `p` of them).
    pub(crate) fn sh(&self, r: usize, p: usize) -> &[f64] {
        let at = r * COLLAPSED_STRIDE + AMPS;
        self.values.get(at..at + p.min(SMALL_SH)).unwrap_or(&[])
    }
}

/// A group's structure: the SH level to evaluate and up to four lobe operations.
#[derive(Debug, Clone, Copy)]
pub(super) struct Group {
    level: u8,
    /// False where the kernel does not apply (two cosine-power peaks so nearly opposite that
    /// their blended direction may vanish): such queries take the general path.
    pub(super) fast: bool,
    pub(super) ops: [Op; 2 * LINE_LOBES],
}

/// One lobe evaluation: at position `li`, either shared by the group's records (its shape
/// blended) or record `slot`'s own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Op {
    None,
    Shared { li: u8, kind: LobeKind },
    Own { slot: u8, li: u8, kind: LobeKind },
}

/// The query side the kernel needs, per lane: the incident vector it is evaluated with, the
/// outgoing vector in the records' frame and the two records' weights.
#[derive(Debug, Clone, Copy)]
pub(super) struct Query<const N: usize> {
    pub(super) wi: [Lanes<N>; 3],
    pub(super) wo: [Lanes<N>; 3],
    pub(super) w: [Lanes<N>; 2],
}

impl Kernel {
    /// The kernel of a file it takes ([`takes`]).
    pub(crate) fn new(res: &Resident) -> Self {
        let n = res.recs.len();
        let kind = |r: usize, li: usize| {
            let rec = &res.recs[r];
            (li < rec.nlobes as usize).then(|| res.lobe(rec, li).kind)
        };
        let recs = res
            .recs
            .iter()
            .map(|rec| {
                let mut k = KernelRecord {
                    sh: rec.sh,
                    amp: [0; LINE_LOBES],
                    par: [0; LINE_LOBES],
                    terms: rec.terms as u8,
                    p: sh_count(rec.level as usize) as u8,
                    nv: [0; LINE_LOBES],
                };
                for li in 0..(rec.nlobes as usize).min(LINE_LOBES) {
                    let l = res.lobe(rec, li);
                    k.amp[li] = l.amp;
                    k.par[li] = l.par;
                    k.nv[li] = if l.kind == LobeKind::CosinePower {
                        1
                    } else {
                        4
                    };
                }
                k
            })
            .collect();
        let mut groups = Vec::with_capacity(2 * n.max(1) - 1);
        for r in 0..n {
            let mut ops = [Op::None; 2 * LINE_LOBES];
            for (li, op) in ops.iter_mut().enumerate().take(LINE_LOBES) {
                if let Some(kind) = kind(r, li) {
                    *op = Op::Shared { li: li as u8, kind };
                }
            }
            groups.push(Group {
                level: res.recs[r].level,
                fast: true,
                ops,
            });
        }
        for r in 0..n.saturating_sub(1) {
            let mut ops = [Op::None; 2 * LINE_LOBES];
            let mut at = 0;
            let mut fast = true;
            for li in 0..LINE_LOBES {
                match (kind(r, li), kind(r + 1, li)) {
                    (Some(a), Some(b)) if a == b => {
                        if a == LobeKind::CosinePower {
                            let (p, q) = (res.recs[r].peak, res.recs[r + 1].peak);
                            // |w0·p + w1·q|² ≥ (1 + p·q)/2 for w0 + w1 = 1: never 0 unless
                            // the peaks are (nearly) opposite.
                            fast &= p[0] * q[0] + p[1] * q[1] + p[2] * q[2] > -1.0 + 1e-6;
                        }
                        ops[at] = Op::Shared {
                            li: li as u8,
                            kind: a,
                        };
                        at += 1;
                    }
                    (a, b) => {
                        for (slot, k) in [(0u8, a), (1u8, b)] {
                            if let Some(kind) = k {
                                ops[at] = Op::Own {
                                    slot,
                                    li: li as u8,
                                    kind,
                                };
                                at += 1;
                            }
                        }
                    }
                }
            }
            groups.push(Group {
                level: res.recs[r].level.max(res.recs[r + 1].level),
                fast,
                ops,
            });
        }
        Kernel {
            recs,
            groups,
            width: Width::detect(),
        }
    }

    /// The same kernel with the batch's lanes chosen (tests: every width on one machine);
    /// a width this CPU lacks is refused.
    pub(crate) fn with_width(mut self, width: Width) -> Option<Self> {
        width.available().then(|| {
            self.width = width;
            self
        })
    }

    /// Each record's SH function count ((level + 1)²), in record order.
    pub(crate) fn sh_counts(&self) -> impl Iterator<Item = usize> + '_ {
        self.recs.iter().map(|k| k.p as usize)
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.recs.capacity() * std::mem::size_of::<KernelRecord>()
            + self.groups.capacity() * std::mem::size_of::<Group>()
    }

    /// One pair's frame, group and second-record weight t, as both one-pair entry points need
    /// them; Err(Some(0)) for a pair below the horizon or not normalisable, Err(None) for a
    /// group the kernel leaves to the general path.
    #[inline(always)]
    pub(super) fn placed(
        &self,
        axis: &Axis,
        wi: [f32; 3],
        wo: [f32; 3],
    ) -> Result<(Frame<1>, usize, f64), Option<f32>> {
        let f = frame::<1>([wi], [wo]);
        if !f.valid.0[0] {
            return Err(Some(0.0));
        }
        let (g, t) = self.group_of(axis, f.theta.0[0]);
        if !self.groups[g].fast {
            return Err(None);
        }
        Ok((f, g, t))
    }

    /// ρ for one pair at the wavelength whose basis values are `b` (not NaN), clamped at 0;
    /// None for a pair the kernel leaves to the general path. The lanes of the batch compute
    /// exactly this.
    #[inline]
    pub(crate) fn one(&self, st: Stored, wi: [f32; 3], wo: [f32; 3], b: &[f64]) -> Option<f32> {
        let (f, g, t) = match self.placed(st.axis, wi, wo) {
            Ok(placed) => placed,
            Err(value) => return value,
        };
        let group = &self.groups[g];
        // The scratch sized for the group's SH level: zeroing level 6's 49 values for a level-0
        // group would cost more than its evaluation.
        Some(match group.level {
            0..=2 => self.one_sized::<{ sh_count(2) }>(st, g, t, &f, b),
            3 | 4 => self.one_sized::<{ sh_count(4) }>(st, g, t, &f, b),
            _ => self.one_sized::<SMALL_SH>(st, g, t, &f, b),
        })
    }

    #[inline(always)]
    fn one_sized<const NSH: usize>(
        &self,
        st: Stored,
        g: usize,
        t: f64,
        f: &Frame<1>,
        b: &[f64],
    ) -> f32 {
        let (r0, count) = self.records(g);
        let mut sh = [[0.0f64; NSH]; 2];
        let mut amps = [NO_AMPS; 2];
        for slot in 0..count {
            let k = &self.recs[r0 + slot];
            collapse_sh(&st.res.vals, k, b, &mut sh[slot]);
            collapse_amps(&st.res.vals, k, b, &mut amps[slot]);
        }
        let p = |slot: usize| (self.recs[r0 + slot.min(count - 1)].p as usize).min(NSH);
        let sh = [&sh[0][..p(0)], &sh[1][..if count == 2 { p(1) } else { 0 }]];
        let q = self.query(st.ends, g, f, [t]);
        let s = self.sh_parts(g, q.wo, sh);
        let v = self.value(st.res, g, s, [&amps[0], &amps[1]], &q);
        v.max(Lanes::splat(0.0)).0[0] as f32
    }

    /// Every record collapsed at basis values `b` (not NaN) into one table, if the file's
    /// records fit [`COLLAPSED_VALUES`].
    pub(crate) fn collapse_all(&self, res: &Resident, b: &[f64]) -> Option<Collapsed> {
        if self.recs.len() * COLLAPSED_STRIDE > COLLAPSED_VALUES {
            return None;
        }
        let mut c = Collapsed {
            values: [0.0; COLLAPSED_VALUES],
        };
        for (k, at) in self
            .recs
            .iter()
            .zip(c.values.chunks_exact_mut(COLLAPSED_STRIDE))
        {
            let (amps, sh) = at.split_at_mut(AMPS);
            let amps: &mut [f64; AMPS] = amps.try_into().ok()?;
            collapse_amps(&res.vals, k, b, amps);
            collapse_sh(&res.vals, k, b, sh);
        }
        Some(c)
    }

    /// [`Kernel::one`] from records collapsed beforehand ([`Kernel::collapse_all`] at the same
    /// wavelength): the same operations on the same values, so the same bits.
    #[inline]
    pub(crate) fn one_collapsed(
        &self,
        st: Stored,
        wi: [f32; 3],
        wo: [f32; 3],
        c: &Collapsed,
    ) -> Option<f32> {
        let (f, g, t) = match self.placed(st.axis, wi, wo) {
            Ok(placed) => placed,
            Err(value) => return value,
        };
        let (r0, count) = self.records(g);
        let rec = |slot: usize| -> (&[f64; AMPS], &[f64]) {
            let at = &c.values[(r0 + slot) * COLLAPSED_STRIDE..(r0 + slot + 1) * COLLAPSED_STRIDE];
            let (amps, sh) = at.split_at(AMPS);
            let p = self.recs[r0 + slot].p as usize;
            (amps.try_into().unwrap_or(&NO_AMPS), &sh[..p.min(sh.len())])
        };
        let (a0, s0) = rec(0);
        let (a1, s1) = if count == 2 {
            rec(1)
        } else {
            (&NO_AMPS, &[][..])
        };
        let q = self.query(st.ends, g, &f, [t]);
        let s = self.sh_parts(g, q.wo, [s0, s1]);
        let v = self.value(st.res, g, s, [a0, a1], &q);
        Some(v.max(Lanes::splat(0.0)).0[0] as f32)
    }

    /// The group of a query at θ (degrees) and the weight t of its second record (blend
    /// (1 − t, t); 0 for a record alone), as `Lattice::blend` forms them.
    #[inline(always)]
    pub(super) fn group_of(&self, axis: &Axis, theta: f64) -> (usize, f64) {
        match axis.neighbours(theta) {
            (i, None) => (i, 0.0),
            (i, Some(t)) => (self.recs.len() + i, t),
        }
    }

    /// Group g's first record and how many it has (one or two).
    #[inline(always)]
    pub(super) fn records(&self, g: usize) -> (usize, usize) {
        let n = self.recs.len();
        if g < n {
            (g, 1)
        } else {
            (g - n, 2)
        }
    }

    /// Group g's SH parts Σ_j ã_j·Y_j(wo) from its collapsed records `sh`: at level 0
    /// ã_0·Y_0^0; otherwise in four partial sums (j mod 4) added as (s0 + s1) + (s2 + s3). One
    /// pair and the lanes both come here, so their sums are the same bits. The level is
    /// dispatched to code compiled for it ([`ShBasis::eval_lanes_fixed`]): its loops unrolled,
    /// its SH values kept in registers rather than in a 49-value scratch.
    #[inline(always)]
    pub(super) fn sh_parts<const N: usize>(
        &self,
        g: usize,
        wo: [Lanes<N>; 3],
        sh: [&[f64]; 2],
    ) -> [Lanes<N>; 2] {
        let count = self.records(g).1;
        match self.groups[g].level {
            0 => sh.map(|a| Lanes::splat(a.first().copied().unwrap_or(0.0) * Y00)),
            1 => sh_parts_at::<N, 1, { table_len(1) }, { sh_count(1) }>(wo, sh, count),
            2 => sh_parts_at::<N, 2, { table_len(2) }, { sh_count(2) }>(wo, sh, count),
            3 => sh_parts_at::<N, 3, { table_len(3) }, { sh_count(3) }>(wo, sh, count),
            4 => sh_parts_at::<N, 4, { table_len(4) }, { sh_count(4) }>(wo, sh, count),
            5 => sh_parts_at::<N, 5, { table_len(5) }, { sh_count(5) }>(wo, sh, count),
            _ => sh_parts_at::<N, 6, { table_len(6) }, { sh_count(6) }>(wo, sh, count),
        }
    }

    /// Group g's query lanes from their frames and second-record weights `t`.
    #[inline(always)]
    pub(super) fn query<const N: usize>(
        &self,
        ends: &[(f64, f64, f64); 2],
        g: usize,
        f: &Frame<N>,
        t: [f64; N],
    ) -> Query<N> {
        let t = Lanes(t);
        // The incidence the records are evaluated at: θ clamped to the stored range, whose
        // ends' (θ, sin θ, cos θ) the evaluator holds.
        let (below, above) = outside(f.theta, ends);
        let (r, z) = clamp_incidence(below, above, f.r, f.z, ends);
        let wi = [r, Lanes::splat(0.0), z];
        let w = if self.records(g).1 == 2 {
            [1.0 - t, t]
        } else {
            [Lanes::splat(1.0), Lanes::splat(0.0)]
        };
        Query { wi, wo: f.wo, w }
    }

    /// ρ before the clamp for group g's query lanes from its records' SH parts `s` and lobe
    /// amplitudes `amps` (collapsed at the wavelength).
    #[inline(always)]
    pub(super) fn value<const N: usize>(
        &self,
        res: &Resident,
        g: usize,
        mut s: [Lanes<N>; 2],
        amps: [&[f64; AMPS]; 2],
        q: &Query<N>,
    ) -> Lanes<N> {
        let group = &self.groups[g];
        let (r0, count) = self.records(g);
        let mut geometry: Option<MicrofacetGeometry<Lanes<N>>> = None;
        for op in group.ops {
            let (first, slots, li, kind) = match op {
                Op::None => break,
                Op::Shared { li, kind } => (0, count, li as usize, kind),
                Op::Own { slot, li, kind } => (slot as usize, 1, li as usize, kind),
            };
            let li = li.min(LINE_LOBES - 1);
            // A shared lobe of two records blends its shape; otherwise the record's own.
            let blended = slots == 2;
            let pars = [
                self.recs[r0 + first].par[li] as usize,
                self.recs[r0 + count - 1].par[li] as usize,
            ];
            // The kind's rule and the record count as constants in each call (the cosine
            // power's one parameter, the microfacet's three; one record's stored values): matched
            // at run time inside `blend_shape`, they cost a tenth of a phong query.
            let shape = |kind: LobeKind, w: &[Lanes<N>]| {
                blend_shape(
                    kind,
                    w,
                    |i, j| res.params[pars[i] + j] as f64,
                    |i, j| res.ln_params[pars[i] + j],
                    || 0.0, // kinds 2–4 have no axis
                )
            };
            // Kind 4's rule is kind 3's (`shape_rule`).
            let rule = if kind == LobeKind::CosinePower {
                LobeKind::CosinePower
            } else {
                LobeKind::Microfacet
            };
            let p = match (rule, blended) {
                (LobeKind::CosinePower, true) => shape(LobeKind::CosinePower, &q.w),
                (LobeKind::CosinePower, false) => shape(LobeKind::CosinePower, &q.w[..1]),
                (_, true) => shape(LobeKind::Microfacet, &q.w),
                (_, false) => shape(LobeKind::Microfacet, &q.w[..1]),
            };
            if kind == LobeKind::CosinePower {
                let peak = if blended {
                    let peaks = [res.recs[r0].peak, res.recs[r0 + 1].peak];
                    blend_peak([(q.w[0], peaks[0]), (q.w[1], peaks[1])]).0
                } else {
                    res.recs[r0 + first].peak.map(Lanes::splat)
                };
                let v = cosine_power(p[0], q.wo, peak);
                for slot in first..first + slots {
                    s[slot] = s[slot] + amps[slot][4 * li] * v;
                }
                continue;
            }
            let (b, c, a) = (p[0], p[1], p[2]);
            let g = match geometry {
                Some(g) => g,
                None => {
                    let g = MicrofacetGeometry::at(q.wi, q.wo);
                    geometry = Some(g);
                    g
                }
            };
            let v = g.variants_of(b, c, a, kind == LobeKind::MicrofacetSin2);
            for slot in first..first + slots {
                let amp = &amps[slot][4 * li..4 * li + 4];
                let sum = amp[0] * v[0] + amp[1] * v[1] + amp[2] * v[2] + amp[3] * v[3];
                s[slot] = s[slot] + sum;
            }
        }
        if count == 2 {
            q.w[0] * s[0] + q.w[1] * s[1]
        } else {
            s[0]
        }
    }
}

/// [`Kernel::sh_parts`] at SH level L (NT its tables' length, NSH its functions' count) for
/// the first `count` records.
#[inline(always)]
fn sh_parts_at<const N: usize, const L: usize, const NT: usize, const NSH: usize>(
    wo: [Lanes<N>; 3],
    sh: [&[f64]; 2],
    count: usize,
) -> [Lanes<N>; 2] {
    let mut y = [Lanes::splat(0.0); NSH];
    ShBasis::shared().eval_lanes_fixed::<N, L, NT>(wo, |j, v| {
        if let Some(y) = y.get_mut(j) {
            *y = v;
        }
    });
    let mut s = [Lanes::splat(0.0); 2];
    for (s, a) in s.iter_mut().zip(sh).take(count) {
        let n = a.len().min(NSH);
        let (a, y) = (&a[..n], &y[..n]);
        let mut acc = [Lanes::splat(0.0); 4];
        let (a4, y4) = (a.chunks_exact(4), y.chunks_exact(4));
        let (at, yt) = (a4.remainder(), y4.remainder());
        for (a, y) in a4.zip(y4) {
            for q in 0..4 {
                acc[q] = acc[q] + a[q] * y[q];
            }
        }
        for (q, (&a, &y)) in at.iter().zip(yt).enumerate() {
            acc[q] = acc[q] + a * y;
        }
        *s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    }
    s
}

/// Whether a file's records fit the kernel: SH level ≤ 6, at most
/// [`SMALL_TERMS`] terms, and per record at most [`LINE_LOBES`] lobes, each a cosine power or a
/// microfacet lobe (kinds 2–4).
pub(crate) fn takes(material: &Material) -> bool {
    sh_count(material.sh_level) <= SMALL_SH
        && material.spectral.terms <= SMALL_TERMS
        && material.records.iter().all(|r| {
            r.lobes.len() <= LINE_LOBES
                && r.lobes.iter().all(|l| {
                    matches!(
                        l.kind,
                        LobeKind::CosinePower | LobeKind::Microfacet | LobeKind::MicrofacetSin2
                    )
                })
        })
}
