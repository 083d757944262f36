//! Many direction pairs per call: what a wavefront renderer, a vectorised language or a
//! precomputation hands the decoder. Per batch, each requested wavelength's spectral basis
//! values (or, for many wavelengths of a tabulated basis, its cell among the nodes) are computed
//! once ([`Spectra`]); per run of pairs with the same incident direction, the incident side of
//! the query (records, weights, blended lobe shapes) is computed once ([`records`]). The values
//! are exactly [`Decoder::eval`](crate::Decoder::eval)'s: the same operations in the same
//! order, through the same shortcuts (one wavelength's terms before the records, node sums for
//! many wavelengths). Which route a batch takes is the evaluator's (`super::evaluator`).

use super::records::blend::{shapes, Incident, LobeShape};
use super::records::general::{takes_one_wavelength, value_at, with_coefficients};
use super::records::incidence::Incidences;
use super::records::lattice::{unit_above, QueryFrame};
use super::records::resident::Resident;
use crate::error::{Error, Result};
use crate::model::material::MAX_LOBES;
use crate::model::spectral::{Cell, SpectrumEvaluator, NODE_SUMS};

/// Basis values kept for a batch: K·M of them at most (8 KiB on the stack).
const BASIS_VALUES: usize = 1024;
/// Wavelength cells kept for a batch (8 KiB on the stack).
const CELLS: usize = 512;

/// The incident side of the current run of pairs; None when ωi gives ρ = 0 (zero, not finite,
/// below the horizon).
type Cached = Option<(QueryFrame, Incident)>;

/// A batch's pairs and steps through its slices, once they are checked ([`check`]): n pairs,
/// pair i = (wi\[i·wi_step\], wo\[i·wo_step\]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shape {
    pub n: usize,
    pub wi_step: usize,
    pub wo_step: usize,
}

/// [`crate::Decoder::eval_batch`]'s slices checked (nothing is written on an error): as many
/// incident as outgoing directions (or one of either) and room for every value.
pub(crate) fn check(
    wi: &[[f32; 3]],
    wo: &[[f32; 3]],
    wavelengths: &[f32],
    out: &[f32],
) -> Result<Shape> {
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
    Ok(Shape {
        n,
        wi_step: usize::from(wi.len() != 1),
        wo_step: usize::from(wo.len() != 1),
    })
}

/// A batch's wavelengths with what is computed once for them: B_k(λ_j) for every requested
/// wavelength, node-major by wavelength (NaN marks a wavelength that is not finite: ρ = 0
/// there), when K·M fit; and, for many wavelengths of a tabulated basis, each one's cell among
/// the nodes (`eval` interpolates node sums, so the batch does).
pub(crate) struct Spectra<'a> {
    wavelengths: &'a [f32],
    k: usize,
    basis: [f64; BASIS_VALUES],
    tabulated: bool,
    cells: [Cell; CELLS],
    celled: bool,
}

impl<'a> Spectra<'a> {
    pub(crate) fn new(res: &Resident, wavelengths: &'a [f32]) -> Self {
        let (k, m) = (res.spectrum.terms(), wavelengths.len());
        let mut basis = [0.0f64; BASIS_VALUES];
        let tabulated = k * m <= BASIS_VALUES;
        if tabulated {
            for (j, &l) in wavelengths.iter().enumerate() {
                let row = &mut basis[j * k..(j + 1) * k];
                if (l as f64).is_finite() {
                    res.spectrum.basis(l as f64, row);
                } else {
                    row.fill(f64::NAN);
                }
            }
        }
        let mut cells = [Cell { i: 0, f: 0.0 }; CELLS];
        let celled = res.spectrum.uses_node_sums(m) && m <= CELLS;
        if celled {
            for (cell, &l) in cells.iter_mut().zip(wavelengths) {
                let l = l as f64;
                if l.is_finite() {
                    *cell = res.spectrum.cell_of(l);
                }
            }
        }
        Spectra {
            wavelengths,
            k,
            basis,
            tabulated,
            cells,
            celled,
        }
    }

    /// The basis values, when they were kept.
    #[inline(always)]
    pub(crate) fn basis(&self) -> Option<&[f64]> {
        self.tabulated
            .then(|| &self.basis[..self.k * self.wavelengths.len()])
    }

    #[inline(always)]
    fn basis_or_empty(&self) -> &[f64] {
        self.basis().unwrap_or(&[])
    }

    #[inline(always)]
    fn cells(&self) -> &[Cell] {
        &self.cells[..if self.celled {
            self.wavelengths.len()
        } else {
            0
        }]
    }
}

