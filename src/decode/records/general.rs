//! The general path over the records: any lattice, any lobe kind, lobes shared or not by the
//! blended records (`spec/EVALUATION.md`, "Reconstruction"). One bookkeeping, two results: the
//! blended coefficients c_0..c_{T*−1} at an outgoing direction (several wavelengths, the factor
//! model, `eval_deg`), or one wavelength's value with the terms summed before the records,
//! Σ_r w_r·Σ_k B_k·(…), so that no coefficient vector is formed ("Rounding"). The kernel
//! (`super::super::kernel`) hands the pairs it does not take to [`value_at`].

use super::blend::{shared_shape, Incident, LobeShape, Shapes};
use super::dot::{dot_f32, dot_terms};
use super::resident::{Rec, Resident};
use crate::model::angles::angle_between;
use crate::model::lobes::lobe_values;
use crate::model::material::{LobeKind, MAX_TERMS};
use crate::model::sh::{sh_count, ShBasis, MAX_SH_LEVEL};

/// Files within SH level 6 and 16 terms (every file the encoder writes by default) evaluate with
/// small scratch arrays: zeroing the format's maxima (441 SH values, 256 terms) would cost more
/// than the evaluation. The kernel takes files within the same bounds.
pub(crate) const SMALL_SH: usize = sh_count(6);
pub(crate) const SMALL_TERMS: usize = 16;

const MAX_SH: usize = sh_count(MAX_SH_LEVEL);

/// The shape of a shared lobe at position `li`: from `shapes` when given (a run of pairs that
/// share the incidence), else blended now.
#[inline(always)]
fn shape_of(res: &Resident, inc: &Incident, shapes: Option<&Shapes>, li: usize) -> LobeShape {
    match shapes {
        Some(s) => s[li],
        None => shared_shape(res, inc, li),
    }
}

/// A record's own lobe `li` (not shared): its stored parameters as a shape.
#[inline(always)]
fn own_shape(res: &Resident, rec: &Rec, li: usize) -> LobeShape {
    let mut shape = LobeShape {
        peak: rec.peak,
        p: [0.0; 6],
    };
    for (p, &v) in shape.p.iter_mut().zip(res.params(rec, res.lobe(rec, li))) {
        *p = v as f64;
    }
    shape
}

/// Computes the blended coefficients c_0..c_{T*−1} at the unit outgoing vector `wo` (records'
/// frame) into scratch arrays on the stack sized for the query (SH level ≤ 2 and ≤ 8 terms,
/// level ≤ 6 and ≤ 16 terms, or the maxima) and passes them to `f`. `shapes`, when given, holds
/// [`super::blend::shapes`] of `inc`.
#[inline(always)]
pub(crate) fn with_coefficients<R>(
    res: &Resident,
    inc: &Incident,
    shapes: Option<&Shapes>,
    wo: [f64; 3],
    f: impl FnOnce(&[f64]) -> R,
) -> R {
    let t = inc.terms;
    if inc.level <= 2 && t <= 8 {
        let mut c = [0.0f64; 8];
        coefficients::<{ sh_count(2) }>(res, inc, shapes, wo, &mut c[..t]);
        f(&c[..t])
    } else if inc.level <= 6 && t <= SMALL_TERMS {
        let mut c = [0.0f64; SMALL_TERMS];
        coefficients::<SMALL_SH>(res, inc, shapes, wo, &mut c[..t]);
        f(&c[..t])
    } else {
        let mut c = [0.0f64; MAX_TERMS];
        coefficients::<MAX_SH>(res, inc, shapes, wo, &mut c[..t]);
        f(&c[..t])
    }
}

