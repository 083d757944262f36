//! `cargo run --release --example gpu_preview -- FILE [OUT.png] [--size N] [--light θ,φ]`
//!
//! Renders `sbrdf preview`'s sphere on a GPU: the sub-samples of `sbrdf::preview` evaluated on
//! the device with the WGSL module's `sbrdf_eval_rgb` from the file's flat device layout, then
//! the preview's own tone curve. The same picture is rendered on the CPU (`Decoder::eval_linear_srgb`,
//! the path of `sbrdf preview`), and the two are compared pixel for pixel: the example prints
//! how many 8-bit channel values differ and by how much, and fails (exit status 1) if any
//! differs by more than one level (f32 on the device against f64 on the CPU moves a value
//! across a rounding boundary at most). Writes the device's picture to OUT.png (default
//! `gpu_preview.png`), through a temporary file and a rename.
//!
//! It runs on the first Vulkan adapter, a CPU one (Mesa's lavapipe) when there is one.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{full_module, shader_source, Gpu, Query};
use sbrdf::preview::{preview_samples, tone_map, PreviewOptions, PreviewSample};
use sbrdf::Decoder;
use std::path::PathBuf;
use std::process::ExitCode;

/// Queries per dispatch: within the 65 535 workgroups of 64 a dispatch may have.
const CHUNK: usize = 1 << 20;

struct Args {
    input: PathBuf,
    output: PathBuf,
    options: PreviewOptions,
}

fn usage() -> String {
    "usage: gpu_preview FILE.sbrdf [OUT.png] [--size N] [--light THETA,PHI]\n\
     renders sbrdf preview's sphere on the GPU (sbrdf_eval_rgb) and compares it with the CPU's"
        .into()
}

fn parse_args() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let mut positional = Vec::new();
    let mut options = PreviewOptions::default();
    while let Some(a) = it.next() {
        match a.as_str() {
            "-h" | "--help" => return Err(usage()),
            "--size" => {
                let v = it.next().ok_or("--size needs a value")?;
                options.size = v
                    .parse()
                    .map_err(|_| format!("--size {v}: not a pixel count"))?;
            }
            "--light" => {
                let v = it.next().ok_or("--light needs THETA,PHI")?;
                let parts: Vec<f64> = v
                    .split(',')
                    .map(|p| p.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| format!("--light {v}: expected THETA,PHI in degrees"))?;
                if parts.len() != 2 {
                    return Err(format!("--light {v}: expected THETA,PHI in degrees"));
                }
                options.light = (parts[0], parts[1]);
            }
            _ if a.starts_with('-') => return Err(format!("unknown option {a}\n{}", usage())),
            _ => positional.push(PathBuf::from(a)),
        }
    }
    match positional.len() {
        1 | 2 => Ok(Args {
            input: positional[0].clone(),
            output: positional
                .get(1)
                .cloned()
                .unwrap_or_else(|| PathBuf::from("gpu_preview.png")),
            options,
        }),
        _ => Err(usage()),
    }
}

fn main() -> ExitCode {
    match run() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("gpu_preview: {e}");
            ExitCode::from(2)
        }
    }
}

/// Renders, compares and writes; Ok(false) when the pictures differ by more than one level.
fn run() -> Result<bool, String> {
    let a = parse_args()?;
    let name = a.input.display();
    let dec = Decoder::open(&a.input).map_err(|e| format!("{name}: {e}"))?;
    let packed = sbrdf::gpu::pack(&[&dec]).map_err(|e| format!("{name}: {e}"))?;
    let samples = preview_samples(&a.options).map_err(|e| e.to_string())?;

    // The device: one query per lit sub-sample, at the material's base (the buffer holds it
    // alone).
    let lit: Vec<(usize, Query)> = samples
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match *s {
            PreviewSample::Lit { light, view, .. } => Some((
                i,
                Query {
                    wi: light,
                    lambda_nm: 0.0,
                    wo: view,
                    base: packed.bases[0],
                },
            )),
            _ => None,
        })
        .collect();
    let gpu = Gpu::new();
    let module = full_module(&shader_source());
    let start = std::time::Instant::now();
    let mut device_rgb = vec![[0.0f64; 3]; samples.len()];
    for chunk in lit.chunks(CHUNK) {
        let queries: Vec<Query> = chunk.iter().map(|(_, q)| *q).collect();
        let out = gpu.run(&module, "eval_rgb", &packed.words, &queries, 3);
        for ((i, _), c) in chunk.iter().zip(out.chunks_exact(3)) {
            device_rgb[*i] = [c[0] as f64, c[1] as f64, c[2] as f64];
        }
    }
    let device_time = start.elapsed();
    let radiance: Vec<Option<[f64; 3]>> = samples
        .iter()
        .zip(&device_rgb)
        .map(|(s, &c)| s.radiance(c))
        .collect();
    let device = tone_map(&a.options, &radiance).map_err(|e| e.to_string())?;

    // The CPU: the same sub-samples through the decoder, as `sbrdf preview` renders them.
    let start = std::time::Instant::now();
    let radiance: Vec<Option<[f64; 3]>> = samples.iter().map(|s| s.radiance_on_cpu(&dec)).collect();
    let cpu_time = start.elapsed();
    let cpu = tone_map(&a.options, &radiance).map_err(|e| e.to_string())?;

    let diffs: Vec<u8> = device
        .rgb
        .iter()
        .zip(&cpu.rgb)
        .map(|(d, c)| d.abs_diff(*c))
        .collect();
    let differing = diffs.iter().filter(|&&d| d > 0).count();
    let worst = diffs.iter().copied().max().unwrap_or(0);
    println!(
        "{name}: {0}×{0} pixels, {1} lit sub-samples on the device in {2:.2} s (CPU, one thread: \
         {3:.2} s); exposure device {4:.6}, CPU {5:.6}; {differing} of {6} channel values differ \
         from the CPU's picture, by at most {worst} level(s)",
        device.size,
        lit.len(),
        device_time.as_secs_f64(),
        cpu_time.as_secs_f64(),
        device.exposure,
        cpu.exposure,
        diffs.len(),
    );
    write_png(&a.output, &device.rgb, device.size)?;
    println!("wrote {}", a.output.display());
    Ok(worst <= 1)
}

/// The picture as a PNG, written to a temporary file beside `path` and renamed onto it.
fn write_png(path: &std::path::Path, rgb: &[u8], size: u32) -> Result<(), String> {
    use image::ImageEncoder;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(rgb, size, size, image::ColorType::Rgb8)
        .map_err(|e| format!("encoding the PNG failed: {e}"))?;
    let tmp = path.with_extension("png.tmp");
    std::fs::write(&tmp, &bytes).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("{}: {e}", path.display()))
}
