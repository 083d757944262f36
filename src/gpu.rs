//! The WGSL evaluation module: `shaders/sbrdf.wgsl` as a string, to paste into a host shader.
//!
//! [`WGSL`] evaluates a material from its flat device layout ([`crate::Decoder::gpu_layout`],
//! `spec/GPU_LAYOUT.md`, versions 1 to 4) in f32 on a GPU:
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
//!   (versions 2 to 4; a layout without one samples the cosine). A factor model (`FACT`) is the
//!   layout's model section (version 3), whose F every evaluation adds; warped tables (`WARP`,
//!   version 4) are a model section that evaluates and samples itself.
//!
//! The text declares no binding: the host declares the storage array it reads, under the name
//! `sbrdf_words`, before the module's text, and fills it with the layout's words (several
//! materials may follow one another, as [`pack`] puts them; `base` is the word offset of a
//! material's layout):
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
//! `docs/guide/renderers.md` ("On a GPU") how to use it. This module needs no feature and no
//! dependency: the shader is text, compiled by whatever GPU API the renderer uses.

/// The text of `shaders/sbrdf.wgsl`: WGSL functions that evaluate a flat device layout.
pub const WGSL: &str = include_str!("../shaders/sbrdf.wgsl");

// Packing lives with the layout in the decoder (the C API packs too, and the decoder does not
// depend on this module); renderers find it here beside the shader it feeds.
pub use crate::decode::gpu_layout::pack::{pack, pack_layouts, Packed};

#[cfg(test)]
mod tests {
    use super::{pack, pack_layouts, WGSL};
    use crate::decode::color::cie;
    use crate::Decoder;

