//! What the tests share: the shader's path, the host prelude (the bindings the shader's contract
//! leaves to the host), the sample files, a seeded generator, and a minimal wgpu harness that runs
//! one compute entry point over a buffer of queries. Materials are put in one buffer by
//! `sbrdf::gpu::pack`, as a renderer does.

#![allow(dead_code)] // each test file uses its own part of this module

use std::path::PathBuf;

/// The repository root (this crate lives in `gpu/`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `SBRDF_WGSL` if set (to test a shader elsewhere), else `shaders/sbrdf.wgsl` in the repository.
pub fn shader_path() -> PathBuf {
    match std::env::var_os("SBRDF_WGSL") {
        Some(p) => PathBuf::from(p),
        None => repo_root().join("shaders").join("sbrdf.wgsl"),
    }
}

/// The shader's text. A missing shader fails the test (no silent skip): CI must test it.
pub fn shader_source() -> String {
    let path = shader_path();
    std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "cannot read the shader {} ({e}); set SBRDF_WGSL to test one elsewhere",
            path.display()
        )
    })
}

/// The host's declarations, pasted before the shader as its contract says: the layout words the
/// shader reads as `sbrdf_words`, the queries, and the results. A query is 8 words:
/// wi.xyz, λ (nm), wo.xyz, and the material's base word offset (bitcast). One entry point per
/// function, so that one module serves every comparison.
pub const PRELUDE: &str = r#"
@group(0) @binding(0) var<storage, read> sbrdf_words: array<u32>;
struct Query { wi: vec3<f32>, lambda_nm: f32, wo: vec3<f32>, base: u32 }
@group(0) @binding(1) var<storage, read> queries: array<Query>;
@group(0) @binding(2) var<storage, read_write> results: array<f32>;
"#;

/// The entry points, appended after the shader (they call its functions).
pub const ENTRY_POINTS: &str = r#"
@compute @workgroup_size(64)
fn eval_spectral(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&queries)) { return; }
    let q = queries[i];
    results[i] = sbrdf_eval(q.base, q.wi, q.wo, q.lambda_nm);
}

// sbrdf_eval4 on four consecutive queries (one pair at four wavelengths): invocation k
// evaluates queries 4k to 4k + 3, so a quarter as many invocations as queries suffice (more
// return at once). The query count must be a multiple of 4.
@compute @workgroup_size(64)
fn eval_four(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = 4u * id.x;
    if (i + 3u >= arrayLength(&queries)) { return; }
    let q = queries[i];
    let l = vec4<f32>(q.lambda_nm, queries[i + 1u].lambda_nm, queries[i + 2u].lambda_nm,
        queries[i + 3u].lambda_nm);
    let v = sbrdf_eval4(q.base, q.wi, q.wo, l);
    results[i] = v.x;
    results[i + 1u] = v.y;
    results[i + 2u] = v.z;
    results[i + 3u] = v.w;
}

@compute @workgroup_size(64)
fn eval_rgb(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&queries)) { return; }
    let q = queries[i];
    let c = sbrdf_eval_rgb(q.base, q.wi, q.wo);
    results[3u * i] = c.x;
    results[3u * i + 1u] = c.y;
    results[3u * i + 2u] = c.z;
}
"#;

/// Prelude + shader + entry points: the module a host would build.
pub fn full_module(shader: &str) -> String {
    format!("{PRELUDE}\n{shader}\n{ENTRY_POINTS}")
}

/// The files the device test covers: `samples/golden/MANIFEST`'s and `samples/ggx_slices.sbrdf`.
pub fn sample_files() -> Vec<PathBuf> {
    let root = repo_root().join("samples");
    let manifest = std::fs::read_to_string(root.join("golden").join("MANIFEST")).unwrap();
    let mut files: Vec<PathBuf> = manifest
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            root.join("golden")
                .join(l.split(':').next().unwrap().trim())
        })
        .collect();
    assert!(files.len() >= 10, "MANIFEST lists {} files", files.len());
    files.push(root.join("ggx_slices.sbrdf"));
    files
}

/// splitmix64: seeded, so that a failure reproduces; no dependency.
pub struct Rng(pub u64);
impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A query as the prelude's `Query` lays it out.
#[derive(Clone, Copy, Debug)]
pub struct Query {
    pub wi: [f32; 3],
    pub lambda_nm: f32,
    pub wo: [f32; 3],
    pub base: u32,
}

