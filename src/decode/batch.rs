//! Many direction pairs per call: what a wavefront renderer, a vectorised language or a
//! precomputation hands the decoder. Per batch, each requested wavelength's spectral basis
//! values (or, for many wavelengths of a tabulated basis, its cell among the nodes) are computed
//! once; per run of pairs with the same incident direction, the incident side of the query
//! (records, weights, blended lobe shapes) is computed once. The values are exactly
//! [`Decoder::eval`](crate::Decoder::eval)'s: the same operations in the same order, through
//! the same shortcuts (one wavelength on a θ line, node sums for many wavelengths).

use super::blend::{Incident, LobeShape, Shapes};
use super::evaluator::{Evaluator, SMALL_TERMS};
use super::kernel::lanes_batch::Pairs;
use super::lattice::{upper, QueryFrame};
use crate::error::{Error, Result};
use crate::model::spectral::{Cell, SpectrumEvaluator, NODE_SUMS};

/// Basis values kept for a batch: K·M of them at most (8 KiB on the stack).
const BASIS_VALUES: usize = 1024;
/// Wavelength cells kept for a batch (8 KiB on the stack).
const CELLS: usize = 512;

/// The incident side of the current run of pairs; None when ωi gives ρ = 0 (zero, not finite,
/// below the horizon).
type Cached = Option<(QueryFrame, Incident)>;

/// [`crate::Decoder::eval_batch`]: the slices checked (nothing written on an error), then
/// [`eval_batch`].
pub(crate) fn checked(
    ev: &Evaluator,
    wi: &[[f32; 3]],
    wo: &[[f32; 3]],
    wavelengths: &[f32],
    out: &mut [f32],
) -> Result<()> {
    let n = match (wi.len(), wo.len()) {
        (a, b) if a == b => a,
        (1, b) => b,
        (a, 1) => a,
        (a, b) => {
            return Err(Error::Parameter(format!(
                "eval_batch: {a} incident and {b} outgoing directions (give as many of \
                     each, or one of either)"
            )))
        }
    };
    let need = n.checked_mul(wavelengths.len());
    if need.is_none_or(|need| out.len() < need) {
        return Err(Error::Parameter(format!(
            "eval_batch: {n} pairs × {} wavelengths need {} output values, {} given",
            wavelengths.len(),
            n.saturating_mul(wavelengths.len()),
            out.len()
        )));
    }
    let (wi_step, wo_step) = (usize::from(wi.len() != 1), usize::from(wo.len() != 1));
    eval_batch(
        ev,
        |i| wi[i * wi_step],
        |i| wo[i * wo_step],
        n,
        wavelengths,
        out,
    );
    Ok(())
}

/// `out[i·M..(i+1)·M]` = ρ(wi(i), wo(i), λ) for i < n, M = `wavelengths.len()`. The caller
/// checked that `out` holds n·M values.
pub(crate) fn eval_batch(
    ev: &Evaluator,
    wi: impl Fn(usize) -> [f32; 3],
    wo: impl Fn(usize) -> [f32; 3],
    n: usize,
    wavelengths: &[f32],
    out: &mut [f32],
) {
    let m = wavelengths.len();
    if m == 0 || n == 0 {
        return;
    }
    if ev.per_pair() {
        // A factor model or warped tables depend on each pair's own directions: nothing to
        // share per run.
        for (i, row) in out[..n * m].chunks_exact_mut(m).enumerate() {
            ev.eval(wi(i), wo(i), wavelengths, row);
        }
        return;
    }
    let k = ev.res.spectrum.terms();
    // B_k(λ_j) for every requested wavelength, node-major by wavelength; NaN marks a
    // wavelength that is not finite (ρ = 0 there).
    let mut basis = [0.0f64; BASIS_VALUES];
    let tabulated = k * m <= BASIS_VALUES;
    if tabulated {
        for (j, &l) in wavelengths.iter().enumerate() {
            let row = &mut basis[j * k..(j + 1) * k];
            if (l as f64).is_finite() {
                ev.res.spectrum.basis(l as f64, row);
            } else {
                row.fill(f64::NAN);
            }
        }
    }
    let basis = &basis[..if tabulated { k * m } else { 0 }];
    // Many wavelengths of a tabulated basis: `eval` interpolates node sums, so the batch does,
    // with each wavelength's cell found once.
    let mut cells = [Cell { i: 0, f: 0.0 }; CELLS];
    let cells = if ev.res.spectrum.uses_node_sums(m) && m <= CELLS {
        for (cell, &l) in cells.iter_mut().zip(wavelengths) {
            let l = l as f64;
            if l.is_finite() {
                *cell = ev.res.spectrum.cell_of(l);
            }
        }
        &cells[..m]
    } else {
        &cells[..0]
    };
    if let (Some((kernel, st)), 1, true) = (ev.kernel_input(), m, tabulated) {
        // One wavelength on a θ line: the kernel, its pairs sorted by group, W lanes at once.
        let fallback = |i: usize| ev.line_fallback(wi(i), wo(i), basis);
        let pairs = Pairs {
            wi: &wi,
            wo: &wo,
            n,
            fallback,
        };
        kernel.batch(st, &pairs, basis, out);
        return;
    }
    if ev.on_line() {
        // A θ line: each pair as `eval` computes it (the line path's incident side costs less
        // than keeping it).
        for (i, row) in out[..n * m].chunks_exact_mut(m).enumerate() {
            line(ev, wi(i), wo(i), basis, cells, k, wavelengths, row);
        }
        return;
    }
    let mut key: Option<[u32; 3]> = None;
    let mut shapes = [LobeShape::default(); crate::model::material::MAX_LOBES];
    let mut cached: Cached = None;
    for (i, row) in out[..n * m].chunks_exact_mut(m).enumerate() {
        let a = wi(i);
        let bits = a.map(f32::to_bits);
        if key != Some(bits) {
            // A pair whose wi differs from the next one's is evaluated as `eval` would (keeping
            // the incident side costs more than it saves); a run of equal wi keeps it.
            if i + 1 >= n || wi(i + 1).map(f32::to_bits) != bits {
                key = None;
                single(ev, a, wo(i), basis, cells, k, wavelengths, row);
                continue;
            }
            key = Some(bits);
            cached = upper(a).map(|v| {
                let q = ev.query_frame(v);
                (q, ev.incident(q.theta, q.phi, Some(q.wi)))
            });
            if let Some((_, inc)) = &cached {
                ev.res.shapes(inc, &mut shapes);
            }
        }
        let Some((q, inc)) = &cached else {
            row.fill(0.0);
            continue;
        };
        let Some(b) = upper(wo(i)) else {
            row.fill(0.0);
            continue;
        };
        let w = q.in_frame(b);
        if m == 1 && !basis.is_empty() && ev.one_wavelength(inc) {
            row[0] = one(ev, inc, Some(&shapes), w, basis);
            continue;
        }
        ev.with_coefficients(inc, Some(&shapes), w, |c| {
            finish(ev, c, basis, cells, k, wavelengths, row)
        });
    }
}