/// c\[k\] = the blended coefficients at `wo`; `c` holds T* values.
#[inline(always)]
fn coefficients<const NSH: usize>(
    res: &Resident,
    inc: &Incident,
    shapes: Option<&Shapes>,
    wo: [f64; 3],
    c: &mut [f64],
) {
    let recs = &inc.blend.rec[..inc.blend.n];
    let ws = &inc.blend.w[..inc.blend.n];
    if inc.level == 0 {
        // Level 0 (records whose shape is all lobe, as the encoder writes Phong's and GGX's θ
        // lines): one SH function, the constant Y_0^0 (what `eval_to_level` gives at level 0),
        // so no SH evaluation and no dot product. A one-value `dot_f32` is ((0 + x) + 0) +
        // (0 + 0), x itself but for −0 turned +0, a sign that `acc` (starting at +0, never −0)
        // absorbs: the bits are the general loop's.
        let y0 = ShBasis::shared().constant();
        for (k, ck) in c.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (&r, &w) in recs.iter().zip(ws) {
                let rec = &res.recs[r];
                if k < rec.terms as usize {
                    acc += w * (res.vals[rec.sh as usize + k] as f64 * y0);
                }
            }
            *ck = acc;
        }
    } else {
        let mut y = [0.0f64; NSH];
        ShBasis::shared().eval_to_level(inc.level, wo, &mut y);
        // Term by term, every record's share summed in a register and written once.
        for (k, ck) in c.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (&r, &w) in recs.iter().zip(ws) {
                let rec = &res.recs[r];
                if k < rec.terms as usize {
                    let p = sh_count(rec.level as usize);
                    let at = rec.sh as usize + k * p;
                    acc += w * dot_f32(&res.vals[at..at + p], &y[..p]);
                }
            }
            *ck = acc;
        }
    }
    // Inlined at both of each_lobe's calls: a call per lobe costs as much as its sums.
    each_lobe(
        res,
        inc,
        shapes,
        wo,
        #[inline(always)]
        |recs, ws, li, lobe| match lobe {
            LobeAt::Gaussian(peak) => add_gaussian(res, c, recs, ws, li, wo, peak),
            LobeAt::Values(v) => add_amplitudes(res, c, recs, ws, li, v),
        },
    );
}

/// A lobe at the outgoing direction, as [`each_lobe`] hands it on.
enum LobeAt<'a> {
    /// An angle-Gaussian lobe with this peak: its widths are blended per term, so the caller
    /// evaluates it against its amplitudes.
    Gaussian([f64; 3]),
    /// Any other lobe's values, evaluated once for the records it is handed on with.
    Values(&'a [f64]),
}

