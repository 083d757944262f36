//! Open a file from arbitrary bytes and, if it opens, evaluate it at a few directions: nothing
//! may panic, hang, or produce a NaN. CRCs are skipped under cfg(fuzzing) so the fuzzer reaches
//! the parser behind them. Warped tables are refused above 2^20 operations to open (the golden
//! WARP files need 3.8 million, so none of them opens here; the default limit, 2^27, lets a
//! hostile 1 kB file cost ~0.1 s each): the reader and its checks at fuzzing speed (at 2^23 the
//! golden warped files opened and the target ran 224 289 inputs in 150 s, below the 300 000 it
//! must reach). `decode_full` takes the default limits, opens them, and also writes what it read.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "decode_checks.rs"]
mod decode_checks;

fuzz_target!(|data: &[u8]| {
    let limits = sbrdf::Limits {
        max_warp_work: 1 << 20,
        ..Default::default()
    };
    let Ok(dec) = sbrdf::Decoder::from_bytes_with_limits(data, &limits) else {
        return;
    };
    decode_checks::evaluate(&dec);
});
