//! RGL material-database measurements (`.bsdf`, Mitsuba 3's `tensor_file` v1.0), read into
//! sampled BRDF values at real directions.
//!
//! Dupuy & Jakob, "An Adaptive Parameterization for Efficient Material Acquisition and
//! Rendering" (ACM TOG 37(6), 2018) store each incidence's measurement on an R × R grid in a
//! *warped* square: a grid node `s = (col/(R−1), row/(R−1))` is the image, under the inverse
//! of the VNDF's marginal/conditional warp, of a half-vector parameter `u = (√(2θm/π),
//! (φm − φi)/2π + ½)` (φm absolute for anisotropic files). This module runs the warp forward
//! for every node (`warp.rs`), reflects the incident direction about that half vector to get
//! the outgoing direction, and returns what Mitsuba 3's `measured` plugin returns there divided
//! by cos θo: the BRDF in 1/sr, `value · NDF(u) / (4 σ(θi, φi)) / cos θo` (the NDF/σ factor
//! when the file's `jacobian` flag is set). Written from the paper and the tensor-file layout;
//! Mitsuba's and powitacq's loaders were read, not copied.
//!
//! Conventions (sbrdf's): angles in degrees, θ from the normal in [0, 90], φ counter-clockwise
//! from +x in [0, 360); the incident direction points toward the light. The file's
//! `theta_i`/`phi_i` parameterise Mitsuba's `si.wi`, the same unit vector
//! (sin θi cos φi, sin θi sin φi, cos θi), so the stored angles are taken as they are.
//!
//! What `sbrdf encode` takes from a file (`collect_rgl`), and why:
//! * stored incidences up to [`MAX_THETA_I`] (85°). RGL files end with θi = 1.5707962 rad
//!   (89.999995°, cos θi = 7.5e−8): there many nodes lie within 1e−8 of the horizon, values
//!   reach 1e6–1e9 in 1/sr, and Mitsuba itself returns NaN or 0 for some of them. Between the
//!   last kept incidence (about 80°) and 90° the decoder answers with the nearest stored one;
//! * grid nodes above the horizon (cos θo > 0; Mitsuba's eval is 0 below), all of them up to
//!   90°;
//! * where the grid leaves gaps (no node within 5°, on a 5° grid up to θo = 87.5°), samples of
//!   the file's own interpolation, as Mitsuba evaluates it ([`fill_gaps`]);
//! * one sample per direction: the 32 nodes of the θm = 0 column are all the mirror direction
//!   and the rows φm − φi = ±180° coincide, so nodes sharing a direction (to 1e−6°) are
//!   averaged (their spread is 0.5–12% at the pole, where Mitsuba's own value depends on float
//!   rounding);
//! * the `valid` field is ignored, as Mitsuba and powitacq ignore it: in the shipped files it is
//!   the above-horizon mask in one and its complement in the other two;
//! * negative values (noise after the colour conversion, down to −0.4% of the maximum) are kept
//!   as stored, as for every input;
//! * RGB files are refused unless asked to convert ([`RgbToSpectrum`]); then each node's
//!   colour becomes a Jakob & Hanika 2019 spectrum ([`Upsampler`], negative components set to 0
//!   first), sampled at [`UPSAMPLED_WAVELENGTHS`], and the file's metadata says so.
//!
//! Hostile input: every count, length, shape and offset is checked against the bytes present
//! before anything is allocated or read; nothing here panics on any input (the `rgl` fuzz
//! target, the truncation and bit-flip tests). Errors name the field and the byte offset.

mod bsdf;
mod common;
mod encode_file;
mod tensor;
mod upsample;
mod warp;
mod warped;

#[cfg(test)]
mod tests;

pub use bsdf::{
    angles_deg, merge_cells, Cell, Channels, Evaluator, Incidence, IncidenceSamples, RglBsdf,
};
pub(crate) use common::rgb_refusal;
pub use common::{
    spectral_name, FILL_GAP_DEG, FILL_STEP_DEG, MAGIC, MAX_THETA_I, UPSAMPLED_WAVELENGTHS,
};
pub use encode_file::{encode_warped_file, WarpedFileOutcome};
pub use tensor::{write_tensor, DType, FieldInfo, RglError, TensorFile};
pub use upsample::{spectrum_to_linear_srgb, Fit, SigmoidSpectrum, Upsampler};
pub use warped::{read_warped, WarpedRead};

use crate::encode::samples::{ReadOptions, ReadReport, RgbToSpectrum};
use crate::error::{Error, Result};
use crate::io::collect::{Place, Sample};
use std::path::Path;

