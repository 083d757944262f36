//! `sbrdf preview`: a sphere under a point light of D65's spectrum, rendered spectrally on the
//! CPU and shown in sRGB. The sphere's geometry and tone curve are [`crate::preview`]'s, which a
//! GPU renders from too (the `gpu_preview` example in `gpu/`).

use super::draw::encode_png;
use crate::error::Result;
use crate::preview::{preview_samples, tone_map};
pub use crate::preview::{Preview, PreviewOptions};
use crate::Decoder;
use rayon::prelude::*;

/// A preview encoded as a PNG file's bytes.
pub fn preview_png(p: &Preview) -> Result<Vec<u8>> {
    encode_png(&p.rgb, p.size, p.size)
}

/// Renders a sphere with the file's BRDF (orthographic camera, sphere filling 90% of the
/// picture, 2×2 samples per pixel: [`crate::preview::preview_samples`]). Radiance per sample is
/// ρ(ωi, ωo)·cos θi under a point light of D65's spectrum (XYZ by the CIE 1931 observer, then
/// linear sRGB: [`Decoder::eval_linear_srgb`]); incident directions between stored incidences
/// are interpolated by the decoder. Exposure and tone curve: [`crate::preview::tone_map`].
pub fn render_preview(dec: &Decoder, o: &PreviewOptions) -> Result<Preview> {
    let samples = preview_samples(o)?;
    let radiance: Vec<Option<[f64; 3]>> =
        samples.par_iter().map(|s| s.radiance_on_cpu(dec)).collect();
    tone_map(o, &radiance)
}
