//! The kernel's batch: a block's pairs framed W at a time, sorted by the group of records they
//! blend, each group's records collapsed once, then its pairs evaluated four lanes at a time
//! (AVX2), eight (AVX-512), or one by one (without AVX2) through [`Kernel::one`]: the same
//! operations in every case, so the same bits.

use super::formulas::{collapse_amps, collapse_sh, frame, gather, Frame};
use super::groups::{Kernel, Stored, NO_AMPS};
use super::width::Width;
use crate::decode::records::general::SMALL_SH;
use crate::model::lanes::{Lanes, Mask};

/// Pairs a batch sorts by group at a time (their scratch lives on the stack).
const BLOCK: usize = 256;
/// The most groups (2n − 1 for n records) a batch sorts by counting; more take a comparison
/// sort.
const COUNTED_GROUPS: usize = 511;

/// Pair i's direction (incident or outgoing).
pub(crate) trait Pairing: Fn(usize) -> [f32; 3] {}
impl<T: Fn(usize) -> [f32; 3]> Pairing for T {}

/// A batch's pairs: n of them, pair i = (wi(i), wo(i)); `fallback(i)` answers pair i where
/// the kernel does not (the general path).
pub(crate) struct Pairs<I, O, F> {
    pub wi: I,
    pub wo: O,
    pub n: usize,
    pub fallback: F,
}

/// `out[i]` = ρ(wi(i), wo(i), λ) for i < n at the one wavelength whose basis values are `b`
/// (NaN: a wavelength that is not finite), each the same bits whatever the batch or the CPU.
pub(crate) fn batch<I: Pairing, O: Pairing, F: Fn(usize) -> f32>(
    k: &Kernel,
    st: Stored,
    pairs: &Pairs<I, O, F>,
    b: &[f64],
    out: &mut [f32],
) {
    let n = pairs.n;
    if b.first().is_none_or(|v| v.is_nan()) {
        out[..n].fill(0.0);
        return;
    }
    #[cfg(target_arch = "x86_64")]
    match k.width {
        // SAFETY: the CPU has these features (`Width::detect`).
        Width::Avx512 => unsafe { batch_avx512(k, st, pairs, b, out) },
        Width::Avx2 => unsafe { batch_avx2(k, st, pairs, b, out) },
        // Without AVX2, pair by pair: four lanes in SSE2 pairs gained little over one
        // and compiling them a third time cost a minute of every release build.
        Width::Base => {
            for (i, o) in out[..n].iter_mut().enumerate() {
                *o = k
                    .one(st, (pairs.wi)(i), (pairs.wo)(i), b)
                    .unwrap_or_else(|| (pairs.fallback)(i));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    batch_lanes::<4, I, O, F>(k, st, pairs, b, out);
}

/// [`batch_lanes`] compiled for AVX2, four lanes: the same operations, the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn batch_avx2<I: Pairing, O: Pairing, F: Fn(usize) -> f32>(
    k: &Kernel,
    st: Stored,
    pairs: &Pairs<I, O, F>,
    b: &[f64],
    out: &mut [f32],
) {
    batch_lanes::<4, I, O, F>(k, st, pairs, b, out)
}

/// [`batch_lanes`] compiled for AVX-512, eight lanes: the same operations, the same
/// bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
unsafe fn batch_avx512<I: Pairing, O: Pairing, F: Fn(usize) -> f32>(
    k: &Kernel,
    st: Stored,
    pairs: &Pairs<I, O, F>,
    b: &[f64],
    out: &mut [f32],
) {
    batch_lanes::<8, I, O, F>(k, st, pairs, b, out)
}

/// The batch in blocks: each block's pairs framed W at a time, sorted by group, then each
/// group's pairs evaluated W at a time with its records collapsed once.
#[inline(always)]
pub(super) fn batch_lanes<const W: usize, I: Pairing, O: Pairing, F: Fn(usize) -> f32>(
    k: &Kernel,
    st: Stored,
    pairs: &Pairs<I, O, F>,
    b: &[f64],
    out: &mut [f32],
) {
    let (wi, wo, n) = (&pairs.wi, &pairs.wo, pairs.n);
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
    let counted = k.groups.len() <= COUNTED_GROUPS;
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
        let ng = k.groups.len();
        if counted {
            first[..ng + 1].fill(0);
        }
        for (p, f) in frames[..len].iter().enumerate() {
            if !f.valid.0[0] {
                out[start + p] = 0.0;
                continue;
            }
            let (g, t) = k.group_of(st.axis, f.theta.0[0]);
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
            if !k.groups[g].fast {
                for &p in members {
                    out[p as usize] = (pairs.fallback)(start + p as usize);
                }
                continue;
            }
            run_group::<W>(k, st, run, out);
        }
    }
}

/// One group's pairs of a block, W lanes at a time, its records collapsed once.
#[inline(always)]
fn run_group<const W: usize>(k: &Kernel, st: Stored, run: Run, out: &mut [f32]) {
    let (r0, count) = k.records(run.g);
    let mut sh = [[0.0f64; SMALL_SH]; 2];
    let mut amps = [NO_AMPS; 2];
    let mut p = [0usize; 2];
    for slot in 0..count {
        let rec = &k.recs[r0 + slot];
        collapse_sh(&st.res.vals, rec, run.b, &mut sh[slot]);
        collapse_amps(&st.res.vals, rec, run.b, &mut amps[slot]);
        p[slot] = (rec.p as usize).min(SMALL_SH);
    }
    let sh = [&sh[0][..p[0]], &sh[1][..p[1]]];
    for chunk in run.members.chunks(W) {
        let lane = |j: usize| chunk[j.min(chunk.len() - 1)] as usize;
        let f = gather::<W>(std::array::from_fn(|j| &run.frames[lane(j)]));
        let q = k.query(st.ends, run.g, &f, std::array::from_fn(|j| run.ts[lane(j)]));
        let s = k.sh_parts(run.g, q.wo, sh);
        let v = k
            .value(st.res, run.g, s, [&amps[0], &amps[1]], &q)
            .max(Lanes::splat(0.0));
        for (j, &at) in chunk.iter().enumerate() {
            out[at as usize] = v.0[j] as f32;
        }
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
