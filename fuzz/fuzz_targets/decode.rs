//! Open a file from arbitrary bytes and, if it opens, evaluate it at a few directions: nothing
//! may panic, hang, or produce a NaN. CRCs are skipped under cfg(fuzzing) so the fuzzer reaches
//! the parser behind them. Warped tables are refused above 2^23 operations to open (the golden
//! WARP files need 3.8 million; the default limit, 2^27, lets a hostile 1 kB file cost ~0.1 s
//! each): the reader and its checks at fuzzing speed. `decode_full` takes the default limits
//! and also writes what it read.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let limits = sbrdf::Limits {
        max_warp_work: 1 << 23,
        ..Default::default()
    };
    let Ok(dec) = sbrdf::Decoder::from_bytes_with_limits(data, &limits) else {
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
});
