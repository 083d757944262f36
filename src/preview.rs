//! The preview sphere (`sbrdf preview`): its geometry, its tone curve and the CPU decoder's
//! radiance per sub-sample, so that the CPU program (`report::preview`, with the `cli`
//! feature) and a GPU (the `gpu_preview` example in `gpu/`, which evaluates on the device with
//! `sbrdf_eval_rgb`) render the same picture from the same queries. No dependency beyond the
//! decoder and the standard library.
//!
//! A render is three steps: [`preview_samples`] gives, per sub-sample, the light and view
//! directions in the surface's local frame (or that the sub-sample misses the sphere or is
//! unlit); the caller evaluates linear sRGB under D65 at each and multiplies by cos θi
//! ([`PreviewSample::radiance_on_cpu`] with the decoder, [`PreviewSample::radiance`] from a
//! value evaluated elsewhere, such as the shader); [`tone_map`] turns the radiances into 8-bit
//! sRGB pixels.

use crate::decode::color::Illuminant;
use crate::error::{Error, Result};
use crate::model::angles::{dir_from_deg, dot, normalize};
use crate::Decoder;

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

/// Sub-samples per pixel along each axis (2 × 2 per pixel).
pub const PREVIEW_SUBSAMPLES: usize = 2;

/// One sub-sample of the picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PreviewSample {
    /// Off the sphere: the background.
    Background,
    /// On the sphere, facing away from the light: black.
    Unlit,
    /// On the sphere and lit: the light and view directions in the surface's local frame (z the
    /// normal, x along the sphere's horizontal circle), rounded to f32 as a decoder takes them,
    /// and cos θi.
    Lit {
        /// Toward the light (ωi).
        light: [f32; 3],
        /// Toward the camera (ωo).
        view: [f32; 3],
        /// cos θi, the light's cosine at the surface.
        cos_i: f64,
    },
}

impl PreviewSample {
    /// The sub-sample's linear sRGB radiance from the BRDF's linear sRGB value `rgb` at
    /// (light, view) (ignored unless lit): `rgb`·cos θi when lit, 0 when unlit, None off the
    /// sphere.
    pub fn radiance(&self, rgb: [f64; 3]) -> Option<[f64; 3]> {
        match *self {
            PreviewSample::Background => None,
            PreviewSample::Unlit => Some([0.0; 3]),
            PreviewSample::Lit { cos_i, .. } => Some(rgb.map(|c| c * cos_i)),
        }
    }

    /// The sub-sample's radiance with the BRDF evaluated by the CPU decoder, linear sRGB under
    /// D65 ([`Decoder::eval_linear_srgb`]): what `sbrdf preview` renders.
    pub fn radiance_on_cpu(&self, dec: &Decoder) -> Option<[f64; 3]> {
        let rgb = match *self {
            PreviewSample::Lit { light, view, .. } => {
                dec.eval_linear_srgb(light, view, Illuminant::D65)
            }
            _ => [0.0; 3],
        };
        self.radiance(rgb)
    }
}

/// The picture's sub-samples, row-major from the top (size·2 × size·2): an orthographic camera
/// looking down −z at a sphere that fills 90% of the picture, each point's tangent frame with
/// its x axis along the sphere's horizontal circle (it matters for anisotropic files only).
/// Checks the options.
pub fn preview_samples(o: &PreviewOptions) -> Result<Vec<PreviewSample>> {
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
    let sub = o.size as usize * PREVIEW_SUBSAMPLES;
    let light = dir_from_deg(lt, lp);
    let view = [0.0, 0.0, 1.0];
    Ok((0..sub * sub)
        .map(|i| {
            let (row, col) = (i / sub, i % sub);
            let x = ((col as f64 + 0.5) / sub as f64 * 2.0 - 1.0) / RADIUS;
            let y = (1.0 - (row as f64 + 0.5) / sub as f64 * 2.0) / RADIUS;
            let r2 = x * x + y * y;
            if r2 >= 1.0 {
                return PreviewSample::Background;
            }
            let normal = [x, y, (1.0 - r2).sqrt()];
            let cos_i = dot(normal, light);
            if cos_i <= 0.0 {
                return PreviewSample::Unlit;
            }
            // Tangent along the horizontal circle: up × normal, normalised.
            let t = normalize([normal[2], 0.0, -normal[0]]).unwrap_or([1.0, 0.0, 0.0]);
            let b = [
                normal[1] * t[2] - normal[2] * t[1],
                normal[2] * t[0] - normal[0] * t[2],
                normal[0] * t[1] - normal[1] * t[0],
            ];
            let local = |v: [f64; 3]| [dot(v, t) as f32, dot(v, b) as f32, dot(v, normal) as f32];
            PreviewSample::Lit {
                light: local(light),
                view: local(view),
                cos_i,
            }
        })
        .collect())
}

/// The sphere's radius as a fraction of the picture's half width.
const RADIUS: f64 = 0.9;

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

/// The picture from the sub-samples' radiances (in [`preview_samples`]' order; None off the
/// sphere).
///
/// Exposure is automatic: the luminance of the lit sphere's median sample is brought to 0.3,
/// within limits that keep the brightest (99.9th percentile) sample between 1 and 8; the
/// extended Reinhard curve then maps that brightest sample to white, compressing highlights
/// smoothly (it is the identity when the exposure is the lower limit), hue preserved. Then the
/// sRGB transfer curve, and the 2 × 2 sub-samples averaged. The background is a dark grey.
pub fn tone_map(o: &PreviewOptions, samples: &[Option<[f64; 3]>]) -> Result<Preview> {
    let n = o.size as usize;
    let ss = PREVIEW_SUBSAMPLES;
    let sub = n * ss;
    if samples.len() != sub * sub {
        return Err(Error::Parameter(format!(
            "preview: {} sub-samples for a {n}-pixel picture (needs {})",
            samples.len(),
            sub * sub
        )));
    }
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
    for (row, out) in rgb.chunks_mut(n * 3).enumerate() {
        for col in 0..n {
            let mut acc = [0.0; 3];
            for dy in 0..ss {
                for dx in 0..ss {
                    let c = match samples[(row * ss + dy) * sub + col * ss + dx] {
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
    }
    let view = [0.0, 0.0, 1.0];
    let light = dir_from_deg(o.light.0, o.light.1);
    let h = normalize([light[0], light[1], light[2] + 1.0]).unwrap_or(view);
    let px = |v: f64| (((v * RADIUS + 1.0) / 2.0) * n as f64).clamp(0.0, n as f64 - 1.0) as u32;
    Ok(Preview {
        size: o.size,
        rgb,
        exposure,
        highlight: (px(h[0]), px(-h[1])),
    })
}
