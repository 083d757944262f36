//! An RGL file as warped tables' input ([`WarpedInput`]): every stored incidence's grid as it
//! is (the nodes are where the file's own VNDF warp puts them, which the decoder rebuilds from
//! the NDF), spectra per node (RGB made spectral by Jakob & Hanika 2019 when asked).

use super::{rgb_refusal, Channels, RglBsdf, Upsampler, UPSAMPLED_WAVELENGTHS};
use crate::decode::color::CIE_WAVELENGTHS;
use crate::encode::samples::{ReadOptions, RgbToSpectrum};
use crate::encode::table_error::Metric;
use crate::encode::warped::WarpedInput;
use crate::error::{Error, Result};
use rayon::prelude::*;

/// What reading an RGL file for warped tables found, beside the input itself.
#[derive(Debug, Clone)]
pub struct WarpedRead {
    /// The input for [`crate::encode::warped`].
    pub input: WarpedInput,
    /// The file's description field.
    pub description: String,
    /// Whether the spectra were made from RGB, and how many colours had negative components
    /// set to 0 first.
    pub upsampled: bool,
    /// The number of RGB colours whose negative components were set to 0 (see `upsampled`).
    pub clamped: usize,
}

/// Reads `bytes` (file `name`) for warped tables. `Ok(Err(reason))` when the file is
/// not one warped tables hold (anisotropic, several azimuths, no `jacobian` flag).
pub fn read_warped(
    name: &str,
    bytes: &[u8],
    options: &ReadOptions,
) -> Result<std::result::Result<WarpedRead, String>> {
    let here = |e: super::RglError| Error::Input(format!("{name}: {e}"));
    let bsdf = RglBsdf::from_bytes(bytes).map_err(here)?;
    let upsampler = match (&bsdf.channels, options.rgb_to_spectrum) {
        (Channels::Rgb, None) => return Err(Error::Input(rgb_refusal(name))),
        (Channels::Rgb, Some(RgbToSpectrum::JakobHanika2019)) => Some(Upsampler::new()),
        (Channels::Spectral { .. }, _) => None,
    };
    let Some((ndf, sigma, warp_grid)) = bsdf.isotropic_warp_parts() else {
        return Ok(Err(format!(
            "{name}: not an isotropic measurement with one stored azimuth, a square VNDF grid and \
             an isotropic NDF; warped tables hold only those"
        )));
    };
    let wavelengths: Vec<f32> = match &bsdf.channels {
        Channels::Spectral { wavelengths } => wavelengths.clone(),
        Channels::Rgb => UPSAMPLED_WAVELENGTHS.iter().map(|&w| w as f32).collect(),
    };
    let (r, nc, w) = (bsdf.res, bsdf.channel_count(), wavelengths.len());
    let nt = bsdf.theta_i.len();
    // Node spectra, incidence-major, then row, column, then wavelength.
    let per_node: Vec<(usize, usize)> = (0..nt)
        .flat_map(|t| (0..r * r).map(move |p| (t, p)))
        .collect();
    let spectra: Vec<Result<(Vec<f64>, bool)>> = per_node
        .par_iter()
        .map(|&(t, p)| {
            let v = bsdf.values_at(t, 0);
            let channel = |c: usize| v[c * r * r + p] as f64;
            match &upsampler {
                None => Ok(((0..nc).map(channel).collect(), false)),
                Some(up) => {
                    let fit = up
                        .fit([channel(0), channel(1), channel(2)])
                        .map_err(|e| Error::Input(format!("{name}: {e}")))?;
                    let s = UPSAMPLED_WAVELENGTHS
                        .iter()
                        .map(|&l| fit.spectrum.eval(l))
                        .collect();
                    Ok((s, fit.clamped))
                }
            }
        })
        .collect();
    let mut flat = Vec::with_capacity(nt * r * r * w);
    let mut clamped = 0;
    for s in spectra {
        let (s, c) = s?;
        clamped += c as usize;
        flat.extend(s);
    }
    let thetas_deg = bsdf
        .theta_i
        .iter()
        .map(|&t| ((t as f64).to_degrees().min(90.0)) as f32)
        .collect();
    Ok(Ok(WarpedRead {
        input: WarpedInput {
            thetas_deg,
            wavelengths,
            grid: r,
            warp_grid,
            ndf,
            sigma: Some(sigma),
            spectra: flat,
            metric: upsampler
                .as_ref()
                .map(|_| srgb_metric(&UPSAMPLED_WAVELENGTHS)),
            // The colours as measured: where Jakob & Hanika's spectra cannot reach one (very
            // saturated colours), the tables still give it back.
            measured: upsampler.as_ref().map(|_| {
                per_node
                    .iter()
                    .flat_map(|&(t, p)| {
                        let v = bsdf.values_at(t, 0);
                        (0..3).map(move |c| v[c * r * r + p] as f64)
                    })
                    .collect()
            }),
        },
        description: bsdf.description.trim().to_string(),
        upsampled: upsampler.is_some(),
        clamped,
    }))
}

/// The linear sRGB (D65) of a spectrum given at `nodes` (linearly interpolated between them,
/// held beyond their ends, as the decoder interpolates a tabulated basis), as a 3 × W matrix:
/// column j is the colour of the hat function of node j, the decoder's own conversion
/// (`spectrum_to_linear_srgb`) being linear.
fn srgb_metric(nodes: &[f64]) -> Metric {
    let w = nodes.len();
    let mut matrix = vec![0.0; 3 * w];
    for j in 0..w {
        let hat: Vec<f64> = CIE_WAVELENGTHS
            .iter()
            .map(|&l| {
                let l = (l as f64).clamp(nodes[0], nodes[w - 1]);
                let i = nodes.partition_point(|&x| x <= l).clamp(1, w - 1) - 1;
                let t = (l - nodes[i]) / (nodes[i + 1] - nodes[i]);
                if i == j {
                    1.0 - t
                } else if i + 1 == j {
                    t
                } else {
                    0.0
                }
            })
            .collect();
        let rgb = super::spectrum_to_linear_srgb(&hat);
        for d in 0..3 {
            matrix[d * w + j] = rgb[d];
        }
    }
    Metric { rows: 3, matrix }
}
