//! The one-wavelength kernel: how the kernel's route (`super::evaluator::Route::Kernel`) answers
//! direction pairs at one wavelength on a θ line, one at a time or many per call (the files
//! [`groups::takes`] takes: isotropic, no factor model, at most two lobes of kinds 2–4 per record, SH
//! level ≤ 6, ≤ 16 terms).
//!
//! A query blends one record or two neighbours, so the stored incidences split the queries into
//! *groups*: record r alone (at or beyond a stored θ) and the neighbours r, r + 1 (between them).
//! Each group's structure is settled when the file is opened: the SH level to evaluate, and the
//! lobe operations (a lobe shared by both records is blended and evaluated once, one held by a
//! single record is evaluated with its own shape). At a wavelength, a record's spectral terms
//! are applied to its stored values first ("collapsed": ã_j = Σ_k B_k·a_kj for its SH rows and
//! likewise for its lobe amplitudes), once per group and block of pairs rather than once per
//! pair. The arithmetic is written once over `Lanes`: a block's pairs are sorted by group
//! and run four lanes at a time (AVX2), eight (AVX-512), or one (without AVX2), so every
//! pair's value is the same bits on every CPU and in any batch. The formulas are those of
//! `spec/EVALUATION.md` ("Reconstruction", "Between stored incidences", "Lobes"); the order of
//! the sums and the `exp` and `ln` (`Lanes::exp`, `Lanes::ln`, within 1 ulp) are the
//! kernel's own, which "Rounding" allows. `Evaluator::eval` at one wavelength is this kernel with
//! one pair and one lane, so `eval` and `eval_batch` give the same bits; [`crate::Decoder::at`]
//! collapses every record once per wavelength ([`groups::Collapsed`]) and evaluates each query from
//! them. The kernel reads the resident arrays and the θ axis it is given; the few queries it
//! does not take (a group whose blended peak may vanish) it hands back to its caller, which
//! answers them on the general path. The θ bracket (`Axis::neighbours`), the θ clamp
//! (`clamp_incidence`) and the shared shapes' blend (`model::lobes::blend_shape`) are the
//! ones every route uses. A baked view (`crate::decode::baked`) runs the same groups with each
//! record's SH part read from its grids, its shapes blended ahead (`baked.rs`), its lobes'
//! powers from tables rather than the C library (`power.rs`).

pub(crate) mod baked;
mod formulas;
pub(crate) mod groups;
pub(crate) mod lanes_batch;
mod power;
pub(crate) mod width;

#[cfg(test)]
mod tests;