/// One pair on its own, as [`Evaluator::eval`] computes it, with the batch's basis values.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn single(
    ev: &Evaluator,
    a: [f32; 3],
    b: [f32; 3],
    basis: &[f64],
    cells: &[Cell],
    k: usize,
    wavelengths: &[f32],
    row: &mut [f32],
) {
    let (Some(a), Some(b)) = (upper(a), upper(b)) else {
        row.fill(0.0);
        return;
    };
    let q = ev.query_frame(a);
    let inc = ev.incident(q.theta, q.phi, Some(q.wi));
    if wavelengths.len() == 1 && !basis.is_empty() && ev.one_wavelength(&inc) {
        row[0] = one(ev, &inc, None, q.in_frame(b), basis);
        return;
    }
    ev.outgoing(&inc, q.in_frame(b), |c| {
        finish(ev, c, basis, cells, k, wavelengths, row)
    });
}

/// One pair as `eval` computes it on the line path: one wavelength from its basis values
/// (NaN for a wavelength that is not finite), several from the coefficients.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn line(
    ev: &Evaluator,
    a: [f32; 3],
    b: [f32; 3],
    basis: &[f64],
    cells: &[Cell],
    k: usize,
    wavelengths: &[f32],
    row: &mut [f32],
) {
    let (Some(a), Some(b)) = (upper(a), upper(b)) else {
        row.fill(0.0);
        return;
    };
    if wavelengths.len() == 1 {
        row[0] = if basis[0].is_nan() {
            0.0
        } else {
            ev.line_value(a, b, basis).max(0.0) as f32
        };
        return;
    }
    let mut c = [0.0f64; SMALL_TERMS];
    let c = &mut c[..k];
    ev.line_coefficients(a, b, c);
    finish(ev, c, basis, cells, k, wavelengths, row);
}

/// ρ at the batch's one wavelength for a query whose incident side is `inc`, as `eval`
/// computes it off the line path.
#[inline(always)]
fn one(
    ev: &Evaluator,
    inc: &Incident,
    shapes: Option<&Shapes>,
    wo: [f64; 3],
    basis: &[f64],
) -> f32 {
    if basis[0].is_nan() {
        return 0.0;
    }
    ev.value_at(inc, shapes, wo, &basis[..inc.terms]).max(0.0) as f32
}

/// ρ(λ_j) = max(0, Σ_k c_k·B_k(λ_j)) from the batch's cells (node sums interpolated) or basis
/// values, or, when there were too many to keep, as `eval` computes them.
#[inline(always)]
fn finish(
    ev: &Evaluator,
    c: &[f64],
    basis: &[f64],
    cells: &[Cell],
    k: usize,
    wavelengths: &[f32],
    row: &mut [f32],
) {
    if !cells.is_empty() {
        // `eval`'s node sums, interpolated at the batch's cells.
        let mut sums = [0.0f64; NODE_SUMS];
        let sums = ev.res.spectrum.node_sums(c, &mut sums);
        for ((o, &cell), &l) in row.iter_mut().zip(cells).zip(wavelengths) {
            *o = if (l as f64).is_finite() {
                SpectrumEvaluator::from_node_sums(sums, cell).max(0.0) as f32
            } else {
                0.0
            };
        }
        return;
    }
    if basis.is_empty() || ev.res.spectrum.uses_node_sums(wavelengths.len()) {
        // As `eval` computes it.
        ev.res.spectrum.eval_clamped(c, wavelengths, row);
        return;
    }
    for (o, b) in row.iter_mut().zip(basis.chunks_exact(k)) {
        if b[0].is_nan() {
            *o = 0.0;
            continue;
        }
        let mut sum = 0.0;
        for (ck, bk) in c.iter().zip(b) {
            sum += ck * bk;
        }
        *o = sum.max(0.0) as f32;
    }
}
