//! # sbrdf
//!
//! A compact, archival codec for spectral BRDFs. Per incident direction, each spectral
//! coefficient of the BRDF is stored as a real spherical-harmonic expansion over outgoing
//! directions plus a specular peak (Xu & Sun, "Efficient Representation of Spectral BRDFs").
//!
//! * [`Decoder`] opens a file and evaluates ρ(ωi, ωo, λ); it needs no optional feature, so a
//!   renderer can depend on `sbrdf` with `default-features = false`.
//! * With the `encode` feature, [`encoder`] fits sampled BRDFs ([`samples::SampleSet`]).
//! * With the `cli` feature (default), the `sbrdf` program and the CSV and spectral-EXR readers.
//!
//! Conventions: `spec/EVALUATION.md`; byte format: `spec/FORMAT.md`.

pub mod angles;
pub mod capi;
mod cie;
pub mod color;
pub mod decoder;
pub mod error;
pub mod format;
pub mod lobes;
pub mod material;
pub mod sampling;
pub mod sh;
pub mod spectral;

#[cfg(feature = "encode")]
pub mod encoder;
#[cfg(feature = "encode")]
pub mod fit;
#[cfg(feature = "encode")]
pub mod info;
#[cfg(feature = "encode")]
pub mod joint;
#[cfg(feature = "encode")]
pub mod samples;
#[cfg(feature = "encode")]
pub mod subset;

#[cfg(feature = "cli")]
pub mod csv_input;
#[cfg(feature = "cli")]
pub mod exr_io;
#[cfg(feature = "cli")]
pub mod figures;
#[cfg(feature = "cli")]
pub mod input;
#[cfg(feature = "cli")]
pub mod output;
#[cfg(feature = "cli")]
pub mod paper_figures;
#[cfg(feature = "cli")]
pub mod settings;
#[cfg(feature = "cli")]
pub mod synth;
#[cfg(feature = "cli")]
pub mod tradeoff;

pub use decoder::Decoder;
pub use error::{Error, Result};
pub use format::{read_material, write_material, Limits};
pub use material::{IncidentRecord, Lobe, LobeKind, Material, Precision};
pub use sampling::Sample;
pub use spectral::{SpectralBasis, SpectralSpace};

#[cfg(test)]
mod assert_traits {
    fn send_sync<T: Send + Sync>() {}
    #[test]
    fn decoder_is_send_and_sync() {
        send_sync::<crate::Decoder>();
    }
}
