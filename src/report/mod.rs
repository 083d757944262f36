//! Pictures and studies (feature `cli`): what a record stores as heat maps and spectra, a
//! rendered sphere, the paper's figures recomputed, and the size/accuracy/speed trade-off measured
//! on a user's own material. Uses everything below it.

pub mod draw;
pub mod paper_figures;
pub mod plot;
pub mod preview;
pub mod tradeoff;
