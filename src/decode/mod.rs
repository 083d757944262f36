//! What a renderer compiles: the decoder (open a file once, answer ρ(ωi, ωo, λ) without
//! allocating), blending between stored incidences, importance sampling, spectrum to colour and
//! the C ABI. Uses [`crate::model`] and [`crate::format`] only.

mod at_wavelength;
mod batch;
mod blend;
pub mod capi;
pub(crate) mod cie;
pub mod color;
pub mod decoder;
mod draw;
mod evaluator;
mod general_coefficients;
mod general_one_wavelength;
mod gpu_factor;
pub mod gpu_layout;
pub(crate) mod gpu_pack;
mod gpu_sampling;
mod gpu_warped;
pub(crate) mod gpu_words;
mod kernel;
mod lattice;
mod proposal;
mod resident;
pub mod sampling;
mod sums;
mod theta_line;
mod warped;

pub use at_wavelength::AtWavelength;
pub use decoder::Decoder;
pub use draw::Sample;
pub use warped::Residency;
// The encoder integrates the warped tables' VNDF as the decoder does.
#[cfg(feature = "encode")]
pub(crate) use warped::vndf_totals;
