//! The heavy half of `decode`: open a file from arbitrary bytes with the default limits (warped
//! tables up to their full opening cost), evaluate it, and write the material it read back out.
//! Nothing may panic, hang, or produce a NaN. CRCs are skipped under cfg(fuzzing).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "decode_checks.rs"]
mod decode_checks;

fuzz_target!(|data: &[u8]| {
    let Ok(dec) = sbrdf::Decoder::from_bytes(data) else {
        return;
    };
    decode_checks::evaluate(&dec);
    let _ = sbrdf::write_material(dec.material()).expect("a material that was read can be written");
});
