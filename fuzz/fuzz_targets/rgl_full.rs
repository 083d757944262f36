//! The heavy paths of the RGL reader on arbitrary bytes: the whole read as `sbrdf encode
//! --rgb-to-spectrum jakob-hanika-2019` does it (samples, gap filling from the file's own
//! interpolation on a 5° grid, one Jakob & Hanika 2019 fit per RGB colour, the collector's
//! checks), the same read without upsampling (spectral files), and the read for warped tables.
//! Each opened input costs milliseconds (about a thousand evaluations per stored incidence for
//! the gap filling, a Newton fit per node and filled direction), so this target runs far fewer
//! inputs than `rgl`, which fuzzes the parser and its checks.
#![no_main]
use libfuzzer_sys::fuzz_target;
use sbrdf::io::{ReadOptions, RgbToSpectrum};

fuzz_target!(|data: &[u8]| {
    // Cheap refusal first: only what opens goes on.
    if sbrdf::io::rgl::RglBsdf::from_bytes(data).is_err() {
        return;
    }
    let upsample = ReadOptions {
        rgb_to_spectrum: Some(RgbToSpectrum::JakobHanika2019),
    };
    for options in [&upsample, &ReadOptions::default()] {
        let _ = sbrdf::io::read_inputs_from_bytes_with(
            &[("fuzz_rgb.bsdf".into(), data.to_vec())],
            options,
        );
        let _ = sbrdf::io::rgl::read_warped("fuzz_rgb.bsdf", data, options);
    }
});
