//! Decoder speed against the simplest alternative a renderer would use: a dense raw table of the
//! same samples with bilinear lookup in (θo, φo), linear in λ, nearest stored incidence, measured
//! in the same run. Per query, for 1, 4 and 31 wavelengths (a measured material: 1 and its 4),
//! on a 9-incidence Phong material, a 7-incidence GGX material and the NIST PTFE measurement
//! (encoded with the defaults; its table is the decoded material resampled on a 5° grid, since
//! the measurement is scattered); the batch entry point on the same pairs; importance sampling
//! (ns per `sample` and per `pdf`, next to `eval` at one wavelength); the time to open a file.
//! Every group's figures are ns per pair (Throughput: 4096 pairs per iteration).
//!
//! Times are the benchmark thread's CPU time (`benches/common/cpu_time.rs`), so that other load
//! on the machine does not count. `cargo bench --bench decode` (or a filter: `-- eval_ggx7`). The memory a decoder holds per
//! material is printed with each material (`Decoder::resident_bytes`, checked against a
//! counting allocator in `tests/memory.rs`).

#[path = "common/cpu_time.rs"]
mod cpu_time;

use cpu_time::CpuTime;
use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use sbrdf::encode::encoder::{encode, EncodeOptions};
use sbrdf::encode::samples::SampleSet;
use sbrdf::io::synth::{paper_grid, sample_material, Ggx, Phong, QueryRng};
use sbrdf::Decoder;

/// The raw-table baseline: values[inc][iθ][iφ][w] on a 5° grid (θo = 2.5…87.5°, φo = 0…355°).
struct RawTable {
    thetas: Vec<f64>,
    wavelengths: Vec<f32>,
    /// Some(1/step) for evenly spaced wavelengths; otherwise the bracket is searched.
    inv_step: Option<f32>,
    values: Vec<f32>,
}

const NT: usize = 18;
const NP: usize = 72;

impl RawTable {
    fn new(thetas: Vec<f64>, wavelengths: Vec<f32>, values: Vec<f32>) -> Self {
        let h = wavelengths.get(1).map_or(1.0, |w| w - wavelengths[0]);
        let even = wavelengths.windows(2).all(|p| p[1] - p[0] == h);
        RawTable {
            thetas,
            inv_step: even.then_some(1.0 / h),
            wavelengths,
            values,
        }
    }

    fn from_samples(set: &SampleSet) -> Self {
        let mut values = Vec::new();
        for s in &set.incidences {
            assert_eq!(s.directions.len(), NT * NP);
            values.extend(s.values.iter().map(|&v| v as f32));
        }
        RawTable::new(
            set.incidences.iter().map(|s| s.theta_i).collect(),
            set.wavelengths.iter().map(|&w| w as f32).collect(),
            values,
        )
    }

    /// A material given by its decoder, resampled on the grid at the file's incidences and
    /// wavelengths (for a measurement whose directions are scattered).
    fn resampled(dec: &Decoder) -> Self {
        let m = dec.material();
        let wl64: Vec<f64> = m.wavelengths.iter().map(|&w| w as f64).collect();
        let mut values = Vec::new();
        let mut out = vec![0.0; wl64.len()];
        for r in &m.records {
            for d in paper_grid(5.0, 5.0) {
                dec.eval_deg((r.theta_i as f64, 0.0), (d[0], d[1]), &wl64, &mut out);
                values.extend(out.iter().map(|&v| v as f32));
            }
        }
        RawTable::new(
            m.records.iter().map(|r| r.theta_i as f64).collect(),
            m.wavelengths.clone(),
            values,
        )
    }

