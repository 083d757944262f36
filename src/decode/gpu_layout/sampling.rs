//! The sampling section of the flat device layout (`spec/GPU_LAYOUT.md`, "Sampling section"):
//! the per-record mixture weights that importance sampling computes when a file is opened
//! ([`super::sampling::SamplingWeights`]), as f32 words, so that a shader draws and gives the
//! pdf of the same mixture as [`crate::Decoder::sample`] and [`crate::Decoder::pdf`].

use super::word;
use super::words::{header, lobe_weights, sampling, weights as record_weights};
use crate::decode::sampling::SamplingWeights;
use crate::error::Result;

/// Appends the sampling section of `records` records to the layout `out` (whose header is
/// complete) and points header word 18 at it; `total_words` is updated.
pub(crate) fn append_sampling_section(
    out: &mut Vec<u32>,
    weights: &SamplingWeights,
    records: usize,
) -> Result<()> {
    let at = out.len();
    // The record index: one offset per record, then each record's weights.
    out.resize(at + sampling::WORDS * records, 0);
    for r in 0..records {
        out[at + sampling::WORDS * r + sampling::OFF_WEIGHTS] = word(out.len())?;
        let (background, lobes) = weights.record(r);
        let start = out.len();
        out.resize(start + record_weights::WORDS, 0);
        out[start + record_weights::BACKGROUND] = f32_word(background);
        for (energy, ln_width) in lobes {
            let l = out.len();
            out.resize(l + lobe_weights::WORDS, 0);
            out[l + lobe_weights::ENERGY] = f32_word(energy);
            out[l + lobe_weights::LN_WIDTH] = f32_word(ln_width);
        }
    }
    out[header::OFF_SAMPLING] = word(at)?;
    out[header::TOTAL] = word(out.len())?;
    Ok(())
}

/// A weight as an f32 word. The decoder's weights are finite (energies are clamped to finite
/// values ≥ 0 when computed, except the background's, which the mixture itself treats as 0 when
/// not finite or negative); a value beyond f32's range becomes ±∞ or 0 here, which the shader
/// treats exactly as the decoder treats a non-finite or zero weight.
fn f32_word(v: f64) -> u32 {
    (v as f32).to_bits()
}