/// `out[i·M..(i+1)·M]` = ρ(wi(i), wo(i), λ) for i < n on the general path over the records
/// (`res`, placed by `places`), at the batch's wavelengths `spectra`. The caller checked that
/// `out` holds n·M values.
pub(crate) fn records(
    res: &Resident,
    places: &Incidences,
    spectra: &Spectra,
    wi: impl Fn(usize) -> [f32; 3],
    wo: impl Fn(usize) -> [f32; 3],
    n: usize,
    out: &mut [f32],
) {
    let m = spectra.wavelengths.len();
    let basis = spectra.basis_or_empty();
    let mut key: Option<[u32; 3]> = None;
    let mut held = [LobeShape::default(); MAX_LOBES];
    // The node sums' scratch, zeroed once per batch rather than once per pair (1 KiB): each
    // pair writes the sums it reads.
    let mut sums = [0.0f64; NODE_SUMS];
    let mut cached: Cached = None;
    for (i, row) in out[..n * m].chunks_exact_mut(m).enumerate() {
        let a = wi(i);
        let bits = a.map(f32::to_bits);
        if key != Some(bits) {
            // A pair whose wi differs from the next one's is evaluated as `eval` would (keeping
            // the incident side costs more than it saves); a run of equal wi keeps it.
            if i + 1 >= n || wi(i + 1).map(f32::to_bits) != bits {
                key = None;
                single(res, places, a, wo(i), spectra, &mut sums, row);
                continue;
            }
            key = Some(bits);
            cached = unit_above(a).map(|v| {
                let q = places.query_frame(v);
                (q, places.incident(res, q.theta, q.phi, Some(q.wi)))
            });
            if let Some((_, inc)) = &cached {
                shapes(res, inc, &mut held);
            }
        }
        let Some((q, inc)) = &cached else {
            row.fill(0.0);
            continue;
        };
        let Some(b) = unit_above(wo(i)) else {
            row.fill(0.0);
            continue;
        };
        let w = q.in_frame(b);
        if m == 1 && !basis.is_empty() && takes_one_wavelength(res, inc) {
            row[0] = one(res, inc, Some(&held), w, basis);
            continue;
        }
        with_coefficients(res, inc, Some(&held), w, |c| {
            finish(res, c, spectra, &mut sums, row)
        });
    }
}

/// One pair on its own, as `Evaluator::eval` computes it, with the batch's basis values.
#[inline(always)]
fn single(
    res: &Resident,
    places: &Incidences,
    a: [f32; 3],
    b: [f32; 3],
    spectra: &Spectra,
    sums: &mut [f64; NODE_SUMS],
    row: &mut [f32],
) {
    let (Some(a), Some(b)) = (unit_above(a), unit_above(b)) else {
        row.fill(0.0);
        return;
    };
    let q = places.query_frame(a);
    let inc = places.incident(res, q.theta, q.phi, Some(q.wi));
    let basis = spectra.basis_or_empty();
    if spectra.wavelengths.len() == 1 && !basis.is_empty() && takes_one_wavelength(res, &inc) {
        row[0] = one(res, &inc, None, q.in_frame(b), basis);
        return;
    }
    with_coefficients(res, &inc, None, q.in_frame(b), |c| {
        finish(res, c, spectra, sums, row)
    });
}

/// ρ at the batch's one wavelength for a query whose incident side is `inc`, as `eval`
/// computes it.
#[inline(always)]
fn one(
    res: &Resident,
    inc: &Incident,
    shapes: Option<&[LobeShape; MAX_LOBES]>,
    wo: [f64; 3],
    basis: &[f64],
) -> f32 {
    if basis[0].is_nan() {
        return 0.0;
    }
    value_at(res, inc, shapes, wo, &basis[..inc.terms]).max(0.0) as f32
}

/// ρ(λ_j) = max(0, Σ_k c_k·B_k(λ_j)) from the batch's cells (node sums interpolated, `sums`
/// their scratch) or basis values, or, when there were too many to keep, as `eval` computes
/// them.
#[inline(always)]
fn finish(
    res: &Resident,
    c: &[f64],
    spectra: &Spectra,
    sums: &mut [f64; NODE_SUMS],
    row: &mut [f32],
) {
    let (cells, wavelengths, k) = (spectra.cells(), spectra.wavelengths, spectra.k);
    let basis = spectra.basis_or_empty();
    if !cells.is_empty() {
        // `eval`'s node sums, interpolated at the batch's cells.
        let sums = res.spectrum.node_sums(c, sums);
        for ((o, &cell), &l) in row.iter_mut().zip(cells).zip(wavelengths) {
            *o = if (l as f64).is_finite() {
                SpectrumEvaluator::from_node_sums(sums, cell).max(0.0) as f32
            } else {
                0.0
            };
        }
        return;
    }
    if basis.is_empty() || res.spectrum.uses_node_sums(wavelengths.len()) {
        // As `eval` computes it.
        res.spectrum.eval_clamped(c, wavelengths, row);
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
