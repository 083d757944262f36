//! `cargo run --release --example gpu_speed -- FILE [--values N] [--reps R] [--grid TI,TO,PD]`
//!
//! N values a dispatch (default 2²⁰: N/4 direction pairs at four wavelengths each).
//!
//! Evaluations per second on the device, in one run: `sbrdf_eval` (one wavelength a call),
//! `sbrdf_eval4` (four a call) and, as the baseline, a dense float32 table of the same
//! material (ρ tabulated by the CPU decoder on a TI × TO × PD grid over θi, θo and φo − φi, at
//! the file's own wavelengths), looked up with trilinear interpolation in angle and linear in
//! wavelength, at one and at four wavelengths a call. The same random direction pairs feed
//! every kernel; each is dispatched R times after a warm-up and the median time is kept (the
//! pipeline is compiled before timing). Prints values per second, the table's size against the
//! layout's, and the ratios sbrdf / table.
//!
//! Isotropic files only (the table has no φi axis). On lavapipe the figures are the CPU's,
//! through Vulkan: they show the harness works and the relative costs there, not a GPU's speed.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{full_module, query_words, shader_source, Gpu, Query, Rng};
use sbrdf::Decoder;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// The dense table's lookup, reading the table from `sbrdf_words` at `base`: header (TI, TO,
/// PD, W, then W wavelengths as f32), then the values, index ((a·TO + b)·PD + c)·W + w.
const DENSE: &str = r#"
fn dense_f(i: u32) -> f32 { return bitcast<f32>(sbrdf_words[i]); }

// (θi, θo, φd) of the pair as continuous grid positions, and whether the pair is above the
// horizon; the angles with the built-ins (a table lookup needs no more).
fn dense_pos(base: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let ti = sbrdf_words[base];
    let to = sbrdf_words[base + 1u];
    let pd = sbrdf_words[base + 2u];
    let i = normalize(wi);
    let o = normalize(wo);
    if (i.z < 0.0 || o.z < 0.0) { return vec4<f32>(0.0); }
    let th_i = acos(clamp(i.z, 0.0, 1.0));
    let th_o = acos(clamp(o.z, 0.0, 1.0));
    var phi = atan2(o.y, o.x) - atan2(i.y, i.x);
    phi = phi - 6.2831853 * floor(phi / 6.2831853);
    return vec4<f32>(th_i / 1.5707964 * f32(ti - 1u), th_o / 1.5707964 * f32(to - 1u),
        phi / 6.2831853 * f32(pd), 1.0);
}

// The value at wavelength index position lw (continuous) of a grid position.
fn dense_at(base: u32, p: vec4<f32>, lw: f32) -> f32 {
    let ti = sbrdf_words[base];
    let to = sbrdf_words[base + 1u];
    let pd = sbrdf_words[base + 2u];
    let nw = sbrdf_words[base + 3u];
    let vals = base + 4u + nw;
    let a0 = min(u32(p.x), ti - 2u);
    let b0 = min(u32(p.y), to - 2u);
    let c0 = min(u32(p.z), pd - 1u);
    let c1 = (c0 + 1u) % pd;
    let w0 = min(u32(lw), nw - 1u);
    let w1 = min(w0 + 1u, nw - 1u);
    let fa = clamp(p.x - f32(a0), 0.0, 1.0);
    let fb = clamp(p.y - f32(b0), 0.0, 1.0);
    let fc = clamp(p.z - f32(c0), 0.0, 1.0);
    let fw = clamp(lw - f32(w0), 0.0, 1.0);
    var v = 0.0;
    for (var k = 0u; k < 8u; k = k + 1u) {
        let da = k & 1u;
        let db = (k >> 1u) & 1u;
        let dc = (k >> 2u) & 1u;
        let c = select(c0, c1, dc == 1u);
        let wgt = select(1.0 - fa, fa, da == 1u) * select(1.0 - fb, fb, db == 1u)
            * select(1.0 - fc, fc, dc == 1u);
        let at = vals + (((a0 + da) * to + (b0 + db)) * pd + c) * nw;
        v = v + wgt * mix(dense_f(at + w0), dense_f(at + w1), fw);
    }
    return v;
}

// The wavelength's continuous index among the table's wavelengths (held at the ends).
fn dense_lw(base: u32, lambda: f32) -> f32 {
    let nw = sbrdf_words[base + 3u];
    let l0 = dense_f(base + 4u);
    let l1 = dense_f(base + 4u + nw - 1u);
    if (nw == 1u || l1 <= l0) { return 0.0; }
    return clamp((lambda - l0) / (l1 - l0), 0.0, 1.0) * f32(nw - 1u);
}

