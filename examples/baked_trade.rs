//! The baked view's trade (`Decoder::baked`): for the decoder benchmark's materials, at each
//! tolerance, its grid side, the bytes it holds beyond the decoder, and its largest error against
//! the exact route on 10⁶ random pairs (|ρ_baked − ρ| / max(ρ, ρ̄)); the exact decoder's and the
//! table's bytes beside them. The README's trade table takes its errors and bytes from here and
//! its times from `cargo bench --bench decode` (the same run as the table's).
//!
//! ```text
//! cargo run --release --example baked_trade
//! ```

// The benchmark's materials, built as it builds them.
#[allow(dead_code)]
#[path = "../benches/common/materials.rs"]
mod materials;

use sbrdf::io::synth::QueryRng;

fn main() {
    let pairs = QueryRng::new(0x5EED_BA4E).direction_pairs(1_000_000, 0.0);
    println!("material | tolerance | grid side | bytes held | worst error on 10⁶ pairs");
    for name in ["phong9", "ggx7", "ptfe6"] {
        let (_, dec, bytes, table, _) = materials::material(name).expect("a benchmark material");
        println!(
            "{name}: file {} B, exact decoder holds {} B, table {} B",
            bytes.len(),
            dec.resident_bytes(),
            table.values.len() * 4
        );
        let w = &dec.material().wavelengths;
        let lambda = if (w[0]..=w[w.len() - 1]).contains(&550.0) {
            550.0
        } else {
            0.5 * (w[0] + w[w.len() - 1])
        };
        let at = dec.at(lambda);
        for tol in [1e-2f32, 1e-3, 1e-4] {
            match dec.baked(lambda, tol) {
                Ok(baked) => {
                    let mean = baked.mean_value();
                    let worst = pairs
                        .iter()
                        .map(|&(wi, wo)| {
                            let e = at.eval(wi, wo) as f64;
                            (baked.eval(wi, wo) as f64 - e).abs() / e.max(mean)
                        })
                        .fold(0.0f64, f64::max);
                    println!(
                        "{name} | {tol:e} | {} | {} | {worst:.2e}",
                        baked.grid_side(),
                        baked.resident_bytes()
                    );
                }
                Err(e) => println!("{name} | {tol:e} | refused: {e}"),
            }
        }
    }
}