/// Reads an RGL file into the collector's samples (file number `fi`, called `name`), with
/// the note and provenance the user and the output file get. See the module documentation for
/// what is kept.
pub(crate) fn collect_rgl(
    fi: usize,
    name: &str,
    bytes: &[u8],
    options: &ReadOptions,
    samples: &mut Vec<Sample>,
    report: &mut ReadReport,
) -> Result<()> {
    let here = |e: RglError| Error::Input(format!("{name}: {e}"));
    let bsdf = RglBsdf::from_bytes(bytes).map_err(here)?;
    let upsampler = match (&bsdf.channels, options.rgb_to_spectrum) {
        (Channels::Rgb, None) => return Err(Error::Input(rgb_refusal(name))),
        (Channels::Rgb, Some(RgbToSpectrum::JakobHanika2019)) => Some(Upsampler::new()),
        (Channels::Spectral { .. }, _) => None,
    };
    let all = bsdf.samples(90.0, 90.0).map_err(here)?;
    let (kept, left_out): (Vec<_>, Vec<_>) =
        all.into_iter().partition(|s| s.theta_i <= MAX_THETA_I);
    if kept.is_empty() {
        return Err(Error::Input(format!(
            "{name}: no stored incidence at or below {MAX_THETA_I}° (the file has θi = {})",
            degrees_list(left_out.iter().map(|s| s.theta_i), 6)
        )));
    }
    let wavelengths: Vec<f64> = match &bsdf.channels {
        Channels::Spectral { wavelengths } => wavelengths.iter().map(|&w| w as f64).collect(),
        Channels::Rgb => UPSAMPLED_WAVELENGTHS.to_vec(),
    };
    let nc = bsdf.channel_count();
    let (mut clamped, mut worst_fit, mut directions, mut filled) = (0usize, 0f64, 0usize, 0usize);
    for s in &kept {
        let (ti, pi) = (s.theta_i.to_bits(), s.phi_i.to_bits());
        let incidence = [s.index[0] as u32, s.index[1] as u32];
        let (fill_dirs, fill_values) = fill_gaps(&bsdf, s).map_err(here)?;
        directions += s.directions.len();
        filled += fill_dirs.len();
        let nodes = s.directions.iter().enumerate().map(|(k, d)| {
            let place = Place::Node {
                incidence,
                row: s.nodes[k][0],
                column: s.nodes[k][1],
            };
            (place, d, &s.values[k * nc..(k + 1) * nc])
        });
        let fills = fill_dirs.iter().enumerate().map(|(k, d)| {
            let place = Place::Fill {
                incidence,
                index: k as u32,
            };
            (place, d, &fill_values[k * nc..(k + 1) * nc])
        });
        for (place, d, values) in nodes.chain(fills) {
            let spectrum: Vec<f64> = match &upsampler {
                None => values.to_vec(),
                Some(up) => {
                    let fit = up
                        .fit([values[0], values[1], values[2]])
                        .map_err(|e| Error::Input(format!("{name}: {e}")))?;
                    clamped += fit.clamped as usize;
                    worst_fit = worst_fit.max(fit.rel_error);
                    wavelengths.iter().map(|&l| fit.spectrum.eval(l)).collect()
                }
            };
            let (to, po) = (d[0].to_bits(), d[1].to_bits());
            for (&l, v) in wavelengths.iter().zip(spectrum) {
                samples.push(Sample {
                    key: [ti, pi, to, po, l.to_bits()],
                    value: v,
                    file: fi as u32,
                    place,
                });
            }
        }
    }
    let base = Path::new(name)
        .file_name()
        .map_or_else(|| name.to_string(), |f| f.to_string_lossy().into_owned());
    let used = degrees_list(kept.iter().map(|s| s.theta_i), 2);
    let mut what = format!(
        "{}; RGL material database (Dupuy & Jakob 2018), read by sbrdf's RGL reader: θi = {used}°",
        bsdf.description.trim()
    );
    if !left_out.is_empty() {
        what += &format!(
            " (left out above {MAX_THETA_I}°: {}°)",
            degrees_list(left_out.iter().map(|s| s.theta_i), 6)
        );
    }
    what += &format!(
        "; grid nodes below the horizon dropped, nodes sharing a direction averaged; {filled} \
         samples added from the file's own interpolation (Mitsuba's) on a {FILL_STEP_DEG}° grid \
         where no node lay within {FILL_GAP_DEG}°"
    );
    if upsampler.is_some() {
        what += &format!(
            "; RGB made spectral (rgb_to_spectrum), {clamped} colours with a negative component \
             set to 0 first"
        );
    }
    report.provenance.push((format!("rgl:{base}"), what));
    let mut note = format!(
        "{name}: RGL measurement \"{}\", {} of {} stored incidences (θi = {used}°), {directions} \
         outgoing directions from the grid and {filled} from the file's interpolation where the \
         grid leaves gaps over {FILL_GAP_DEG}°, {} wavelengths",
        bsdf.description.trim(),
        kept.len(),
        kept.len() + left_out.len(),
        wavelengths.len()
    );
    if !left_out.is_empty() {
        note += &format!(
            "; θi = {}° left out (above {MAX_THETA_I}°: values there reach 1e6–1e9 1/sr at nodes \
             within 1e-8 of the horizon)",
            degrees_list(left_out.iter().map(|s| s.theta_i), 6)
        );
    }
    if upsampler.is_some() {
        note += &format!(
            "; RGB made spectral by Jakob & Hanika 2019 ({} colours with a negative component \
             set to 0 first; worst colour error {worst_fit:.1e})",
            clamped
        );
        report.provenance.push((
            "rgb_to_spectrum".into(),
            format!(
                "{}: each grid node's linear sRGB turned into a Jakob & Hanika 2019 spectrum \
                 (sigmoid of a quadratic in λ) whose linear sRGB under D65 (CIE 1931 2°, \
                 380–780 nm every 5 nm, sbrdf's colour conversion) is the colour, sampled at \
                 380–780 nm every 10 nm; negative components set to 0 first; the spectra \
                 reproduce the colours, not the measured spectra",
                RgbToSpectrum::JakobHanika2019.name()
            ),
        ));
    }
    report.notes.push(note);
    Ok(())
}

