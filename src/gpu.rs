//! The WGSL evaluation module: `shaders/sbrdf.wgsl` as a string, to paste into a host shader.
//!
//! [`WGSL`] evaluates a material from its flat device layout ([`crate::Decoder::gpu_layout`],
//! `spec/GPU_LAYOUT.md`, version 3) in f32 on a GPU:
//!
//! * `sbrdf_eval(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: f32) -> f32`: ρ in 1/sr,
//!   as [`crate::Decoder::eval`] computes it;
//! * `sbrdf_eval4(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: vec4<f32>) -> vec4<f32>`:
//!   ρ at four wavelengths (a hero-wavelength renderer's), the directions' work done once;
//!   component i is `sbrdf_eval` at `lambda_nm[i]`;
//! * `sbrdf_eval_rgb(base: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32>`: linear sRGB under
//!   D65, as [`crate::Decoder::eval_linear_srgb`] with
//!   [`Illuminant::D65`](crate::decode::color::Illuminant::D65);
//! * `sbrdf_pdf(base: u32, wi: vec3<f32>, wo: vec3<f32>) -> f32` and `sbrdf_sample(base: u32, wi:
//!   vec3<f32>, u: vec2<f32>) -> vec4<f32>` (direction in xyz, pdf in w): importance sampling as
//!   [`crate::Decoder::pdf`] and [`crate::Decoder::sample`], from the layout's sampling section
//!   (versions 2 and 3; a layout without one samples the cosine). A factor model (`FACT`) is the
//!   layout's model section (version 3), whose F every evaluation adds.
//!
//! The text declares no binding: the host declares the storage array it reads, under the name
//! `sbrdf_words`, before the module's text, and fills it with the layout's words (several
//! materials may follow one another; `base` is the word offset of a material's layout):
//!
//! ```
//! let host = format!(
//!     "@group(0) @binding(0) var<storage, read> sbrdf_words: array<u32>;\n{}",
//!     sbrdf::gpu::WGSL
//! );
//! assert!(host.contains("fn sbrdf_eval("));
//! assert!(host.contains("fn sbrdf_sample("));
//! ```
//!
//! Directions are vectors in the local frame with z the normal, `wi` toward the light and `wo`
//! toward the viewer, as for [`crate::Decoder::eval`]; a zero, non-finite or below-horizon
//! direction, or a non-finite wavelength, gives 0. The module's header comment says the rest, and
//! `docs/renderers.md` ("On a GPU") how to use it. This module needs no feature and no
//! dependency: the shader is text, compiled by whatever GPU API the renderer uses.

/// The text of `shaders/sbrdf.wgsl`: WGSL functions that evaluate a flat device layout.
pub const WGSL: &str = include_str!("../shaders/sbrdf.wgsl");

#[cfg(test)]
mod tests {
    use super::WGSL;
    use crate::decode::cie;

    /// The shader's `SBRDF_RGB_WEIGHTS`, parsed from its text.
    fn wgsl_weights() -> Vec<[f32; 3]> {
        let start = WGSL
            .find("const SBRDF_RGB_WEIGHTS")
            .expect("the weights' declaration");
        let body = &WGSL[start..];
        let body = &body[..body.find(");\n").expect("the array's end")];
        body.split("vec3<f32>(")
            .skip(1) // the declaration up to the first row
            .map(|row| {
                let row = &row[..row.find(')').expect("a row's end")];
                let v: Vec<f32> = row
                    .split(',')
                    .map(|x| x.trim().parse().expect("an f32 literal"))
                    .collect();
                [v[0], v[1], v[2]]
            })
            .collect()
    }

    /// The weights the shader must hold: what `color.rs` computes for a spectrum that is 1 at
    /// wavelength i and 0 elsewhere (its own functions, so its order of operations), rounded to
    /// f32.
    fn cie_weights() -> Vec<[f32; 3]> {
        use crate::decode::color::{spectrum_to_xyz, xyz_to_linear_srgb, Illuminant};
        (0..cie::COUNT)
            .map(|i| {
                let mut one = [0.0f32; cie::COUNT];
                one[i] = 1.0;
                let rgb = xyz_to_linear_srgb(spectrum_to_xyz(&one, Illuminant::D65));
                rgb.map(|v| v as f32)
            })
            .collect()
    }

    /// The generated constants cannot drift from `cie.rs`: regenerate them with
    /// `python3 tools/gen_wgsl_rgb_weights.py` when this fails.
    #[test]
    fn rgb_weights_match_cie_tables() {
        let (got, want) = (wgsl_weights(), cie_weights());
        assert_eq!(got.len(), cie::COUNT);
        assert_eq!(got, want);
        // The shader's loop covers the CPU's wavelengths: 380 + 5 i nm for i < 81.
        assert_eq!((cie::FIRST_NM, cie::STEP_NM, cie::COUNT), (380.0, 5.0, 81));
        assert!(WGSL.contains("for (var i = 0u; i < 81u; i = i + 1u)"));
        assert!(WGSL.contains("let lambda = 380.0 + 5.0 * f32(i);"));
    }

    /// The module is pasted after the host's declarations: a binding of its own would collide
    /// with the host's, and it must read the array the host names `sbrdf_words`.
    #[test]
    fn declares_no_binding_and_reads_sbrdf_words() {
        let code: String = WGSL
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .collect::<Vec<_>>()
            .join("\n");
        assert!(!code.contains("@group") && !code.contains("@binding"));
        assert!(!code.contains("var<storage"));
        assert!(code.contains("sbrdf_words["));
        assert!(code.contains(
            "fn sbrdf_eval(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: f32) -> f32"
        ));
        assert!(code
            .contains("fn sbrdf_eval_rgb(base: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32>"));
        assert!(code.contains(
            "fn sbrdf_eval4(base: u32, wi: vec3<f32>, wo: vec3<f32>, lambda_nm: vec4<f32>) -> vec4<f32>"
        ));
    }
}
