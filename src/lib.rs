//! # sbrdf
//!
//! A compact, archival codec for spectral BRDFs. Per incident direction, each spectral
//! coefficient of the BRDF is stored as a real spherical-harmonic expansion over outgoing
//! directions plus specular lobes (beyond Xu & Sun, "Efficient Representation of Spectral BRDFs").
//!
//! * [`Decoder`] opens a file and evaluates ρ(ωi, ωo, λ); it needs no optional feature, so a
//!   renderer can depend on `sbrdf` with `default-features = false`.
//! * With the `encode` feature, [`encode`] fits sampled BRDFs ([`encode::SampleSet`]).
//! * With the `cli` feature (default), the `sbrdf` program, the CSV and spectral-EXR readers
//!   ([`io`]) and the pictures and studies ([`report`]).
//!
//! The folders are the architecture; dependencies point one way, down this list:
//!
//! | room | feature | what it is for |
//! | --- | --- | --- |
//! | [`model`] | always | what a file holds and the math both sides share |
//! | [`format`](mod@format) | always | bytes: signature, chunks and CRCs, limits, reader and writer |
//! | [`decode`] | always | the decoder, incidence blending, sampling, colour, the C ABI |
//! | [`gpu`] | always | the WGSL module that evaluates the decoder's flat device layout |
//! | [`preview`] | `preview` | the preview sphere's geometry and tone curve, for CPU and GPU renders |
//! | [`encode`] | `encode` | from samples to a material: the fitters, budgets, subset, info |
//! | [`io`] | `cli` | files in and out: CSV, EXR, atomic output, synthetic materials |
//! | [`report`] | `cli` | pictures and studies: plots, previews, paper figures, the trade-off |
//!
//! ## Quick start
//!
//! Open a file, evaluate ρ at three wavelengths and draw a direction (the README's example;
//! `ggx.sbrdf` is what `sbrdf encode` wrote):
//!
//! ```no_run
//! fn main() -> sbrdf::Result<()> {
//!     let dec = sbrdf::Decoder::open("ggx.sbrdf")?;
//!     let (wi, wo) = ([0.2588, 0.0, 0.9659], [-0.2588, 0.0, 0.9659]); // unit vectors, z = normal
//!     let mut rho = [0.0f32; 3];
//!     dec.eval(wi, wo, &[450.0, 550.0, 650.0], &mut rho); // 1/sr; no allocation
//!     let s = dec.sample(wi, [0.3, 0.7]); // importance sampling: wo, pdf
//!     println!(
//!         "{rho:?} {:?} {} bytes resident",
//!         s.map(|s| s.pdf),
//!         dec.resident_bytes()
//!     );
//!     Ok(())
//! }
//! ```
//!
//! Batches, one wavelength at a time ([`Decoder::at`]), colour and memory: `docs/guide/library.md`.
//!
//! Conventions: `spec/EVALUATION.md`; byte format: `spec/FORMAT.md`.

#![warn(missing_docs)]

pub mod error;

pub mod decode;
pub mod format;
pub mod gpu;
pub mod model;
#[cfg(feature = "preview")]
pub mod preview;

#[cfg(feature = "encode")]
pub mod encode;

#[cfg(feature = "cli")]
pub mod io;
#[cfg(feature = "cli")]
pub mod report;

pub use decode::{AtWavelength, Baked, Decoder, Residency, Sample};
pub use error::{Error, Result};
pub use format::{read_material, write_material, Limits};
pub use model::{
    IncidentRecord, Lobe, LobeKind, Material, Precision, SpectralBasis, SpectralSpace,
};

#[cfg(test)]
mod assert_traits {
    fn send_sync<T: Send + Sync>() {}
    #[test]
    fn decoder_is_send_and_sync() {
        send_sync::<crate::Decoder>();
    }
}
