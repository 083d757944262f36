//! Files in and out (feature `cli`): the readers of sampled BRDFs (CSV, spectral-EXR slices,
//! ASTM E1392 text, RGL `.bsdf` measurements) behind one sample collector, the CSV and EXR
//! writers, atomic output, and the synthetic test materials. Uses the encoder and everything
//! below it.

pub mod astm;
pub mod collect;
pub mod csv;
pub mod exr;
pub mod input;
pub mod output;
pub mod rgl;
pub mod synth;

pub use crate::encode::samples::{ReadOptions, ReadReport, RgbToSpectrum};
pub use collect::{samples_from_columns, COLUMNS};
pub use input::{
    expand_inputs, read_inputs, read_inputs_from_bytes, read_inputs_from_bytes_with,
    read_inputs_with,
};
