//! The CSV reader on arbitrary text: errors are fine, panics are not.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = sbrdf::io::csv::read_samples_from_bytes(&[("fuzz.csv".to_string(), data.to_vec())]);
});
