//! What a file holds and the math both sides share: the in-memory material, spectral bases,
//! spherical harmonics, lobe shapes, the factor model shared across incidences, and the angle
//! conventions. Uses nothing above it.

pub mod angles;
pub mod basis_storage;
pub mod factor;
pub mod lanes;
pub mod lobes;
pub mod material;
pub mod precision;
pub mod sh;
pub mod spectral;
pub mod warped;

pub use material::{IncidentRecord, Lobe, LobeKind, Material};
pub use precision::Precision;
pub use spectral::{SpectralBasis, SpectralSpace};
