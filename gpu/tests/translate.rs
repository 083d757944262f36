//! The shader, after the host prelude and with compute entry points that call both of its
//! functions, parses and validates with naga (the shader compiler wgpu, Firefox and others use)
//! and translates to every backend: SPIR-V (Vulkan), HLSL (Direct3D), MSL (Metal) and GLSL
//! (OpenGL ES 3.1 compute). Each writer must return Ok and non-empty output. This runs without a
//! device: it catches what a backend cannot express before anyone renders with it.

mod common;
mod sampling;
use common::*;
use naga::back::{glsl, hlsl, msl, spv};
use naga::valid::{Capabilities, ValidationFlags, Validator};
use sampling::{SAMPLING_ENTRIES, SAMPLING_ENTRY_POINTS};

/// Parses, validates and writes `src` with every backend; panics naming the step that failed.
fn translate_everywhere(src: &str, what: &str, expect: &[&str]) {
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("{what}: WGSL parse error:\n{}", e.emit_to_string(src)));
    // Default capabilities: what every backend supports, not what one device adds.
    let info = Validator::new(ValidationFlags::all(), Capabilities::default())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{what}: validation error:\n{}", e.emit_to_string(src)));
    let entries: Vec<String> = module.entry_points.iter().map(|e| e.name.clone()).collect();
    assert_eq!(entries, expect, "{what}: entry points");

    let spirv = spv::write_vec(&module, &info, &spv::Options::default(), None)
        .unwrap_or_else(|e| panic!("{what}: SPIR-V: {e}"));
    assert!(spirv.len() > 5, "{what}: SPIR-V is only a header");
    assert_eq!(spirv[0], 0x0723_0203, "{what}: SPIR-V magic");

    let mut hlsl_out = String::new();
    hlsl::Writer::new(&mut hlsl_out, &hlsl::Options::default())
        .write(&module, &info, None)
        .unwrap_or_else(|e| panic!("{what}: HLSL: {e}"));

    let (msl_out, _) = msl::write_string(
        &module,
        &info,
        &msl::Options::default(),
        &msl::PipelineOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{what}: MSL: {e}"));

    // GLSL is written one entry point at a time.
    let mut glsl_out = Vec::new();
    for entry in &entries {
        let mut s = String::new();
        let options = glsl::Options::default(); // OpenGL ES 3.1, the first with compute shaders
        let pipeline = glsl::PipelineOptions {
            shader_stage: naga::ShaderStage::Compute,
            entry_point: entry.clone(),
            multiview: None,
        };
        glsl::Writer::new(
            &mut s,
            &module,
            &info,
            &options,
            &pipeline,
            naga::proc::BoundsCheckPolicies::default(),
        )
        .and_then(|mut w| w.write())
        .unwrap_or_else(|e| panic!("{what}: GLSL ({entry}): {e}"));
        glsl_out.push(s);
    }

    // Each output must carry both kernels (names may be mangled, so look for the calls' callee).
    for (lang, text) in [("HLSL", &hlsl_out), ("MSL", &msl_out)] {
        assert!(expect.iter().all(|e| text.contains(e)), "{what}: {lang}");
    }
    for (entry, text) in entries.iter().zip(&glsl_out) {
        assert!(
            text.contains("void main()"),
            "{what}: GLSL ({entry}) has no main"
        );
    }
    println!(
        "{what}: SPIR-V {} words, HLSL {} bytes, MSL {} bytes, GLSL {:?} bytes",
        spirv.len(),
        hlsl_out.len(),
        msl_out.len(),
        glsl_out.iter().map(String::len).collect::<Vec<_>>()
    );
}

#[test]
fn shader_translates_to_every_backend() {
    let path = shader_path();
    translate_everywhere(
        &full_module(&shader_source()),
        &path.display().to_string(),
        &["eval_spectral", "eval_four", "eval_rgb"],
    );
}

/// The same with the entry points of the sampling functions (`sbrdf_pdf`, `sbrdf_sample`) too.
#[test]
fn sampling_functions_translate_to_every_backend() {
    let path = shader_path();
    let src = format!("{}\n{SAMPLING_ENTRY_POINTS}", full_module(&shader_source()));
    let mut expect = vec!["eval_spectral", "eval_four", "eval_rgb"];
    expect.extend(SAMPLING_ENTRIES);
    translate_everywhere(&src, &path.display().to_string(), &expect);
}

/// The same for the stand-in shader of `plumbing.rs`: the prelude and entry points themselves
/// are valid and portable, so a failure of the test above is the shader's.
#[test]
fn prelude_and_entry_points_translate() {
    translate_everywhere(
        &full_module(include_str!("probe.wgsl")),
        "tests/probe.wgsl",
        &["eval_spectral", "eval_four", "eval_rgb"],
    );
}
