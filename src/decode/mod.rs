//! What a renderer compiles: the decoder (open a file once, answer ρ(ωi, ωo, λ) without
//! allocating), blending between stored incidences, importance sampling, spectrum to colour,
//! the flat device layout and the C ABI. Uses [`crate::model`] and [`crate::format`] only.
//!
//! The facade ([`decoder`], [`AtWavelength`], [`Baked`]) sits on the evaluator (`evaluator.rs`), which
//! chooses each file's route once and is the one place that matches on it; the routes live in
//! their rooms: `records/` (the records' general path and what places a query among them),
//! `kernel/` (one wavelength on a θ line, in lanes), `factor.rs` (the factor model) and
//! `warped/` (warped tables); `baked/` is the kernel's route with each record's SH part read
//! from octahedral grids (a view made with a tolerance). `batch.rs` is the batch over the records, `sampling/` importance
//! sampling, `color/` spectrum to colour, `gpu_layout/` the device layout, `capi.rs` the C ABI.

mod at_wavelength;
pub mod baked;
mod batch;
pub mod capi;
pub mod color;
pub mod decoder;
mod evaluator;
mod factor;
pub mod gpu_layout;
mod kernel;
mod records;
pub mod sampling;
mod warped;

pub use at_wavelength::AtWavelength;
pub use baked::Baked;
pub use decoder::Decoder;
pub use sampling::sample::Sample;
pub use warped::Residency;
// The encoder integrates the warped tables' VNDF as the decoder does.
#[cfg(feature = "encode")]
pub(crate) use warped::vndf_totals;
