//! The one-wavelength batch kernel: how [`super::batch`] answers many direction pairs at one
//! wavelength on a θ line (the files [`super::line`] covers: isotropic, no factor model, at
//! most two lobes of kinds 2–4 per record, SH level ≤ 6, ≤ 16 terms).
//!
//! A query blends one record or two neighbours, so the stored incidences split the queries into
//! *groups*: record r alone (at or beyond a stored θ) and the neighbours r, r + 1 (between them).
//! Each group's structure is settled when the file is opened: the SH level to evaluate, and the
//! lobe operations (a lobe shared by both records is blended and evaluated once, one held by a
//! single record is evaluated with its own shape). At a wavelength, a record's spectral terms
//! are applied to its stored values first ("collapsed": ã_j = Σ_k B_k·a_kj for its SH rows and
//! likewise for its lobe amplitudes), once per group and block of pairs rather than once per
//! pair. The arithmetic is written once over [`Lanes`]: a block's pairs are sorted by group
//! and run four lanes at a time (AVX2), eight (AVX-512), or one (without AVX2), so every
//! pair's value is the same bits on every CPU and in any batch. The formulas are those of
//! `spec/EVALUATION.md` ("Reconstruction", "Between stored incidences", "Lobes"); the order of
//! the sums and the `exp` and `ln` ([`Lanes::exp`], [`Lanes::ln`], within 1 ulp) are the
//! kernel's own, which "Rounding" allows: its values are `Evaluator::eval`'s to a few binary32
//! roundings, not bit for bit (`tests/batch.rs` holds both to the general path and to each
//! other). `eval` keeps the line path: for one query, collapsing a record's terms first costs
//! more than it saves.

mod formulas;

use super::evaluator::{Evaluator, SMALL_SH};
use super::lattice::{upper, Lattice};
use super::line::LINE_LOBES;
use crate::model::lanes::{Lanes, Mask};
use crate::model::material::LobeKind;
use crate::model::sh::{sh_count, ShBasis};
use formulas::{cosine_power, dot, frame, Geometry};

/// The microfacet functions' floor on cosines (`MicrofacetGeometry`'s).
const MIN_COS: f64 = 1e-6;
/// Pairs a batch sorts by group at a time (their scratch lives on the stack).
const BLOCK: usize = 256;
/// The most groups (2n − 1 for n records) a batch sorts by counting; more take a comparison
/// sort.
const COUNTED_GROUPS: usize = 511;

/// What the kernel knows of a file on a θ line.
#[derive(Debug, Clone)]
pub(crate) struct Kernel {
    /// Per record, where its values are (offsets into the resident arrays) and their sizes.
    recs: Vec<KRec>,
    /// Group r < n: record r alone; group n + r: records r and r + 1.
    groups: Vec<Group>,
    /// Y_0^0 (a constant).
    y0: f64,
    /// The batch's widest lanes on this CPU.
    width: Width,
}

/// The vector instructions a batch uses: found once, when the file is opened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Width {
    /// Whatever the build targets (SSE2 on x86-64): four lanes as two pairs.
    Base,
    /// Four binary64 lanes per instruction.
    Avx2,
    /// Eight binary64 lanes per instruction.
    Avx512,
}

/// A record as the kernel reads it: offsets of its SH rows and of each lobe position's
/// amplitudes (into `vals`) and parameters (into `params`, `ln_params`), its terms, SH count
/// and each lobe position's variant count (0: no lobe there).
#[derive(Debug, Clone, Copy)]
struct KRec {
    sh: u32,
    amp: [u32; LINE_LOBES],
    par: [u32; LINE_LOBES],
    terms: u8,
    p: u8,
    nv: [u8; LINE_LOBES],
}

/// A group's structure: the SH level to evaluate and up to four lobe operations.
#[derive(Debug, Clone, Copy)]
struct Group {
    level: u8,
    /// False where the kernel does not apply (two cosine-power peaks so nearly opposite that
    /// their blended direction may vanish): such queries take the line path.
    fast: bool,
    ops: [Op; 2 * LINE_LOBES],
}

/// One lobe evaluation: at position `li`, either shared by the group's records (its shape
/// blended) or record `slot`'s own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    None,
    Shared { li: u8, kind: LobeKind },
    Own { slot: u8, li: u8, kind: LobeKind },
}

