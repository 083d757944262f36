//! Encoding speed: a 90-incidence × 1296-direction × 31-wavelength Phong material with the
//! defaults (the target: ≤ 3 s on a 2-core machine) and in paper mode (≤ 2 s), beside
//! direct-SH mode as a baseline measured in the same run. Wall time: the encoder is parallel.

use criterion::{criterion_group, criterion_main, Criterion};
use sbrdf::encode::encoder::{encode, EncodeOptions};
use sbrdf::encode::fit::PeakMode;
use sbrdf::io::synth::{paper_grid, sample_material, Phong};
use std::time::Duration;

fn material() -> sbrdf::encode::samples::SampleSet {
    let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
    let phong = Phong::colorchecker("green", "white", (1.0, 15.0, 50.0), &wl).unwrap();
    let incidences: Vec<(f64, f64)> = (0..90).map(|i| (i as f64, 0.0)).collect();
    let set = sample_material(&wl, &incidences, &paper_grid(5.0, 5.0), |i, o, w| {
        phong.value(i, o, w)
    });
    assert_eq!(set.incidences.len(), 90);
    assert_eq!(set.incidences[0].directions.len(), 1296);
    set
}

fn bench_encode(c: &mut Criterion) {
    let set = material();
    let mut g = c.benchmark_group("encode_90x1296x31");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("defaults", |b| {
        b.iter(|| encode(&set, &EncodeOptions::default()).unwrap())
    });
    g.bench_function("paper_mode_auto_critical_angle", |b| {
        b.iter(|| encode(&set, &EncodeOptions::paper()).unwrap())
    });
    g.bench_function("direct_sh_level_4", |b| {
        let o = EncodeOptions {
            peak: PeakMode::None,
            sh_level: Some(4),
            ..EncodeOptions::paper()
        };
        b.iter(|| encode(&set, &o).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench_encode);
criterion_main!(benches);
