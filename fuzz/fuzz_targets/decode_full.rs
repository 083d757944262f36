//! The heavy half of `decode`: open a file from arbitrary bytes with the default limits (warped
//! tables up to their full opening cost), evaluate it, and write the material it read back out.
//! Nothing may panic, hang, or produce a NaN. CRCs are skipped under cfg(fuzzing).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(dec) = sbrdf::Decoder::from_bytes(data) else {
        return;
    };
    let m = dec.material();
    let wl = [
        m.spectral.lambda_min as f32,
        m.spectral.lambda_max as f32,
        550.0,
    ];
    let mut out = [0.0f32; 3];
    for (wi, wo) in [
        ([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
        ([0.5, 0.0, 0.866], [-0.5, 0.0, 0.866]),
        ([0.0, 0.999, 0.04], [1.0, 0.0, 0.0]),
    ] {
        dec.eval(wi, wo, &wl, &mut out);
        // Finite stored values can still overflow f32 when summed; what must never happen is a
        // NaN from the evaluation itself.
        assert!(
            out.iter().all(|v| !v.is_nan()),
            "NaN from a file that validated"
        );
    }
    let _ = sbrdf::write_material(m).expect("a material that was read can be written");
});
