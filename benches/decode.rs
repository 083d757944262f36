//! Decoder speed against the simplest alternative a renderer would use: a dense raw table of the
//! same samples with bilinear lookup in (θo, φo), linear in λ, nearest stored incidence.
//! Per query, for 1, 4 and 31 wavelengths, on a 9-incidence Phong material and a 7-incidence
//! GGX material; plus the time to open a file. Both are measured in the same run. Importance
//! sampling: ns per `sample` and per `pdf`, next to `eval` at one wavelength, on the same
//! materials and incidences.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use sbrdf::encode::encoder::{encode, EncodeOptions};
use sbrdf::encode::samples::SampleSet;
use sbrdf::io::synth::{paper_grid, sample_material, Ggx, Phong, QueryRng};
use sbrdf::Decoder;

/// The raw-table baseline: values[inc][iθ][iφ][w] on the paper's grid.
struct RawTable {
    thetas: Vec<f64>,
    wavelengths: Vec<f32>,
    values: Vec<f32>,
}

const NT: usize = 18;
const NP: usize = 72;

impl RawTable {
    fn new(set: &SampleSet) -> Self {
        let mut values = Vec::new();
        for s in &set.incidences {
            values.extend(s.values.iter().map(|&v| v as f32));
        }
        RawTable {
            thetas: set.incidences.iter().map(|s| s.theta_i).collect(),
            wavelengths: set.wavelengths.iter().map(|&w| w as f32).collect(),
            values,
        }
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
            let fw = ((l - self.wavelengths[0]) / (self.wavelengths[1] - self.wavelengths[0]))
                .clamp(0.0, (nw - 1) as f32);
            let iw = (fw as usize).min(nw - 2);
            let s = fw - iw as f32;
            let bil = |w: usize| {
                (1.0 - t) * ((1.0 - u) * at(it, ip, w) + u * at(it, ip1, w))
                    + t * ((1.0 - u) * at(it + 1, ip, w) + u * at(it + 1, ip1, w))
            };
            *o = (1.0 - s) * bil(iw) + s * bil(iw + 1);
        }
    }
}

fn materials() -> Vec<(&'static str, SampleSet)> {
    let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
    let grid = paper_grid(5.0, 5.0);
    let phong = Phong::colorchecker("green", "white", (1.0, 15.0, 50.0), &wl).unwrap();
    let nine: Vec<(f64, f64)> = (0..9).map(|i| (10.0 * i as f64, 0.0)).collect();
    let ggx = Ggx::colorchecker(0.2, 1.0, "blue", "yellow", &wl).unwrap();
    let seven: Vec<(f64, f64)> = (0..7).map(|i| (12.0 * i as f64, 0.0)).collect();
    vec![
        (
            "phong9",
            sample_material(&wl, &nine, &grid, |i, o, w| phong.value(i, o, w)),
        ),
        (
            "ggx7",
            sample_material(&wl, &seven, &grid, |i, o, w| ggx.value(i, o, w)),
        ),
    ]
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

fn bench_decode(c: &mut Criterion) {
    let qs = QueryRng::new(0x2545_F491_4F6C_DD1D).direction_pairs(4096, 0.05);
    for (name, set) in materials() {
        let enc = encode(&set, &EncodeOptions::default()).unwrap();
        let bytes = sbrdf::write_material(&enc.material).unwrap();
        let dec = Decoder::from_bytes(&bytes).unwrap();
        let raw = RawTable::new(&set);
        let mut g = c.benchmark_group(format!("eval_{name}"));
        g.throughput(Throughput::Elements(qs.len() as u64));
        for count in [1usize, 4, 31] {
            let wl: Vec<f32> = (0..count)
                .map(|i| {
                    if count == 1 {
                        550.0
                    } else {
                        400.0 + 300.0 * i as f32 / (count - 1) as f32
                    }
                })
                .collect();
            let mut out = vec![0.0f32; count];
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
        }
        g.finish();
        let us = uniforms(qs.len());
        let mut g = c.benchmark_group(format!("sampling_{name}"));
        g.throughput(Throughput::Elements(qs.len() as u64));
        let mut one = [0.0f32];
        g.bench_function("eval_1", |b| {
            b.iter(|| {
                for (wi, wo) in &qs {
                    dec.eval(*wi, *wo, &[550.0], &mut one);
                    black_box(&one);
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
        eprintln!(
            "{name}: file {} bytes, raw table {} bytes",
            bytes.len(),
            raw.values.len() * 4
        );
        c.bench_function(&format!("open_{name}"), |b| {
            b.iter(|| Decoder::from_bytes(black_box(&bytes)).unwrap())
        });
    }
}

criterion_group!(benches, bench_decode);
criterion_main!(benches);