    fn eval(&self, wi: [f32; 3], wo: [f32; 3], wl: &[f32], out: &mut [f32]) {
        let ti = wi[2].clamp(-1.0, 1.0).acos().to_degrees() as f64;
        let inc = self
            .thetas
            .iter()
            .enumerate()
            .min_by(|a, b| (a.1 - ti).abs().total_cmp(&(b.1 - ti).abs()))
            .unwrap()
            .0;
        // Rotate wo so the incident azimuth is 0 (isotropic), then grid coordinates.
        let phi_i = wi[1].atan2(wi[0]);
        let phi_o = wo[1].atan2(wo[0]) - phi_i;
        let to = wo[2].clamp(-1.0, 1.0).acos().to_degrees();
        let po = phi_o.to_degrees().rem_euclid(360.0);
        let ft = ((to - 2.5) / 5.0).clamp(0.0, (NT - 1) as f32);
        let it = (ft as usize).min(NT - 2);
        let t = ft - it as f32;
        let fp = po / 5.0;
        let ip = (fp as usize) % NP;
        let u = fp - fp.floor();
        let ip1 = (ip + 1) % NP;
        let nw = self.wavelengths.len();
        let base = inc * NT * NP * nw;
        let at = |a: usize, b: usize, w: usize| self.values[base + (a * NP + b) * nw + w];
        for (o, &l) in out.iter_mut().zip(wl) {
            let (iw, s) = match self.inv_step {
                Some(inv) => {
                    let fw = ((l - self.wavelengths[0]) * inv).clamp(0.0, (nw - 1) as f32);
                    let iw = (fw as usize).min(nw - 2);
                    (iw, fw - iw as f32)
                }
                None => {
                    let iw = self
                        .wavelengths
                        .partition_point(|&x| x <= l)
                        .clamp(1, nw - 1)
                        - 1;
                    let (a, b) = (self.wavelengths[iw], self.wavelengths[iw + 1]);
                    (iw, ((l - a) / (b - a)).clamp(0.0, 1.0))
                }
            };
            let bil = |w: usize| {
                (1.0 - t) * ((1.0 - u) * at(it, ip, w) + u * at(it, ip1, w))
                    + t * ((1.0 - u) * at(it + 1, ip, w) + u * at(it + 1, ip1, w))
            };
            *o = (1.0 - s) * bil(iw) + s * bil(iw + 1);
        }
    }
}

/// (name, decoder, file bytes, table, the wavelength counts to time).
type Bench = (&'static str, Decoder, Vec<u8>, RawTable, Vec<usize>);

fn materials() -> Vec<Bench> {
    let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
    let grid = paper_grid(5.0, 5.0);
    let phong = Phong::colorchecker("green", "white", (1.0, 15.0, 50.0), &wl).unwrap();
    let nine: Vec<(f64, f64)> = (0..9).map(|i| (10.0 * i as f64, 0.0)).collect();
    let ggx = Ggx::colorchecker(0.2, 1.0, "blue", "yellow", &wl).unwrap();
    let seven: Vec<(f64, f64)> = (0..7).map(|i| (12.0 * i as f64, 0.0)).collect();
    let mut out = Vec::new();
    for (name, set) in [
        (
            "phong9",
            sample_material(&wl, &nine, &grid, |i, o, w| phong.value(i, o, w)),
        ),
        (
            "ggx7",
            sample_material(&wl, &seven, &grid, |i, o, w| ggx.value(i, o, w)),
        ),
    ] {
        let enc = encode(&set, &EncodeOptions::default()).unwrap();
        let bytes = sbrdf::write_material(&enc.material).unwrap();
        let dec = Decoder::from_bytes(&bytes).unwrap();
        out.push((
            name,
            dec,
            bytes,
            RawTable::from_samples(&set),
            vec![1, 4, 31],
        ));
    }
    let nist =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/nist_ptfe_fr11.csv");
    let (set, _) = sbrdf::io::csv::read_samples(&[nist]).unwrap();
    let enc = encode(&set, &EncodeOptions::default()).unwrap();
    let bytes = sbrdf::write_material(&enc.material).unwrap();
    let dec = Decoder::from_bytes(&bytes).unwrap();
    let table = RawTable::resampled(&dec);
    out.push(("ptfe6", dec, bytes, table, vec![1, 4]));
    // An RGL measurement as warped tables (format 1.4, the golden file), against a table of
    // its own values on the 5° grid at its stored incidences.
    let golden = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("samples/golden/rgl_paper_warp_v14.sbrdf");
    let bytes = std::fs::read(golden).unwrap();
    let dec = Decoder::from_bytes(&bytes).unwrap();
    let table = RawTable::resampled(&dec);
    out.push(("rgl_paper", dec, bytes, table, vec![1, 4, 41]));
    out
}

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
