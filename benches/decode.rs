//! Decoder speed against the simplest alternative a renderer would use: a dense raw table of the
//! same samples with bilinear lookup in (θo, φo), linear in λ, nearest stored incidence, measured
//! in the same run. Per query, for 1, 4 and 31 wavelengths (a measured material: 1 and its 4),
//! on a 9-incidence Phong material, a 7-incidence GGX material and the NIST PTFE measurement
//! (encoded with the defaults; its table is the decoded material resampled on a 5° grid, since
//! the measurement is scattered); `Decoder::at(λ)` at one wavelength; the batch entry point on
//! the same pairs; importance sampling
//! (ns per `sample` and per `pdf`, next to `eval` at one wavelength); the time to open a file.
//! Every group's figures are ns per pair (Throughput: 4096 pairs per iteration).
//!
//! Times are the benchmark thread's CPU time (`benches/common/cpu_time.rs`), so that other load
//! on the machine does not count. `cargo bench --bench decode` (or a filter: `-- eval_ggx7`). The memory a decoder holds per
//! material is printed with each material (`Decoder::resident_bytes`, checked against a
//! counting allocator in `tests/memory.rs`).

#[path = "common/cpu_time.rs"]
mod cpu_time;

#[path = "common/materials.rs"]
mod materials;

use cpu_time::CpuTime;
use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use materials::materials;
use sbrdf::io::synth::QueryRng;
use sbrdf::Decoder;

/// The tolerances the baked view is timed at (`Decoder::baked`).
const BAKED_TOLERANCES: [f32; 3] = [1e-2, 1e-3, 1e-4];

/// Deterministic uniform pairs for `sample`.
fn uniforms(n: usize) -> Vec<[f32; 2]> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 40) as f32 / (1u32 << 24) as f32).min(0.999_999_9)
    };
    (0..n).map(|_| [next(), next()]).collect()
}

/// `count` wavelengths over the material's range (550 nm, or the middle, for one).
fn wavelengths(dec: &Decoder, count: usize) -> Vec<f32> {
    let w = &dec.material().wavelengths;
    let (lo, hi) = (w[0], w[w.len() - 1]);
    if count == w.len() {
        return w.clone();
    }
    (0..count)
        .map(|i| {
            if count == 1 {
                if (lo..=hi).contains(&550.0) {
                    550.0
                } else {
                    0.5 * (lo + hi)
                }
            } else {
                lo + (hi - lo) * i as f32 / (count - 1) as f32
            }
        })
        .collect()
}

fn bench_decode(c: &mut Criterion<CpuTime>) {
    let qs = QueryRng::new(0x2545_F491_4F6C_DD1D).direction_pairs(4096, 0.05);
    let wis: Vec<[f32; 3]> = qs.iter().map(|q| q.0).collect();
    let wos: Vec<[f32; 3]> = qs.iter().map(|q| q.1).collect();
    // The same outgoing directions with one incident direction per run of 64 pairs (a light
    // and the pixels of a tile, say).
    let runs: Vec<[f32; 3]> = (0..qs.len()).map(|i| qs[i / 64 * 64].0).collect();
    for (name, dec, bytes, raw, counts) in materials() {
        let mut g = c.benchmark_group(format!("eval_{name}"));
        g.throughput(Throughput::Elements(qs.len() as u64));
        for &count in &counts {
            let wl = wavelengths(&dec, count);
            let mut out = vec![0.0f32; count];
            let mut batch_out = vec![0.0f32; count * qs.len()];
            g.bench_with_input(BenchmarkId::new("sbrdf", count), &count, |b, _| {
                b.iter(|| {
                    for (wi, wo) in &qs {
                        dec.eval(*wi, *wo, &wl, &mut out);
                        black_box(&out);
                    }
                })
            });
            if count == 1 {
                // A hero-wavelength renderer's view: the wavelength's work done once.
                let at = dec.at(wl[0]);
                g.bench_with_input(BenchmarkId::new("at", count), &count, |b, _| {
                    b.iter(|| {
                        for (wi, wo) in &qs {
                            black_box(at.eval(*wi, *wo));
                        }
                    })
                });
            }
            if count == 1 {
                // The baked view at three tolerances (files it takes): grids made once, here.
                for tol in BAKED_TOLERANCES {
                    let Ok(baked) = dec.baked(wl[0], tol) else {
                        continue;
                    };
                    println!(
                        "{name}: baked at τ = {tol:e}: grid side {}, {} bytes",
                        baked.grid_side(),
                        baked.resident_bytes()
                    );
                    let id = BenchmarkId::new(format!("baked_{tol:e}"), count);
                    g.bench_with_input(id, &count, |b, _| {
                        b.iter(|| {
                            for (wi, wo) in &qs {
                                black_box(baked.eval(*wi, *wo));
                            }
                        })
                    });
                }
            }
            g.bench_with_input(BenchmarkId::new("raw_table", count), &count, |b, _| {
                b.iter(|| {
                    for (wi, wo) in &qs {
                        raw.eval(*wi, *wo, &wl, &mut out);
                        black_box(&out);
                    }
                })
            });
            g.bench_with_input(BenchmarkId::new("batch", count), &count, |b, _| {
                b.iter(|| {
                    dec.eval_batch(&wis, &wos, &wl, &mut batch_out).unwrap();
                    black_box(&batch_out);
                })
            });
            g.bench_with_input(BenchmarkId::new("batch_runs64", count), &count, |b, _| {
                b.iter(|| {
                    dec.eval_batch(&runs, &wos, &wl, &mut batch_out).unwrap();
                    black_box(&batch_out);
                })
            });
            g.bench_with_input(
                BenchmarkId::new("raw_table_runs64", count),
                &count,
                |b, _| {
                    b.iter(|| {
                        for (wi, wo) in runs.iter().zip(&wos) {
                            raw.eval(*wi, *wo, &wl, &mut out);
                            black_box(&out);
                        }
                    })
                },
            );
        }
        g.finish();
        let us = uniforms(qs.len());
        let mut g = c.benchmark_group(format!("sampling_{name}"));
        g.throughput(Throughput::Elements(qs.len() as u64));
        let one = wavelengths(&dec, 1);
        let mut v = [0.0f32];
        g.bench_function("eval_1", |b| {
            b.iter(|| {
                for (wi, wo) in &qs {
                    dec.eval(*wi, *wo, &one, &mut v);
                    black_box(&v);
                }
            })
        });
        g.bench_function("sample", |b| {
            b.iter(|| {
                for ((wi, _), u) in qs.iter().zip(&us) {
                    black_box(dec.sample(*wi, *u));
                }
            })
        });
        g.bench_function("pdf", |b| {
            b.iter(|| {
                for (wi, wo) in &qs {
                    black_box(dec.pdf(*wi, *wo));
                }
            })
        });
        g.finish();
        let opened = Decoder::from_bytes(&bytes).unwrap();
        eprintln!(
            "{name}: file {} bytes, raw table {} bytes, decoder resident {} bytes ({:.2}× the file)",
            bytes.len(),
            raw.values.len() * 4,
            opened.resident_bytes(),
            opened.resident_bytes() as f64 / bytes.len() as f64
        );
        c.bench_function(&format!("open_{name}"), |b| {
            b.iter(|| Decoder::from_bytes(black_box(&bytes)).unwrap())
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(CpuTime::default());
    targets = bench_decode
}
criterion_main!(benches);