    fn golden(name: &str) -> Decoder {
        Decoder::open(format!(
            "{}/samples/golden/{name}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap()
    }

    /// `pack` concatenates the decoders' own layouts, in order, each at its base.
    #[test]
    fn pack_concatenates_the_layouts() {
        let names = [
            "ggx_3inc_default.sbrdf",
            "krylon_shared_v11.sbrdf",
            "ggx_aniso_lattice_v12.sbrdf",
        ];
        let decoders: Vec<Decoder> = names.iter().map(|n| golden(n)).collect();
        let packed = pack(&decoders.iter().collect::<Vec<_>>()).unwrap();
        let mut at = 0;
        for (d, &base) in decoders.iter().zip(&packed.bases) {
            let layout = d.gpu_layout().unwrap();
            assert_eq!(base as usize, at);
            assert_eq!(&packed.words[at..at + layout.len()], &layout[..]);
            at += layout.len();
        }
        assert_eq!((packed.bases.len(), packed.words.len()), (3, at));
    }

    /// What `pack` and `pack_layouts` refuse, each with a message naming the material.
    #[test]
    fn pack_refuses_what_the_shader_cannot_read() {
        let good = golden("ggx_3inc_default.sbrdf").gpu_layout().unwrap();
        let refused = |layouts: &[&[u32]], what: &str| {
            let e = pack_layouts(layouts).unwrap_err().to_string();
            assert!(e.contains(what), "{e:?} lacks {what:?}");
        };
        refused(&[], "no materials");
        refused(&[&good, &good[..19]], "material 1: 19 words");
        let mut bad = good.clone();
        bad[0] ^= 1;
        refused(&[&bad], "magic");
        let mut bad = good.clone();
        bad[1] = 0;
        refused(&[&good, &bad], "material 1: layout version 0");
        bad[1] = crate::decode::gpu_layout::GPU_LAYOUT_VERSION + 1;
        refused(&[&bad], "layout version");
        let mut bad = good.clone();
        bad.push(0);
        refused(&[&bad], "total_words");
        // Every version the shader reads is accepted (word 1 alone changed).
        for v in 1..=crate::decode::gpu_layout::GPU_LAYOUT_VERSION {
            let mut l = good.clone();
            l[1] = v;
            assert!(pack_layouts(&[&l]).is_ok(), "version {v}");
        }
        // Every file is laid out since version 4 (warped tables included): such a pair packs,
        // each material at its base, its words those of its own layout.
        let ggx = golden("ggx_3inc_default.sbrdf");
        let warp = golden("rgl_paper_warp_v14.sbrdf");
        let p = pack(&[&ggx, &warp]).unwrap();
        let (a, b) = (ggx.gpu_layout().unwrap(), warp.gpu_layout().unwrap());
        assert_eq!(p.bases, vec![0, a.len() as u32]);
        assert_eq!(p.words.len(), a.len() + b.len());
        assert_eq!(&p.words[a.len()..], &b[..], "the warped layout's words");
    }

    /// The text of `shaders/sbrdf.wgsl` between its `// BEGIN GENERATED {what}` and
    /// `// END GENERATED {what}` lines.
    fn generated(what: &str) -> &'static str {
        let begin = format!("// BEGIN GENERATED {what}\n");
        let end = format!("// END GENERATED {what}\n");
        let a = WGSL.find(&begin).expect("the block's first marker") + begin.len();
        let b = WGSL.find(&end).expect("the block's last marker");
        &WGSL[a..b]
    }

    /// The shader's colour weights, parsed from `sbrdf_rgb_weights4`'s columns in order (the
    /// padding columns `vec3<f32>(0.0)` of the last group left out).
    fn wgsl_weights() -> Vec<[f32; 3]> {
        generated("RGB WEIGHTS")
            .split("vec3<f32>(")
            .skip(1) // the function up to the first column
            .filter_map(|col| {
                let col = &col[..col.find(')').expect("a column's end")];
                let v: Vec<f32> = col
                    .split(',')
                    .map(|x| x.trim().parse().expect("an f32 literal"))
                    .collect();
                (v.len() == 3).then(|| [v[0], v[1], v[2]])
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
        // The shader's loop covers the CPU's wavelengths, 380 + 5 i nm for i < 81, four at a
        // time (group g holds i = 4g .. 4g + 3; the last group only i = 80), and the padding
        // columns of the last group are the only zero columns.
        assert_eq!((cie::FIRST_NM, cie::STEP_NM, cie::COUNT), (380.0, 5.0, 81));
        assert!(WGSL.contains("for (var g = 0u; g < 21u; g = g + 1u)"));
        assert!(WGSL.contains(
            "let lambda = vec4<f32>(380.0 + 20.0 * f32(g)) + vec4<f32>(0.0, 5.0, 10.0, 15.0);"
        ));
        assert!(WGSL.contains("let nl = select(4u, 1u, g == 20u);"));
        assert_eq!(
            generated("RGB WEIGHTS").matches("vec3<f32>(0.0)").count(),
            3
        );
    }

    /// The shader's layout constants are the Rust table's (`src/decode/gpu_layout/words.rs`, the one
    /// definition of the layout's word offsets). With `SBRDF_REGENERATE=1` in the environment
    /// the test writes the table's block into `shaders/sbrdf.wgsl` instead of failing.
    #[test]
    fn layout_words_match_the_rust_table() {
        let want = crate::decode::gpu_layout::words::wgsl_block();
        if generated("LAYOUT WORDS") == want {
            return;
        }
        if std::env::var_os("SBRDF_REGENERATE").is_some() {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/sbrdf.wgsl");
            let text = std::fs::read_to_string(path).expect("the shader's file");
            let (begin, end) = (
                "// BEGIN GENERATED LAYOUT WORDS\n",
                "// END GENERATED LAYOUT WORDS\n",
            );
            let a = text.find(begin).expect("the block's first marker") + begin.len();
            let b = text.find(end).expect("the block's last marker");
            std::fs::write(path, format!("{}{want}{}", &text[..a], &text[b..]))
                .expect("writing the shader");
            eprintln!("regenerated the layout constants of {path}");
            return;
        }
        panic!(
            "shaders/sbrdf.wgsl's layout constants (between // BEGIN GENERATED LAYOUT WORDS and \
             // END GENERATED LAYOUT WORDS) differ from src/decode/gpu_layout/words.rs; regenerate them \
             with `SBRDF_REGENERATE=1 cargo test --lib gpu::tests::layout_words_match_the_rust_table`\n\
             --- the shader's block:\n{}\n--- the table's:\n{want}",
            generated("LAYOUT WORDS")
        );
    }

    /// No word offset is written as a number outside the generated block: every read of a
    /// table's word names it (`sbrdf_u(e + SBRDF_REC_TERMS)`, not `sbrdf_u(e + 5u)`). The
    /// words a read starts from are a material's base and the absolute words of its tables.
    #[test]
    fn no_literal_word_offsets() {
        let block = generated("LAYOUT WORDS");
        let code = WGSL.replacen(block, "", 1);
        let mut found = Vec::new();
        for (n, line) in code.lines().enumerate() {
            let line = line.split("//").next().unwrap();
            for start in ["base", "e", "m", "lt"] {
                for read in ["sbrdf_u(", "sbrdf_f("] {
                    let pat = format!("{read}{start} + ");
                    for (i, _) in line.match_indices(&pat) {
                        let rest = &line[i + pat.len()..];
                        if rest.starts_with(|c: char| c.is_ascii_digit()) {
                            found.push(format!("line {}: {}", n + 1, line.trim()));
                        }
                    }
                }
            }
        }
        assert!(found.is_empty(), "literal word offsets: {found:#?}");
        // What the check looks for is there to be found: reads through the named offsets.
        assert!(code.contains("sbrdf_u(e + SBRDF_REC_TERMS)"));
        assert!(code.contains("sbrdf_u(base + SBRDF_HDR_OFF_MODEL)"));
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
