//! What `decode` and `decode_full` ask of every file that opens: a few evaluations, none NaN
//! (finite stored values can still overflow f32 when summed; what must never happen is a NaN
//! from the evaluation itself).

pub fn evaluate(dec: &sbrdf::Decoder) {
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
        assert!(
            out.iter().all(|v| !v.is_nan()),
            "NaN from a file that validated"
        );
    }
}
