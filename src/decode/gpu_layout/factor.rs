//! The model section of the flat device layout for a factor model (`spec/GPU_LAYOUT.md`, "Model
//! section", kind 1): the `FACT` chunk's ranges, component descriptors and values as words, so
//! that a shader adds F(ωi, ωo, λ) (`spec/EVALUATION.md`, "Factor model") to the records' value.

use super::words::codes::{ENCODING_F16_PAIRS, ENCODING_F32, MODEL_FACTOR};
use super::words::{component, factor, header, model as model_words};
use super::{push_values, word};
use crate::error::Result;
use crate::model::factor::FactorModel;
use crate::model::Precision;

/// Appends the model section of `model` to the layout `out` (whose header is complete) and
/// points header word 19 at it; `total_words` is updated.
pub(crate) fn append_factor_section(out: &mut Vec<u32>, model: &FactorModel) -> Result<()> {
    let at = out.len();
    let encoding = match model.precision {
        Precision::F16 => ENCODING_F16_PAIRS,
        Precision::F32 => ENCODING_F32,
    };
    out.resize(at + factor::WORDS, 0);
    out[at + model_words::KIND] = MODEL_FACTOR;
    out[at + factor::ENCODING] = encoding;
    out[at + factor::COMPONENTS] = word(model.components.len())?;
    out[at + factor::RESERVED] = 0;
    let ranges = model.ranges.iter().flatten().map(|v| v.to_bits());
    for (i, v) in ranges.enumerate() {
        out[at + factor::RANGES + i] = v;
    }
    let entries = out.len();
    out.resize(entries + component::WORDS * model.components.len(), 0);
    for (ci, c) in model.components.iter().enumerate() {
        // The values in the file's order: s_c, then per rank r its w_cr (r ≥ 1) and tables.
        let mut values: Vec<f32> = c.spectrum.clone();
        for (r, tables) in c.tables.iter().enumerate() {
            if r >= 1 {
                values.extend(&c.modulation[r - 1]);
            }
            values.extend(tables.iter().flatten());
        }
        let off_values = out.len();
        // The model's f16 values are binary16 numbers without a scale (`spec/FORMAT.md` §3.7,
        // validated exact when the file was read): encoding 2 with scale 1 keeps them exactly.
        push_values(out, &values, encoding, 1.0);
        // Feature codes (1 to 6) four bits each: at most six features per component.
        let codes = c
            .features
            .iter()
            .enumerate()
            .fold(0u32, |acc, (k, f)| acc | (f.code() as u32) << (4 * k));
        let e = &mut out[entries + component::WORDS * ci..][..component::WORDS];
        e[component::RANK] = word(c.rank())?;
        e[component::FEATURES] = word(c.features.len())?;
        e[component::CODES] = codes;
        e[component::OFF_VALUES] = word(off_values)?;
    }
    out[header::OFF_MODEL] = word(at)?;
    out[header::TOTAL] = word(out.len())?;
    Ok(())
}