/// A group's records with the spectral terms applied at one wavelength: per record slot, its
/// SH coefficients (`p` of them) and its lobe amplitudes.
#[derive(Debug, Clone, Copy)]
struct Collapsed {
    sh: [[f64; SMALL_SH]; 2],
    amps: [Amps; 2],
    p: [u8; 2],
}

/// A record's lobe amplitudes with the spectral terms applied at one wavelength: per lobe
/// position, its variants' (one for a cosine power, four otherwise).
type Amps = [[f64; 4]; LINE_LOBES];

/// The query side the kernel needs, per lane: the incident vector it is evaluated with, the
/// outgoing vector in the records' frame and the two records' weights.
#[derive(Debug, Clone, Copy)]
struct Query<const N: usize> {
    wi: [Lanes<N>; 3],
    wo: [Lanes<N>; 3],
    w: [Lanes<N>; 2],
}

/// A pair's vectors after the frame step: valid when both are unit-normalisable and on or above
/// the surface; the incident vector's horizontal length and height, its θ (degrees), and the
/// outgoing vector rotated into the records' frame.
#[derive(Debug, Clone, Copy)]
struct Frame<const N: usize> {
    valid: Mask<N>,
    r: Lanes<N>,
    z: Lanes<N>,
    theta: Lanes<N>,
    wo: [Lanes<N>; 3],
}

