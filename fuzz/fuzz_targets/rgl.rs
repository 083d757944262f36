//! The RGL reader (`sbrdf::io::rgl`, Mitsuba `tensor_file` v1.0) on arbitrary bytes: errors are
//! fine, panics, hangs and allocations beyond the bytes present are not. Whatever opens is
//! turned into samples (every grid node, warped forward), its cheap accessors are called, and
//! its first stored incidence is evaluated at a few directions (Mitsuba's inverse warp). The
//! whole read (gap filling, RGB-to-spectrum upsampling, warped tables) is the `rgl_full`
//! target: it costs milliseconds per input, this one microseconds.
#![no_main]
use libfuzzer_sys::fuzz_target;
use sbrdf::io::rgl::RglBsdf;

fuzz_target!(|data: &[u8]| {
    let Ok(b) = RglBsdf::from_bytes(data) else {
        return;
    };
    let _ = b.samples(90.0, 90.0);
    let _ = b.isotropic_warp_parts();
    let _ = (b.values_field(), b.is_rgb(), b.incidence_usable(0));
    let _ = b.valid_bits(0, 0);
    if let Ok(e) = b.evaluator(0, 0) {
        let mut out = vec![0.0; b.channel_count()];
        for (t, p) in [(0.0, 0.0), (30.0, 180.0), (60.0, 95.0), (89.9, 10.0)] {
            e.eval(t, p, &mut out);
        }
    }
});
