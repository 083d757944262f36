//! The ASTM E1392 reader on arbitrary text, then the shared sample-set checks: errors are fine,
//! panics are not.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if sbrdf::io::astm::read_astm("fuzz.astm", data).is_ok() {
        let _ = sbrdf::io::read_inputs_from_bytes(&[("fuzz.astm".into(), data.to_vec())]);
    }
});
