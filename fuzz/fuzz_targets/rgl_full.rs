//! The heavy paths of the RGL reader on arbitrary bytes: the whole read as `sbrdf encode
//! --rgb-to-spectrum jakob-hanika-2019` does it (samples, gap filling from the file's own
//! interpolation, one Jakob & Hanika 2019 fit per RGB colour, the collector's checks), the same
//! read without upsampling, and the read for warped tables (`read_warped`), both ways.
//!
//! Bounds on the work per input, so that the target runs at fuzzing speed (over 300,000 inputs
//! in 150 s on two shared cores; `rgl`, which fuzzes the parser and its checks, runs millions):
//! * the gap-filling grid is 30° in fuzz builds (`FILL_STEP_DEG`, `cfg(fuzzing)`; 5° otherwise):
//!   the 5° grid is about 830 candidate directions per stored incidence whatever the file's
//!   size, each filled one a Newton fit for an RGB file, so milliseconds per 100-byte incidence.
//!   The same code runs, over 26 candidates;
//! * a spectral file is read once, not once per option: `rgb_to_spectrum` is ignored for
//!   spectral files, so the second pair of reads did the same work again (RGB files still go
//!   both ways: with upsampling, and without, which refuses them).
#![no_main]
use libfuzzer_sys::fuzz_target;
use sbrdf::io::{ReadOptions, RgbToSpectrum};

fuzz_target!(|data: &[u8]| {
    // Cheap refusal first: only what opens goes on.
    let Ok(bsdf) = sbrdf::io::rgl::RglBsdf::from_bytes(data) else {
        return;
    };
    let upsample = ReadOptions {
        rgb_to_spectrum: Some(RgbToSpectrum::JakobHanika2019),
    };
    let plain = ReadOptions::default();
    let options: &[&ReadOptions] = if bsdf.is_rgb() {
        &[&upsample, &plain]
    } else {
        &[&plain]
    };
    for options in options {
        let _ = sbrdf::io::read_inputs_from_bytes_with(
            &[("fuzz_rgb.bsdf".into(), data.to_vec())],
            options,
        );
        let _ = sbrdf::io::rgl::read_warped("fuzz_rgb.bsdf", data, options);
    }
});
