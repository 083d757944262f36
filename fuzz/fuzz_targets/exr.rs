//! The spectral-EXR slice reader on arbitrary bytes: errors are fine, panics, hangs and
//! unbounded allocations are not. Whatever reads is also pushed through the shared sample-set
//! checks, as `sbrdf encode` would.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if sbrdf::io::exr::read_slice("fuzz_ti15_pi0.exr", data).is_ok() {
        let _ = sbrdf::io::read_inputs_from_bytes(&[("fuzz_ti15_pi0.exr".into(), data.to_vec())]);
    }
});
