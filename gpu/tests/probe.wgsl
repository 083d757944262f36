// A stand-in for shaders/sbrdf.wgsl with the same contract (no binding; reads the host's
// sbrdf_words), used by tests/plumbing.rs to test the harness itself: that a material is found
// at its base word offset, and that the query's fields reach the functions.

// λmin (header word 11) of the material at `base`, plus the query's wavelength, plus wi.x and
// wo.y (exact integers in the test, so the sum is exact on any device).
fn sbrdf_eval(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: f32) -> f32 {
    return bitcast<f32>(sbrdf_words[base + 11u]) + lambda_nm + wi.x + wo.y;
}

// sbrdf_eval at each of the four wavelengths.
fn sbrdf_eval4(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(sbrdf_eval(base, wi, wo, lambda_nm.x), sbrdf_eval(base, wi, wo, lambda_nm.y),
        sbrdf_eval(base, wi, wo, lambda_nm.z), sbrdf_eval(base, wi, wo, lambda_nm.w));
}

// The header's λmin, λmax and total_words of the material at `base`.
fn sbrdf_eval_rgb(base: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        bitcast<f32>(sbrdf_words[base + 11u]),
        bitcast<f32>(sbrdf_words[base + 12u]),
        f32(sbrdf_words[base + 2u]),
    );
}
