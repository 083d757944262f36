//! The RGL reader (`sbrdf::io::rgl`, Mitsuba `tensor_file` v1.0) on arbitrary bytes: errors are
//! fine, panics, hangs and allocations beyond the bytes present are not. Whatever opens is
//! turned into samples, evaluated between its nodes, and read as `sbrdf encode
//! --rgb-to-spectrum jakob-hanika-2019` would read it (the collector's checks included).
#![no_main]
use libfuzzer_sys::fuzz_target;
use sbrdf::io::rgl::RglBsdf;
use sbrdf::io::{ReadOptions, RgbToSpectrum};

fuzz_target!(|data: &[u8]| {
    let Ok(b) = RglBsdf::from_bytes(data) else {
        return;
    };
    let _ = b.samples(90.0, 90.0);
    if let Ok(e) = b.evaluator(0, 0) {
        let mut out = vec![0.0; b.channel_count()];
        e.eval(30.0, 180.0, &mut out);
        e.eval(89.9, 10.0, &mut out);
    }
    let options = ReadOptions {
        rgb_to_spectrum: Some(RgbToSpectrum::JakobHanika2019),
    };
    let _ = sbrdf::io::read_inputs_from_bytes_with(
        &[("fuzz_rgb.bsdf".into(), data.to_vec())],
        &options,
    );
    // What warped tables read of it (spectral files only: an RGB one would be upsampled node
    // by node, the heavy path above).
    let _ = sbrdf::io::rgl::read_warped("fuzz_spec.bsdf", data, &ReadOptions::default());
});
