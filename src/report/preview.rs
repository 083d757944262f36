//! `sbrdf preview`: a sphere under a point light of D65's spectrum, rendered spectrally and
//! shown in sRGB.

use super::draw::encode_png;
use crate::decode::color::Illuminant;
use crate::error::{Error, Result};
use crate::model::angles::{dir_from_deg, dot};
use crate::Decoder;
use rayon::prelude::*;

/// A sphere seen from the camera, lit by a point light of D65's spectrum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreviewOptions {
    /// Width and height of the picture in pixels.
    pub size: u32,
    /// Direction toward the light in the camera's frame, degrees: θ from the viewing direction
    /// (0 = light at the camera), φ counter-clockwise from the picture's right.
    pub light: (f64, f64),
}

impl Default for PreviewOptions {
    fn default() -> Self {
        PreviewOptions {
            size: 256,
            light: (45.0, 135.0),
        }
    }
}

/// A rendered preview: 8-bit sRGB pixels, row-major, top row first.
#[derive(Debug, Clone)]
pub struct Preview {
    /// Width and height in pixels (the picture is square).
    pub size: u32,
    /// size × size pixels of 3 bytes (R, G, B).
    pub rgb: Vec<u8>,
    /// The factor applied to luminance (Y in units where a white Lambertian surface lit head-on
    /// by the light has Y = 1) before the tone curve.
    pub exposure: f64,
    /// Pixel (column, row) of the sphere point whose normal is the half vector of light and
    /// camera: where a mirror-like highlight sits.
    pub highlight: (u32, u32),
}

impl Preview {
    /// The preview encoded as a PNG file's bytes.
    pub fn png(&self) -> Result<Vec<u8>> {
        encode_png(&self.rgb, self.size, self.size)
    }
}

/// The background, sRGB-encoded.
const PREVIEW_BACKGROUND: [u8; 3] = [46, 48, 54];

fn srgb_encode(linear: f64) -> u8 {
    let v = linear.clamp(0.0, 1.0);
    let e = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0).round() as u8
}

fn srgb_decode(c: u8) -> f64 {
    let v = c as f64 / 255.0;
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Renders a sphere with the file's BRDF (orthographic camera, sphere filling 90% of the
/// picture, 2×2 samples per pixel). Radiance per sample is ρ(ωi, ωo)·cos θi under a point light
/// of D65's spectrum (XYZ by the CIE 1931 observer, then linear sRGB); incident directions
/// between stored incidences are interpolated by the decoder. Each point's tangent frame has
/// its x axis along the sphere's horizontal circle (it matters for anisotropic files only).
///
/// Exposure is automatic: the luminance of the lit sphere's median sample is brought to 0.3,
/// within limits that keep the brightest (99.9th percentile) sample between 1 and 8; the
/// extended Reinhard curve then maps that brightest sample to white, compressing highlights
/// smoothly (it is the identity when the exposure is the lower limit), hue preserved. Then the
/// sRGB transfer curve. The background is a dark grey; the unlit side stays black.
pub fn render_preview(dec: &Decoder, o: &PreviewOptions) -> Result<Preview> {
    if !(16..=4096).contains(&o.size) {
        return Err(Error::Parameter(format!(
            "--size {} is outside 16..=4096 pixels",
            o.size
        )));
    }
    let (lt, lp) = o.light;
    if !(lt.is_finite() && lp.is_finite() && (0.0..=90.0).contains(&lt)) {
        return Err(Error::Parameter(format!(
            "--light ({lt}, {lp}): θ must lie in [0, 90] degrees from the viewing direction"
        )));
    }
    let n = o.size as usize;
    let ss = 2usize;
    let light = dir_from_deg(lt, lp);
    let view = [0.0, 0.0, 1.0];
    let radius = 0.9;
    // Linear sRGB radiance per sub-sample; None off the sphere.
    let sub = n * ss;
    let samples: Vec<Option<[f64; 3]>> = (0..sub * sub)
        .into_par_iter()
        .map(|i| {
            let (row, col) = (i / sub, i % sub);
            let x = ((col as f64 + 0.5) / sub as f64 * 2.0 - 1.0) / radius;
            let y = (1.0 - (row as f64 + 0.5) / sub as f64 * 2.0) / radius;
            let r2 = x * x + y * y;
            if r2 >= 1.0 {
                return None;
            }
            let normal = [x, y, (1.0 - r2).sqrt()];
            let cos_i = dot(normal, light);
            if cos_i <= 0.0 {
                return Some([0.0; 3]);
            }
            // Tangent along the horizontal circle: up × normal, normalised.
            let t = crate::model::angles::normalize([normal[2], 0.0, -normal[0]])
                .unwrap_or([1.0, 0.0, 0.0]);
            let b = [
                normal[1] * t[2] - normal[2] * t[1],
                normal[2] * t[0] - normal[0] * t[2],
                normal[0] * t[1] - normal[1] * t[0],
            ];
            let local = |v: [f64; 3]| [dot(v, t) as f32, dot(v, b) as f32, dot(v, normal) as f32];
            let c = dec.eval_linear_srgb(local(light), local(view), Illuminant::D65);
            Some([c[0] * cos_i, c[1] * cos_i, c[2] * cos_i])
        })
        .collect();
    let lum = |c: &[f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let mut lit: Vec<f64> = samples
        .iter()
        .flatten()
        .map(lum)
        .filter(|&l| l > 0.0 && l.is_finite())
        .collect();
    lit.sort_by(f64::total_cmp);
    let (exposure, white) = if lit.is_empty() {
        (1.0, 1.0)
    } else {
        let median = lit[lit.len() / 2];
        let top = lit[((lit.len() - 1) as f64 * 0.999) as usize];
        let s = (0.3 / median).clamp(1.0 / top, 8.0 / top);
        (s, (s * top).max(1.0))
    };
    let background = PREVIEW_BACKGROUND.map(srgb_decode);
    let tone = |c: [f64; 3]| -> [f64; 3] {
        let c = c.map(|v| {
            if v.is_finite() {
                v.max(0.0) * exposure
            } else {
                0.0
            }
        });
        let l = lum(&c);
        if l <= 0.0 {
            return c;
        }
        let mapped = l * (1.0 + l / (white * white)) / (1.0 + l);
        let f = mapped / l;
        c.map(|v| (v * f).min(1.0))
    };
    let mut rgb = vec![0u8; n * n * 3];
    rgb.par_chunks_mut(n * 3)
        .enumerate()
        .for_each(|(row, out)| {
            for col in 0..n {
                let mut acc = [0.0; 3];
                for dy in 0..ss {
                    for dx in 0..ss {
                        let s = samples[(row * ss + dy) * sub + col * ss + dx];
                        let c = match s {
                            Some(c) => tone(c),
                            None => background,
                        };
                        for (a, v) in acc.iter_mut().zip(c) {
                            *a += v;
                        }
                    }
                }
                for (o, a) in out[col * 3..col * 3 + 3].iter_mut().zip(acc) {
                    *o = srgb_encode(a / (ss * ss) as f64);
                }
            }
        });
    let h = crate::model::angles::normalize([light[0], light[1], light[2] + 1.0]).unwrap_or(view);
    let px = |v: f64| (((v * radius + 1.0) / 2.0) * n as f64).clamp(0.0, n as f64 - 1.0) as u32;
    let highlight = (px(h[0]), px(-h[1]));
    Ok(Preview {
        size: o.size,
        rgb,
        exposure,
        highlight,
    })
}
