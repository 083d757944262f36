//! The encoder (feature `encode`): from sampled spectral BRDFs to a [`crate::Material`] — the
//! sample sets, the data-derived spectral basis, the per-incidence fitters (the paper's split
//! and the joint fit), error budgets, the command-line option set, and the tools that derive or
//! describe files (subset, info). May use the decoder; nothing below uses it.

pub mod basis;
pub mod encoder;
pub mod factor_fit;
pub mod factor_model;
pub mod fit;
pub mod info;
pub mod metrics;
pub mod nearest;
pub mod noise;
pub mod options;
pub mod samples;
pub mod settings;
pub mod subset;
pub mod table_error;
pub mod validate;
pub mod warped;

pub use encoder::{encode, EncodeOptions, Encoded, ModelChoice};
pub use samples::{IncidentSamples, SampleSet};