@compute @workgroup_size(64)
fn dense_one(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&queries)) { return; }
    let q = queries[i];
    let p = dense_pos(q.base, q.wi, q.wo);
    results[i] = select(0.0, dense_at(q.base, p, dense_lw(q.base, q.lambda_nm)), p.w != 0.0);
}

// One invocation per four consecutive queries (dispatched for a quarter of them).
@compute @workgroup_size(64)
fn dense_four(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = 4u * id.x;
    if (i + 3u >= arrayLength(&queries)) { return; }
    let q = queries[i];
    let p = dense_pos(q.base, q.wi, q.wo);
    for (var k = 0u; k < 4u; k = k + 1u) {
        results[i + k] = select(0.0,
            dense_at(q.base, p, dense_lw(q.base, queries[i + k].lambda_nm)), p.w != 0.0);
    }
}
"#;

struct Args {
    input: PathBuf,
    values: usize,
    reps: usize,
    grid: [usize; 3],
}

fn parse_args() -> Result<Args, String> {
    let usage = "usage: gpu_speed FILE.sbrdf [--values N] [--reps R] [--grid TI,TO,PD]";
    let mut it = std::env::args().skip(1);
    let mut a = Args {
        input: PathBuf::new(),
        values: 1 << 20,
        reps: 5,
        grid: [32, 64, 64],
    };
    let mut input = None;
    let number = |flag: &str, v: Option<String>| -> Result<usize, String> {
        let v = v.ok_or(format!("{flag} needs a value"))?;
        v.parse::<usize>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or(format!("{flag} {v}: not a positive integer"))
    };
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--values" => a.values = number("--values", it.next())?.div_ceil(64) * 64,
            "--reps" => a.reps = number("--reps", it.next())?,
            "--grid" => {
                let v = it.next().ok_or("--grid needs TI,TO,PD")?;
                let n: Vec<usize> = v
                    .split(',')
                    .map(|p| p.trim().parse().map_err(|_| format!("--grid {v}")))
                    .collect::<Result<_, _>>()?;
                if n.len() != 3 || n[0] < 2 || n[1] < 2 || n[2] < 2 {
                    return Err(format!("--grid {v}: three counts of at least 2"));
                }
                a.grid = [n[0], n[1], n[2]];
            }
            "-h" | "--help" => return Err(usage.into()),
            _ if arg.starts_with('-') => return Err(format!("unknown option {arg}\n{usage}")),
            _ if input.is_none() => input = Some(PathBuf::from(arg)),
            _ => return Err(usage.into()),
        }
    }
    a.input = input.ok_or(usage)?;
    if a.values > 65_535 * 64 {
        return Err("--values: at most 65535 × 64 (one dispatch)".into());
    }
    Ok(a)
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gpu_speed: {e}");
            ExitCode::from(2)
        }
    }
}

/// The dense table of `dec` on the grid, as words: header, wavelengths, values.
fn dense_table(dec: &Decoder, grid: [usize; 3], waves: &[f32]) -> Vec<u32> {
    let [ti, to, pd] = grid;
    let mut out = vec![ti as u32, to as u32, pd as u32, waves.len() as u32];
    out.extend(waves.iter().map(|v| v.to_bits()));
    let dir = |theta: f64, phi: f64| {
        let (s, c) = theta.sin_cos();
        [(s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32]
    };
    let mut rho = vec![0.0f32; waves.len()];
    for a in 0..ti {
        let wi = dir(
            a as f64 / (ti - 1) as f64 * std::f64::consts::FRAC_PI_2,
            0.0,
        );
        for b in 0..to {
            let theta_o = b as f64 / (to - 1) as f64 * std::f64::consts::FRAC_PI_2;
            for c in 0..pd {
                let wo = dir(theta_o, c as f64 / pd as f64 * std::f64::consts::TAU);
                dec.eval(wi, wo, waves, &mut rho);
                out.extend(rho.iter().map(|v| v.to_bits()));
            }
        }
    }
    out
}

/// One compute pipeline over fixed buffers, dispatched repeatedly.
struct Timed<'a> {
    gpu: &'a Gpu,
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
    groups: u32,
}

impl<'a> Timed<'a> {
    fn new(
        gpu: &'a Gpu,
        module: &wgpu::ShaderModule,
        entry: &str,
        bufs: &[&wgpu::Buffer; 3],
        invocations: usize,
    ) -> Self {
        let d = &gpu.device;
        let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: None,
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        let entries: Vec<wgpu::BindGroupEntry> = bufs
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        Timed {
            gpu,
            pipeline,
            bind,
            groups: invocations.div_ceil(64) as u32,
        }
    }