/// Queries as the words of the prelude's `Query` array.
pub fn query_words(q: &[Query]) -> Vec<u32> {
    let mut w = Vec::with_capacity(q.len() * 8);
    for q in q {
        w.extend(q.wi.iter().map(|v| v.to_bits()));
        w.push(q.lambda_nm.to_bits());
        w.extend(q.wo.iter().map(|v| v.to_bits()));
        w.push(q.base);
    }
    w
}

/// A wgpu device on a Vulkan adapter, a CPU one (lavapipe) when there is one.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// Whether the adapter runs on the CPU (lavapipe): tests that draw many random pairs draw
    /// fewer there, where each query costs microseconds of a CI core.
    pub on_cpu: bool,
}

impl Gpu {
    pub fn new() -> Gpu {
        let instance = wgpu::Instance::new(&wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            ..Default::default()
        });
        let adapters = instance.enumerate_adapters(wgpu::Backends::VULKAN);
        for a in &adapters {
            eprintln!("Vulkan adapter found: {:?}", a.get_info());
        }
        // The CPU adapter (lavapipe) is what CI has; any other Vulkan adapter will do elsewhere.
        let adapter = adapters
            .iter()
            .position(|a| a.get_info().device_type == wgpu::DeviceType::Cpu)
            .or(if adapters.is_empty() { None } else { Some(0) })
            .map(|i| adapters.into_iter().nth(i).unwrap())
            .unwrap_or_else(|| {
                panic!(
                    "no Vulkan adapter: install Mesa's lavapipe (apt-get install -y \
                     mesa-vulkan-drivers), the Vulkan driver that runs compute shaders on the CPU"
                )
            });
        eprintln!("using adapter: {:?}", adapter.get_info());
        let on_cpu = adapter.get_info().device_type == wgpu::DeviceType::Cpu;
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("sbrdf tests"),
            required_features: wgpu::Features::empty(),
            // The adapter's own limits: large storage buffers for 10^5 pairs × wavelengths.
            required_limits: limits,
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .expect("request_device");
        Gpu {
            device,
            queue,
            on_cpu,
        }
    }

    /// Compiles `module` and runs `entry` once per query; returns `per_query` f32 per query.
    pub fn run(
        &self,
        module: &str,
        entry: &str,
        words: &[u32],
        queries: &[Query],
        per_query: usize,
    ) -> Vec<f32> {
        use wgpu::util::DeviceExt;
        let d = &self.device;
        d.push_error_scope(wgpu::ErrorFilter::Validation);
        let shader = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("sbrdf"),
            source: wgpu::ShaderSource::Wgsl(module.into()),
        });
        let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: None,
            module: &shader,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        let storage = |contents: &[u32], usage| {
            d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: None,
                contents: &bytes(contents),
                usage,
            })
        };
        let words_buf = storage(words, wgpu::BufferUsages::STORAGE);
        let query_buf = storage(&query_words(queries), wgpu::BufferUsages::STORAGE);
        let out_len = (queries.len() * per_query * 4) as u64;
        let out_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: out_len,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let read_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: out_len,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Entry points not used by `entry` are not in the auto layout; all three bindings are.
        let bind = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: words_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: query_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: out_buf.as_entire_binding(),
                },
            ],
        });
        let mut enc = d.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind, &[]);
            let groups = queries.len().div_ceil(64);
            assert!(groups <= 65535, "{} queries: split them", queries.len());
            pass.dispatch_workgroups(groups as u32, 1, 1);
        }
        enc.copy_buffer_to_buffer(&out_buf, 0, &read_buf, 0, out_len);
        self.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(d.pop_error_scope()) {
            panic!("wgpu validation error (shader or pipeline): {e}");
        }
        let slice = read_buf.slice(..);
        slice.map_async(wgpu::MapMode::Read, |r| r.expect("map"));
        wait(d);
        let data = slice.get_mapped_range();
        data.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }
}

/// Waits for the device's work to finish. wgpu gives up a wait after 60 s; lavapipe shares the
/// machine's cores among every test's device (and CI's other jobs), so a small dispatch can wait
/// that long behind another test's large ones: wait again rather than fail (a shader that never
/// finishes still hangs the test, which the harness's timeout reports).
pub fn wait(d: &wgpu::Device) {
    loop {
        match d.poll(wgpu::PollType::Wait) {
            Ok(_) => return,
            Err(wgpu::PollError::Timeout) => eprintln!("still waiting for the device (60 s more)"),
        }
    }
}

fn bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}