/// Directions of a regular grid (θo = 2.5°, 7.5°, … 87.5°; φo every 5°, fewer toward the
/// pole) that lie more than [`FILL_GAP_DEG`] from every direction of `s`, with the file's own
/// value there: Mitsuba's `measured` evaluation (inverse warp, bilinear in the warped grid),
/// which [`Evaluator`] reproduces. The warped grid puts nodes where the VNDF is dense, so far
/// from the specular peak (backward and near the horizon at high θi) it leaves gaps of up to
/// 38° between nodes (and none above θo ≈ 85° at θi = 0); a fit left free there overshoots
/// (cc_ibiza_sunset: 8.5·10⁴ 1/sr at the horizon without the fill, 203 with it, where its
/// largest measured value is 213). A ring closer to the horizon (89.5°) was tried: it bounds
/// the fit there too, but Mitsuba's values in that ring carry 1/cos θo and pulled the fit of
/// the measured nodes of white paper from 8% to 29%, so the fill stops at 87.5°. Returns the
/// directions and `channel_count` values each.
pub fn fill_gaps(
    bsdf: &RglBsdf,
    s: &IncidenceSamples,
) -> std::result::Result<(Vec<[f64; 2]>, Vec<f64>), RglError> {
    let eval = bsdf.evaluator(s.index[0], s.index[1])?;
    let nc = bsdf.channel_count();
    let unit = |t: f64, p: f64| {
        let (t, p) = (t.to_radians(), p.to_radians());
        [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
    };
    let have: Vec<[f64; 3]> = s.directions.iter().map(|d| unit(d[0], d[1])).collect();
    let cos_gap = FILL_GAP_DEG.to_radians().cos();
    let (mut dirs, mut values) = (Vec::new(), Vec::new());
    let mut out = vec![0.0; nc];
    let rings = (90.0 / FILL_STEP_DEG).round() as usize;
    for t in (0..rings).map(|i| (i as f64 + 0.5) * FILL_STEP_DEG) {
        // About FILL_STEP_DEG apart along the ring too.
        let n = ((360.0 * t.to_radians().sin() / FILL_STEP_DEG).round() as usize).max(6);
        for j in 0..n {
            let p = 360.0 * j as f64 / n as f64;
            let w = unit(t, p);
            let near = have
                .iter()
                .any(|h| h[0] * w[0] + h[1] * w[1] + h[2] * w[2] >= cos_gap);
            if !near && eval.eval(t, p, &mut out) {
                dirs.push([t, p]);
                values.extend_from_slice(&out);
            }
        }
    }
    Ok((dirs, values))
}

/// Angles as `0, 27.67, 39.86` (`digits` decimals, trailing zeros dropped).
fn degrees_list(v: impl Iterator<Item = f64>, digits: usize) -> String {
    v.map(|d| {
        let s = format!("{d:.digits$}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    })
    .collect::<Vec<_>>()
    .join(", ")
}