    /// The wall time of one dispatch, submitted and waited for.
    fn once(&self) -> Duration {
        let d = &self.gpu.device;
        let start = Instant::now();
        let mut enc = d.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind, &[]);
            pass.dispatch_workgroups(self.groups, 1, 1);
        }
        self.gpu.queue.submit([enc.finish()]);
        common::wait(d);
        start.elapsed()
    }

    /// The median of `reps` dispatches after one warm-up.
    fn median(&self, reps: usize) -> Duration {
        self.once();
        let mut t: Vec<Duration> = (0..reps).map(|_| self.once()).collect();
        t.sort();
        t[t.len() / 2]
    }
}

fn run() -> Result<(), String> {
    use wgpu::util::DeviceExt;
    let a = parse_args()?;
    let name = a.input.display().to_string();
    let dec = Decoder::open(&a.input).map_err(|e| format!("{name}: {e}"))?;
    let packed = sbrdf::gpu::pack(&[&dec]).map_err(|e| format!("{name}: {e}"))?;
    let base = packed.bases[0];
    let layout = &packed.words[base as usize..];
    if layout[3] != 0 {
        return Err(format!(
            "{name}: not isotropic; the dense table baseline has no φi axis"
        ));
    }
    let waves: Vec<f32> = (0..layout[7] as usize)
        .map(|i| f32::from_bits(layout[layout[13] as usize + i]))
        .collect();
    let start = Instant::now();
    let table = dense_table(&dec, a.grid, &waves);
    let table_time = start.elapsed();
    // One buffer: the packed layout, the table after it.
    let table_base = packed.words.len() as u32;
    let mut words = packed.words.clone();
    words.extend_from_slice(&table);

    // The same random pairs for every kernel, four wavelengths each (the four-wavelength
    // kernels read groups of four queries; the one-wavelength ones take each query alone).
    let mut rng = Rng(0x5EED);
    let (lo, hi) = (waves[0], waves[waves.len() - 1]);
    let mut sbrdf_q = Vec::with_capacity(a.values);
    for _ in 0..a.values / 4 {
        let mut dir = || {
            let z = rng.f64();
            let phi = std::f64::consts::TAU * rng.f64();
            let s = (1.0 - z * z).sqrt();
            [(s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32]
        };
        let (wi, wo) = (dir(), dir());
        for _ in 0..4 {
            let lambda_nm = lo + (hi - lo) * rng.f64() as f32;
            sbrdf_q.push(Query {
                wi,
                lambda_nm,
                wo,
                base,
            });
        }
    }
    let dense_q: Vec<Query> = sbrdf_q
        .iter()
        .map(|q| Query {
            base: table_base,
            ..*q
        })
        .collect();
    let n = sbrdf_q.len();

    let gpu = Gpu::new();
    let d = &gpu.device;
    // The tests' module (prelude, shader, entry points eval_spectral and eval_four), then the
    // table's lookup and entry points.
    let source = format!("{}\n{DENSE}", full_module(&shader_source()));
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("sbrdf speed"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let storage = |w: &[u32], usage| {
        d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: &w.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>(),
            usage,
        })
    };
    let words_buf = storage(&words, wgpu::BufferUsages::STORAGE);
    let sq = storage(&query_words(&sbrdf_q), wgpu::BufferUsages::STORAGE);
    let dq = storage(&query_words(&dense_q), wgpu::BufferUsages::STORAGE);
    let out = d.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: (4 * n) as u64,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    // The four-wavelength kernels run one invocation per four values.
    let time = |entry: &str, q: &wgpu::Buffer, invocations: usize| {
        Timed::new(&gpu, &module, entry, &[&words_buf, q, &out], invocations).median(a.reps)
    };
    let t_one = time("eval_spectral", &sq, n);
    let t_four = time("eval_four", &sq, n / 4);
    let t_dense_one = time("dense_one", &dq, n);
    let t_dense_four = time("dense_four", &dq, n / 4);
    let rate = |t: Duration| n as f64 / t.as_secs_f64();
    println!(
        "{name}: {n} values a dispatch ({} pairs × 4 wavelengths), median of {} dispatches",
        n / 4,
        a.reps
    );
    println!(
        "  layout {} B; dense table {}×{}×{} × {} wavelengths = {} B (tabulated on the CPU in {:.2} s)",
        4 * layout.len(),
        a.grid[0],
        a.grid[1],
        a.grid[2],
        waves.len(),
        4 * table.len(),
        table_time.as_secs_f64()
    );
    for (what, ts, td) in [
        ("1 wavelength a call", t_one, t_dense_one),
        ("4 wavelengths a call", t_four, t_dense_four),
    ] {
        println!(
            "  {what:21}: sbrdf {:.3e} values/s, dense table {:.3e} values/s, sbrdf / table {:.3}",
            rate(ts),
            rate(td),
            td.as_secs_f64() / ts.as_secs_f64()
        );
    }
    Ok(())
}
