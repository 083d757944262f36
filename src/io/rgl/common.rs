//! What the RGL reader's parts share: the container's magic, which stored incidences are kept
//! and where gaps are filled, the wavelengths RGB is upsampled to, and the names and refusals
//! the user reads.

use crate::encode::samples::RgbToSpectrum;
use std::path::Path;

/// The first 12 bytes of every tensor file.
pub const MAGIC: &[u8; 12] = b"tensor_file\0";

/// Stored incidences above this θi (degrees) are left out by `sbrdf encode`: the module
/// documentation says why.
pub const MAX_THETA_I: f64 = 85.0;

/// Gap filling (see [`super::fill_gaps`]): candidate directions on a grid of this step (degrees) in
/// θo (from half a step to 90° minus half a step) and φo ...
#[cfg(not(fuzzing))]
pub const FILL_STEP_DEG: f64 = 5.0;

/// ... 30° in fuzz builds (`cfg(fuzzing)`, as CRCs are skipped there): the 5° grid is about 830
/// candidates per stored incidence whatever the file's size, each filled one a Jakob & Hanika
/// fit for an RGB file, so a 100-byte incidence of a hostile file costs milliseconds; at 30°
/// (26 candidates) the same code runs at fuzzing speed (the `rgl_full` target).
#[cfg(fuzzing)]
pub const FILL_STEP_DEG: f64 = 30.0;

/// ... are added where no grid node lies within this angle (degrees).
pub const FILL_GAP_DEG: f64 = 5.0;

/// The wavelengths (nm) at which spectra made from RGB are sampled: 380–780 nm every 10 nm,
/// the CIE tables' range. The sigmoid spectra are smooth (three parameters), so 10 nm loses
/// nothing a linear interpolation between samples would not recover.
pub const UPSAMPLED_WAVELENGTHS: [f64; 41] = {
    let mut a = [0.0; 41];
    let mut i = 0;
    while i < 41 {
        a[i] = 380.0 + 10.0 * i as f64;
        i += 1;
    }
    a
};

/// The name of the spectral version of an RGL file: `x_rgb.bsdf` → `x_spec.bsdf`.
pub fn spectral_name(name: &str) -> String {
    let file = Path::new(name)
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| name.to_string());
    match file.strip_suffix("_rgb.bsdf") {
        Some(stem) => format!("{stem}_spec.bsdf"),
        None => "the material's `_spec.bsdf` file".to_string(),
    }
}

/// The message that refuses an RGB file.
pub(crate) fn rgb_refusal(name: &str) -> String {
    format!(
        "{name}: an RGB measurement (field \"rgb\": linear sRGB, no spectra), and sbrdf encodes \
         spectra. Use the spectral version of this material, {} (RGL material database, \
         rgl.epfl.ch/materials), or pass --rgb-to-spectrum {} to make a spectrum from each \
         colour by Jakob & Hanika 2019 (recorded in the file's metadata; the spectra reproduce \
         the colours, not the real spectra)",
        spectral_name(name),
        RgbToSpectrum::JakobHanika2019.name()
    )
}
