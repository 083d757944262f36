//! Decoder throughput on uniformly random direction pairs: the baseline the Python binding's
//! `Material.eval` is compared with (python/bench_eval.py).
//!
//! cargo run --release --example throughput -- FILE [PAIRS] [WAVELENGTHS]

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .expect("usage: throughput FILE [PAIRS] [WAVELENGTHS]");
    let n: usize = args.get(2).map_or(1_000_000, |s| s.parse().expect("PAIRS"));
    let m: usize = args.get(3).map_or(4, |s| s.parse().expect("WAVELENGTHS"));
    let dec = sbrdf::Decoder::open(path).expect("open");
    let pairs = sbrdf::io::synth::QueryRng::new(0x2545_F491_4F6C_DD1D).direction_pairs(n, 0.0);
    let wl: Vec<f32> = (0..m)
        .map(|i| 450.0 + 200.0 * i as f32 / m.max(2) as f32)
        .collect();
    let mut out = vec![0.0f32; n * m];
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = std::time::Instant::now();
        for ((wi, wo), row) in pairs.iter().zip(out.chunks_mut(m)) {
            dec.eval(*wi, *wo, &wl, row);
        }
        best = best.min(t.elapsed().as_secs_f64());
        std::hint::black_box(&out);
    }
    println!("{}", best);
}
