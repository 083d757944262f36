//! The model section of the flat device layout for a factor model (`spec/GPU_LAYOUT.md`, "Model
//! section", kind 1): the `FACT` chunk's ranges, component descriptors and values as words, so
//! that a shader adds F(ωi, ωo, λ) (`spec/EVALUATION.md`, "Factor model") to the records' value.

use super::gpu_layout::{push_values, word, ENCODING_F16_PAIRS, ENCODING_F32};
use crate::error::Result;
use crate::model::factor::FactorModel;
use crate::model::Precision;

/// Header word holding the model section's offset (0: none).
pub(crate) const HEADER_MODEL: usize = 19;
/// Header word holding `total_words`.
const HEADER_TOTAL: usize = 2;
/// The model section's kind word for a factor model.
const MODEL_FACTOR: u32 = 1;
/// Words before the component entries: kind, encoding, C, reserved, ten range bounds.
const FIXED_WORDS: usize = 14;
/// Words per component entry: rank, feature count, packed feature codes, offset of the values.
const COMPONENT_WORDS: usize = 4;

/// Appends the model section of `model` to the layout `out` (whose header is complete) and
/// points header word 19 at it; `total_words` is updated.
pub(crate) fn append_factor_section(out: &mut Vec<u32>, model: &FactorModel) -> Result<()> {
    let at = out.len();
    let encoding = match model.precision {
        Precision::F16 => ENCODING_F16_PAIRS,
        Precision::F32 => ENCODING_F32,
    };
    out.extend([MODEL_FACTOR, encoding, word(model.components.len())?, 0]);
    out.extend(model.ranges.iter().flatten().map(|v| v.to_bits()));
    let entries = out.len();
    debug_assert_eq!(entries, at + FIXED_WORDS);
    out.resize(entries + COMPONENT_WORDS * model.components.len(), 0);
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
        let e = entries + COMPONENT_WORDS * ci;
        out[e] = word(c.rank())?;
        out[e + 1] = word(c.features.len())?;
        out[e + 2] = codes;
        out[e + 3] = word(off_values)?;
    }
    out[HEADER_MODEL] = word(at)?;
    out[HEADER_TOTAL] = word(out.len())?;
    Ok(())
}