impl Kernel {
    /// The kernel of a file on the line path.
    pub(crate) fn new(ev: &Evaluator) -> Self {
        let res = &ev.res;
        let n = res.recs.len();
        let kind = |r: usize, li: usize| {
            let rec = &res.recs[r];
            (li < rec.nlobes as usize).then(|| res.lobe(rec, li).kind)
        };
        let recs = res
            .recs
            .iter()
            .map(|rec| {
                let mut k = KRec {
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
            y0: ShBasis::shared().constant(),
            width: Width::detect(),
        }
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.recs.capacity() * std::mem::size_of::<KRec>()
            + self.groups.capacity() * std::mem::size_of::<Group>()
    }

    /// ρ for one pair at the wavelength whose basis values are `b`, clamped at 0.
    #[inline]
    fn one(&self, ev: &Evaluator, wi: [f32; 3], wo: [f32; 3], b: &[f64]) -> f32 {
        let f = frame::<1>([wi], [wo]);
        if !f.valid.0[0] {
            return 0.0;
        }
        let (g, t) = self.group_of(ev, f.theta.0[0]);
        let group = &self.groups[g];
        if !group.fast {
            return fallback(ev, wi, wo, b);
        }
        let q = self.query(ev, g, &f, [t]);
        let c = self.collapse(ev, g, b);
        let mut y = [Lanes::splat(0.0); SMALL_SH];
        let s = self.sh_parts(g, q.wo, &c, &mut y);
        self.value(ev, g, s, &c.amps, &q).max(Lanes::splat(0.0)).0[0] as f32
    }

    /// Group g's records collapsed at basis values `b`: what `one` does per pair and the
    /// batch once per group and block.
    #[inline(always)]
    fn collapse(&self, ev: &Evaluator, g: usize, b: &[f64]) -> Collapsed {
        let (r0, count) = self.records(g);
        let vals = &ev.res.vals[..];
        let mut c = Collapsed {
            sh: [[0.0; SMALL_SH]; 2],
            amps: [[[0.0; 4]; LINE_LOBES]; 2],
            p: [0; 2],
        };
        for slot in 0..count {
            let k = &self.recs[r0 + slot];
            c.p[slot] = k.p;
            collapse_sh(vals, k, b, &mut c.sh[slot]);
            collapse_amps(vals, k, b, &mut c.amps[slot]);
        }
        c
    }

    /// `out[i]` = ρ(wi(i), wo(i), λ) for i < n at the one wavelength whose basis values are `b`
    /// (NaN: a wavelength that is not finite), each the same bits whatever the batch or the CPU.
    pub(crate) fn batch(
        &self,
        ev: &Evaluator,
        wi: &impl Fn(usize) -> [f32; 3],
        wo: &impl Fn(usize) -> [f32; 3],
        n: usize,
        b: &[f64],
        out: &mut [f32],
    ) {
        if b.first().is_none_or(|v| v.is_nan()) {
            out[..n].fill(0.0);
            return;
        }
        #[cfg(target_arch = "x86_64")]
        match self.width {
            // SAFETY: the CPU has these features (`Width::detect`).
            Width::Avx512 => unsafe { self.batch_avx512(ev, wi, wo, n, b, out) },
            Width::Avx2 => unsafe { self.batch_avx2(ev, wi, wo, n, b, out) },
            // Without AVX2, pair by pair: four lanes in SSE2 pairs gained little over one
            // and compiling them a third time cost a minute of every release build.
            Width::Base => {
                for (i, o) in out[..n].iter_mut().enumerate() {
                    *o = self.one(ev, wi(i), wo(i), b);
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.batch_lanes::<4>(ev, wi, wo, n, b, out);
    }

    /// [`Kernel::batch_lanes`] compiled for AVX2, four lanes: the same operations, the same bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn batch_avx2(
        &self,
        ev: &Evaluator,
        wi: &impl Fn(usize) -> [f32; 3],
        wo: &impl Fn(usize) -> [f32; 3],
        n: usize,
        b: &[f64],
        out: &mut [f32],
    ) {
        self.batch_lanes::<4>(ev, wi, wo, n, b, out)
    }

    /// [`Kernel::batch_lanes`] compiled for AVX-512, eight lanes: the same operations, the same
    /// bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
    unsafe fn batch_avx512(
        &self,
        ev: &Evaluator,
        wi: &impl Fn(usize) -> [f32; 3],
        wo: &impl Fn(usize) -> [f32; 3],
        n: usize,
        b: &[f64],
        out: &mut [f32],
    ) {
        self.batch_lanes::<8>(ev, wi, wo, n, b, out)
    }

    /// The batch in blocks: each block's pairs framed W at a time, sorted by group, then each
    /// group's pairs evaluated W at a time with its records collapsed once.
    #[inline(always)]
    fn batch_lanes<const W: usize>(
        &self,
        ev: &Evaluator,
        wi: &impl Fn(usize) -> [f32; 3],
        wo: &impl Fn(usize) -> [f32; 3],
        n: usize,
        b: &[f64],
        out: &mut [f32],
    ) {
        let zero = Lanes([0.0]);
        let mut frames = [Frame::<1> {
            valid: Mask([false]),
            r: zero,
            z: zero,
            theta: zero,
            wo: [zero; 3],
        }; BLOCK];
        // Per position in the block: its group and t; then the positions ordered by group.
        let mut groups = [0u32; BLOCK];
        let mut ts = [0.0f64; BLOCK];
        let mut order = [0u16; BLOCK];
        let mut live_at = [0u16; BLOCK];
        // Pairs per group, then where each group's pairs start in `order` (a counting sort:
        // a comparison sort cost a quarter of the batch).
        let counted = self.groups.len() <= COUNTED_GROUPS;
        let mut first = [0u16; COUNTED_GROUPS + 1];
        for start in (0..n).step_by(BLOCK) {
            let len = BLOCK.min(n - start);
            for c in (0..len).step_by(W) {
                // A short last chunk repeats its last pair.
                let at = |j: usize| start + (c + j).min(len - 1);
                let f = frame::<W>(
                    std::array::from_fn(|j| wi(at(j))),
                    std::array::from_fn(|j| wo(at(j))),
                );
                for j in 0..W.min(len - c) {
                    frames[c + j] = f.lane(j);
                }
            }
            let mut live = 0;
            let ng = self.groups.len();
            if counted {
                first[..ng + 1].fill(0);
            }
            for (p, f) in frames[..len].iter().enumerate() {
                if !f.valid.0[0] {
                    out[start + p] = 0.0;
                    continue;
                }
                let (g, t) = self.group_of(ev, f.theta.0[0]);
                groups[p] = g as u32;
                ts[p] = t;
                live_at[live] = p as u16;
                live += 1;
                if counted {
                    first[g + 1] += 1;
                }
            }
            let order = &mut order[..live];
            if counted {
                for g in 0..ng {
                    first[g + 1] += first[g];
                }
                for &p in &live_at[..live] {
                    let g = groups[p as usize] as usize;
                    order[first[g] as usize] = p;
                    first[g] += 1;
                }
            } else {
                order.copy_from_slice(&live_at[..live]);
                order.sort_unstable_by_key(|&p| (groups[p as usize], p));
            }
            let mut i = 0;
            while i < order.len() {
                let g = groups[order[i] as usize];
                let mut end = i + 1;
                while end < order.len() && groups[order[end] as usize] == g {
                    end += 1;
                }
                let members = &order[i..end];
                i = end;
                let g = g as usize;
                let run = Run {
                    g,
                    b,
                    members,
                    frames: &frames[..len],
                    ts: &ts[..len],
                };
                let out = &mut out[start..start + len];
                if !self.groups[g].fast {
                    for &p in members {
                        let at = start + p as usize;
                        out[p as usize] = fallback(ev, wi(at), wo(at), b);
                    }
                    continue;
                }
                self.run::<W>(ev, run, out);
            }
        }
    }

    /// One group's pairs of a block, W lanes at a time, its records collapsed once.
    #[inline(always)]
    fn run<const W: usize>(&self, ev: &Evaluator, run: Run, out: &mut [f32]) {
        let c = self.collapse(ev, run.g, run.b);
        // The SH values of each W pairs, overwritten up to the level's count every time.
        let mut y = [Lanes::splat(0.0); SMALL_SH];
        for chunk in run.members.chunks(W) {
            let lane = |j: usize| chunk[j.min(chunk.len() - 1)] as usize;
            let f = Frame::gather::<W>(std::array::from_fn(|j| &run.frames[lane(j)]));
            let q = self.query(ev, run.g, &f, std::array::from_fn(|j| run.ts[lane(j)]));
            let s = self.sh_parts(run.g, q.wo, &c, &mut y);
            let v = self.value(ev, run.g, s, &c.amps, &q).max(Lanes::splat(0.0));
            for (j, &at) in chunk.iter().enumerate() {
                out[at as usize] = v.0[j] as f32;
            }
        }
    }

    /// The group of a query at θ (degrees) and the weight t of its second record (blend
    /// (1 − t, t); 0 for a record alone), as `Lattice::blend` forms them.
    #[inline(always)]
    fn group_of(&self, ev: &Evaluator, theta: f64) -> (usize, f64) {
        let Lattice::Theta(axis) = &ev.lattice else {
            return (0, 0.0);
        };
        let (i, t) = axis.bracket(theta);
        let n = self.recs.len();
        if n == 1 || t <= 0.0 {
            (i, 0.0)
        } else if 1.0 - t <= 0.0 {
            (i + 1, 0.0)
        } else {
            (n + i, t)
        }
    }

    /// Group g's first record and how many it has (one or two).
    #[inline(always)]
    fn records(&self, g: usize) -> (usize, usize) {
        let n = self.recs.len();
        if g < n {
            (g, 1)
        } else {
            (g - n, 2)
        }
    }

    /// Group g's SH parts Σ_j ã_j·Y_j(wo) from its collapsed records `c`, the SH values into
    /// `y`: at level 0 ã_0·Y_0^0;
    /// otherwise in four partial sums (j mod 4) added as (s0 + s1) + (s2 + s3). One pair and
    /// the lanes both come here, so their sums are the same bits.
    #[inline(always)]
    fn sh_parts<const N: usize>(
        &self,
        g: usize,
        wo: [Lanes<N>; 3],
        c: &Collapsed,
        y: &mut [Lanes<N>; SMALL_SH],
    ) -> [Lanes<N>; 2] {
        let (level, count) = (self.groups[g].level as usize, self.records(g).1);
        let (a, p) = (&c.sh, c.p);
        if level == 0 {
            return [0, 1].map(|slot| Lanes::splat(a[slot][0] * self.y0));
        }
        let level = level.min(crate::model::sh::level_of(SMALL_SH));
        ShBasis::shared().eval_lanes(level, wo, |j, v| {
            if let Some(y) = y.get_mut(j) {
                *y = v;
            }
        });
        let mut s = [Lanes::splat(0.0); 2];
        for (slot, s) in s.iter_mut().enumerate().take(count) {
            let n = (p[slot] as usize).min(SMALL_SH);
            let (a, y) = (&a[slot][..n], &y[..n]);
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

    /// Group g's query lanes from their frames and second-record weights `t`.
    #[inline(always)]
    fn query<const N: usize>(
        &self,
        ev: &Evaluator,
        g: usize,
        f: &Frame<N>,
        t: [f64; N],
    ) -> Query<N> {
        let t = Lanes(t);
        // The incidence the records are evaluated at: θ clamped to the stored range, whose
        // ends' (θ, sin θ, cos θ) the evaluator holds.
        let [(first, s0, c0), (last, s1, c1)] = ev.theta_ends;
        let below = f.theta.lt(Lanes::splat(first));
        let above = f.theta.gt(Lanes::splat(last));
        let pick = |lo: f64, hi: f64, own: Lanes<N>| {
            Lanes::select(
                below,
                Lanes::splat(lo),
                Lanes::select(above, Lanes::splat(hi), own),
            )
        };
        let wi = [pick(s0, s1, f.r), Lanes::splat(0.0), pick(c0, c1, f.z)];
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
    fn value<const N: usize>(
        &self,
        ev: &Evaluator,
        g: usize,
        mut s: [Lanes<N>; 2],
        amps: &[Amps; 2],
        q: &Query<N>,
    ) -> Lanes<N> {
        let group = &self.groups[g];
        let (r0, count) = self.records(g);
        let res = &ev.res;
        let mut geometry: Option<Geometry<N>> = None;
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
            let stored = |j: usize| Lanes::splat(res.params[pars[0] + j] as f64);
            let geometric = |j: usize| {
                (q.w[0] * res.ln_params[pars[0] + j] + q.w[1] * res.ln_params[pars[1] + j]).exp()
            };
            if kind == LobeKind::CosinePower {
                let (n, peak) = if blended {
                    let (p0, p1) = (res.recs[r0].peak, res.recs[r0 + 1].peak);
                    let m: [Lanes<N>; 3] = std::array::from_fn(|c| q.w[0] * p0[c] + q.w[1] * p1[c]);
                    let inv = 1.0 / dot(m, m).sqrt();
                    (geometric(0), m.map(|c| c * inv))
                } else {
                    (stored(0), res.recs[r0 + first].peak.map(Lanes::splat))
                };
                let v = cosine_power(n, q.wo, peak);
                for slot in first..first + slots {
                    s[slot] = s[slot] + amps[slot][li][0] * v;
                }
                continue;
            }
            let (b, c, a) = if blended {
                let a0 = res.params[pars[0] + 2] as f64;
                let a1 = res.params[pars[1] + 2] as f64;
                let a = (q.w[0] * a0 + q.w[1] * a1) / (q.w[0] + q.w[1]);
                (
                    geometric(0).round_f32(),
                    geometric(1).round_f32(),
                    a.round_f32(),
                )
            } else {
                (stored(0), stored(1), stored(2))
            };
            let g = match geometry {
                Some(g) => g,
                None => {
                    let g = Geometry::new(q.wi, q.wo);
                    geometry = Some(g);
                    g
                }
            };
            let v = g.variants(b, c, a, kind == LobeKind::MicrofacetSin2);
            for slot in first..first + slots {
                let amp = &amps[slot][li];
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

impl Width {
    fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512dq")
                && std::arch::is_x86_feature_detected!("avx512vl")
            {
                return Width::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Width::Avx2;
            }
        }
        Width::Base
    }
}

/// One group's pairs in a block (positions in the block, ordered) with the block's frames and
/// second-record weights by position.
struct Run<'a> {
    g: usize,
    b: &'a [f64],
    members: &'a [u16],
    frames: &'a [Frame<1>],
    ts: &'a [f64],
}

/// Record k's SH coefficients at basis values `b` into `a` (as many as fit):
/// ã_j = Σ_k B_k·a_kj, k in order from 0.
#[inline(always)]
fn collapse_sh(vals: &[f32], k: &KRec, b: &[f64], a: &mut [f64]) {
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
fn collapse_amps(vals: &[f32], k: &KRec, b: &[f64], amps: &mut Amps) {
    let t = (k.terms as usize).min(b.len());
    for (li, amps) in amps.iter_mut().enumerate() {
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

/// A pair of a group the kernel leaves to the line path.
fn fallback(ev: &Evaluator, wi: [f32; 3], wo: [f32; 3], b: &[f64]) -> f32 {
    match (upper(wi), upper(wo)) {
        (Some(a), Some(o)) => ev.line_value(a, o, b).max(0.0) as f32,
        _ => 0.0,
    }
}

impl Frame<1> {
    /// Lanes gathered from one-lane frames.
    #[inline(always)]
    fn gather<const N: usize>(f: [&Frame<1>; N]) -> Frame<N> {
        let l = |g: fn(&Frame<1>) -> Lanes<1>| Lanes(std::array::from_fn(|j| g(f[j]).0[0]));
        Frame {
            valid: Mask(std::array::from_fn(|j| f[j].valid.0[0])),
            r: l(|f| f.r),
            z: l(|f| f.z),
            theta: l(|f| f.theta),
            wo: [l(|f| f.wo[0]), l(|f| f.wo[1]), l(|f| f.wo[2])],
        }
    }
}

impl<const N: usize> Frame<N> {
    /// Lane j alone.
    #[inline(always)]
    fn lane(&self, j: usize) -> Frame<1> {
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

#[cfg(test)]
mod tests;