/// Every lobe position of the records `inc` blends, at the unit outgoing vector `wo`: a
/// position they share once, with its blended shape (from `shapes` when given) and every
/// record's weight; any other position once per record that has a lobe there, with that
/// record's own shape and weight alone. `f` receives the records, their weights, the position
/// and the lobe, in that order (what both results sum in).
#[inline(always)]
fn each_lobe(
    res: &Resident,
    inc: &Incident,
    shapes: Option<&Shapes>,
    wo: [f64; 3],
    mut f: impl FnMut(&[usize], &[f64], usize, LobeAt<'_>),
) {
    let recs = &inc.blend.rec[..inc.blend.n];
    let ws = &inc.blend.w[..inc.blend.n];
    // The microfacet geometry depends on the directions alone: computed at most once.
    let mut geometry = None;
    for li in 0..inc.nlobes {
        if inc.shared & (1 << li) != 0 {
            let kind = res.lobe(&res.recs[recs[0]], li).kind;
            let shape = shape_of(res, inc, shapes, li);
            match kind {
                LobeKind::AngleGaussian => f(recs, ws, li, LobeAt::Gaussian(shape.peak)),
                _ => {
                    let (v, nv) =
                        lobe_values(kind, &shape.p, shape.peak, inc.wi, wo, &mut geometry);
                    f(recs, ws, li, LobeAt::Values(&v[..nv]));
                }
            }
        } else {
            for (r, w) in recs.iter().zip(ws) {
                let rec = &res.recs[*r];
                if li >= rec.nlobes as usize {
                    continue;
                }
                let (r, w) = (std::slice::from_ref(r), std::slice::from_ref(w));
                let kind = res.lobe(rec, li).kind;
                if kind == LobeKind::AngleGaussian {
                    f(r, w, li, LobeAt::Gaussian(rec.peak));
                    continue;
                }
                let shape = own_shape(res, rec, li);
                let (v, nv) = lobe_values(kind, &shape.p, shape.peak, inc.wi, wo, &mut geometry);
                f(r, w, li, LobeAt::Values(&v[..nv]));
            }
        }
    }
}

/// Adds angle-Gaussian lobe `li` of the records `recs` (weights `ws`), with peak `peak`: per
/// term, the amplitudes blended linearly and the widths geometrically over the records that
/// have the term.
fn add_gaussian(
    res: &Resident,
    c: &mut [f64],
    recs: &[usize],
    ws: &[f64],
    li: usize,
    wo: [f64; 3],
    peak: [f64; 3],
) {
    let a2 = angle_between(wo, peak).powi(2);
    if recs.len() == 1 {
        let rec = &res.recs[recs[0]];
        let l = res.lobe(rec, li);
        let (amp, width) = (res.amplitudes(rec, l, 0), res.params(rec, l));
        for ((ck, &p), &b) in c.iter_mut().zip(amp).zip(width) {
            *ck += ws[0] * (p as f64 * (-a2 / b as f64).exp());
        }
        return;
    }
    for (kk, ck) in c.iter_mut().enumerate() {
        let (mut lw, mut wsum, mut amp) = (0.0, 0.0, 0.0);
        for (&r, &w) in recs.iter().zip(ws) {
            let rec = &res.recs[r];
            if kk < rec.terms as usize {
                let l = res.lobe(rec, li);
                lw += w * res.ln_params[l.par as usize + kk];
                wsum += w;
                amp += w * res.vals[l.amp as usize + kk] as f64;
            }
        }
        if wsum > 0.0 {
            *ck += amp * (-a2 / (lw / wsum).exp()).exp();
        }
    }
}

/// c\[k\] += Σ_r w_r·Σ_j v\[j\]·amplitude_r\[j·T_r + k\] over the records (weights `ws`) that
/// have term k: lobe `li`'s values `v`, evaluated once, weighted by every record's amplitudes;
/// each c\[k\] is summed in a register and written once.
#[inline(always)]
fn add_amplitudes(res: &Resident, c: &mut [f64], recs: &[usize], ws: &[f64], li: usize, v: &[f64]) {
    // One record or two neighbours, one value (cosine power) or four (microfacet): the usual
    // cases with their loops' bounds known, so that the compiler unrolls them (the same
    // operations in the same order).
    match (recs.len(), v.len()) {
        (1, 1) => add_amplitudes_n::<1, 1>(res, c, recs, ws, li, v),
        (1, 4) => add_amplitudes_n::<1, 4>(res, c, recs, ws, li, v),
        (2, 1) => add_amplitudes_n::<2, 1>(res, c, recs, ws, li, v),
        (2, 4) => add_amplitudes_n::<2, 4>(res, c, recs, ws, li, v),
        _ => add_amplitudes_any(res, c, recs, ws, li, v),
    }
}

/// [`add_amplitudes`] for N records and NV values.
#[inline(always)]
fn add_amplitudes_n<const N: usize, const NV: usize>(
    res: &Resident,
    c: &mut [f64],
    recs: &[usize],
    ws: &[f64],
    li: usize,
    v: &[f64],
) {
    let (Some(recs), Some(ws), Some(v)) = (
        recs.first_chunk::<N>(),
        ws.first_chunk::<N>(),
        v.first_chunk::<NV>(),
    ) else {
        return;
    };
    // Per record: w·v_j and its amplitudes (NV rows of its terms).
    let mut scaled = [[0.0f64; NV]; N];
    let mut amps: [&[f32]; N] = [&[]; N];
    for i in 0..N {
        let rec = &res.recs[recs[i]];
        let start = res.lobe(rec, li).amp as usize;
        amps[i] = &res.vals[start..start + NV * rec.terms as usize];
        for j in 0..NV {
            scaled[i][j] = ws[i] * v[j];
        }
    }
    for (k, ck) in c.iter_mut().enumerate() {
        let mut acc = 0.0;
        for i in 0..N {
            let t = amps[i].len() / NV;
            if k < t {
                for j in 0..NV {
                    acc += scaled[i][j] * amps[i][j * t + k] as f64;
                }
            }
        }
        *ck += acc;
    }
}

/// [`add_amplitudes`] for any number of records and values.
#[inline(always)]
fn add_amplitudes_any(
    res: &Resident,
    c: &mut [f64],
    recs: &[usize],
    ws: &[f64],
    li: usize,
    v: &[f64],
) {
    let nv = v.len();
    // Per record: w·v_j, where its amplitudes start, and its terms.
    let mut scaled = [[0.0f64; 4]; 4];
    let mut start = [0usize; 4];
    let mut terms = [0usize; 4];
    for (i, (&r, &w)) in recs.iter().zip(ws).enumerate() {
        let rec = &res.recs[r];
        start[i] = res.lobe(rec, li).amp as usize;
        terms[i] = rec.terms as usize;
        for (s, &vj) in scaled[i].iter_mut().zip(v) {
            *s = w * vj;
        }
    }
    let n = recs.len();
    for (k, ck) in c.iter_mut().enumerate() {
        let mut acc = 0.0;
        for i in 0..n {
            let t = terms[i];
            if k < t {
                let amp = &res.vals[start[i] + k..start[i] + k + (nv - 1) * t + 1];
                for (j, &s) in scaled[i][..nv].iter().enumerate() {
                    acc += s * amp[j * t] as f64;
                }
            }
        }
        *ck += acc;
    }
}

/// Whether a query at incidence `inc` takes [`value_at`] for one wavelength: no factor model,
/// and the small arrays suffice.
#[inline(always)]
pub(crate) fn takes_one_wavelength(res: &Resident, inc: &Incident) -> bool {
    res.factor.is_none() && inc.terms <= SMALL_TERMS && inc.level <= 6
}

/// ρ at one wavelength before the clamp, from that wavelength's basis values `b`
/// (B_0..B_{T*−1}): each record's terms weighted by w_r·B_k before its sums, so no coefficient
/// vector is formed (terms before records: "Rounding"). `shapes`, when given, holds
/// [`super::blend::shapes`] of `inc`. The caller checked [`takes_one_wavelength`].
#[inline(always)]
pub(crate) fn value_at(
    res: &Resident,
    inc: &Incident,
    shapes: Option<&Shapes>,
    wo: [f64; 3],
    b: &[f64],
) -> f64 {
    // The SH values on the stack, sized for the query: zeroing 49 for a level-0 record would
    // cost more than its evaluation.
    if inc.level <= 2 {
        value_at_sized::<{ sh_count(2) }>(res, inc, shapes, wo, b)
    } else {
        value_at_sized::<SMALL_SH>(res, inc, shapes, wo, b)
    }
}

#[inline(always)]
fn value_at_sized<const NSH: usize>(
    res: &Resident,
    inc: &Incident,
    shapes: Option<&Shapes>,
    wo: [f64; 3],
    b: &[f64],
) -> f64 {
    let recs = &inc.blend.rec[..inc.blend.n];
    let ws = &inc.blend.w[..inc.blend.n];
    let mut y = [0.0f64; NSH];
    ShBasis::shared().eval_to_level(inc.level, wo, &mut y);
    let mut acc = 0.0;
    for (&r, &w) in recs.iter().zip(ws) {
        let rec = &res.recs[r];
        acc += w * if inc.level == 0 {
            // Level 0 (records whose shape is all lobe): one SH function.
            let t = rec.terms as usize;
            dot_terms(&res.vals[rec.sh as usize..rec.sh as usize + t], &b[..t]) * y[0]
        } else {
            sh_sum(res, rec, &y, b)
        };
    }
    // One wavelength of angle-Gaussian lobes: their coefficients against `b`.
    let gaussian = |recs: &[usize], ws: &[f64], li: usize, peak: [f64; 3]| {
        let mut c = [0.0f64; SMALL_TERMS];
        let c = &mut c[..b.len()];
        add_gaussian(res, c, recs, ws, li, wo, peak);
        c.iter().zip(b).map(|(c, b)| c * b).sum::<f64>()
    };
    each_lobe(res, inc, shapes, wo, |recs, ws, li, lobe| {
        acc += match lobe {
            LobeAt::Gaussian(peak) => gaussian(recs, ws, li, peak),
            LobeAt::Values(v) => amplitudes_at(res, recs, ws, li, v, b),
        }
    });
    acc
}

/// Σ_k B_k·Σ_j A_kj·y_j: a record's SH part at one wavelength (basis values `b`, SH values `y`
/// up to at least its level).
#[inline(always)]
fn sh_sum(res: &Resident, rec: &Rec, y: &[f64], b: &[f64]) -> f64 {
    let (t, p) = (rec.terms as usize, sh_count(rec.level as usize));
    let a = &res.vals[rec.sh as usize..rec.sh as usize + t * p];
    let mut sum = 0.0;
    for (row, &bk) in a.chunks_exact(p).zip(b) {
        sum += bk * dot_f32(row, &y[..p]);
    }
    sum
}

/// Σ_r w_r·Σ_j v\[j\]·Σ_k B_k·amplitude_r\[j·T_r + k\]: lobe `li`'s values `v` weighted by every
/// record's amplitudes at one wavelength (basis values `b`).
#[inline(always)]
fn amplitudes_at(
    res: &Resident,
    recs: &[usize],
    ws: &[f64],
    li: usize,
    v: &[f64],
    b: &[f64],
) -> f64 {
    let mut acc = 0.0;
    for (&r, &w) in recs.iter().zip(ws) {
        let rec = &res.recs[r];
        let t = rec.terms as usize;
        let start = res.lobe(rec, li).amp as usize;
        let amp = &res.vals[start..start + v.len() * t];
        let mut sum = 0.0;
        for (row, &vj) in amp.chunks_exact(t).zip(v) {
            sum += vj * dot_terms(row, &b[..t]);
        }
        acc += w * sum;
    }
    acc
}
