//! Instructions per query, for callgrind: the decoder's cost counted where no other load on the
//! machine can disturb it (criterion's times on a shared machine move by ±30%).
//!
//! ```text
//! cargo build --release --example decode_cost
//! valgrind --tool=callgrind --callgrind-out-file=/dev/null \
//!   target/release/examples/decode_cost ggx7 eval 1 4096
//! ```
//!
//! Arguments: the material (`phong9`, `ggx7`, `ptfe6`, `rgl_paper`: those of
//! `benches/decode.rs`), the route (`eval`, `batch`, `at`, `baked` (τ = 10⁻³), `table`, or `none` to count
//! the set-up alone), the wavelength count and the pairs. Run it twice, with the pairs and with 0, and divide
//! the difference in instructions by the pairs: that is the route's cost per query. The first
//! run encodes the material and keeps it with its table in `target/decode_cost/`, so that
//! callgrind's runs read them instead of encoding under the instrumentation.

// The benchmark's list of every material is not used here: one is measured at a time.
#[allow(dead_code)]
#[path = "../benches/common/materials.rs"]
mod materials;

use materials::RawTable;
use sbrdf::io::synth::QueryRng;
use sbrdf::Decoder;
use std::hint::black_box;

/// Pairs drawn in every run (the first `PAIRS` are used).
const PAIRS_DRAWN: usize = 4096;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 5 {
        eprintln!("usage: decode_cost MATERIAL (eval|batch|at|baked|table|none) WAVELENGTHS PAIRS");
        std::process::exit(2);
    }
    let (name, route) = (args[1].as_str(), args[2].as_str());
    let count: usize = args[3].parse().expect("WAVELENGTHS: a count");
    let n: usize = args[4].parse().expect("PAIRS: a count");
    let Some((dec, table)) = cached(name) else {
        eprintln!("no material {name}");
        std::process::exit(2);
    };
    let w = &dec.material().wavelengths;
    let (lo, hi) = (w[0], w[w.len() - 1]);
    let wl: Vec<f32> = if count == 1 {
        vec![if (lo..=hi).contains(&550.0) {
            550.0
        } else {
            0.5 * (lo + hi)
        }]
    } else {
        (0..count)
            .map(|i| lo + (hi - lo) * i as f32 / (count - 1) as f32)
            .collect()
    };
    // The same pairs are drawn whatever `PAIRS` says, so that drawing them is set-up.
    let qs = QueryRng::new(0x2545_F491_4F6C_DD1D).direction_pairs(PAIRS_DRAWN.max(n), 0.05);
    let (wis, wos): (Vec<[f32; 3]>, Vec<[f32; 3]>) = qs[..n].iter().copied().unzip();
    let mut out = vec![0.0f32; count * n.max(1)];
    let mut sum = 0.0f64;
    match route {
        "eval" => {
            for (a, b) in wis.iter().zip(&wos) {
                dec.eval(*a, *b, &wl, &mut out[..count]);
                sum += black_box(&out)[0] as f64;
            }
        }
        "batch" => {
            if n > 0 {
                dec.eval_batch(&wis, &wos, &wl, &mut out).unwrap();
            }
            sum = black_box(&out).iter().map(|&v| v as f64).sum();
        }
        "at" => {
            let at = dec.at(wl[0]);
            for (a, b) in wis.iter().zip(&wos) {
                sum += black_box(at.eval(*a, *b)) as f64;
            }
        }
        "baked" => {
            // τ = 10⁻³; the grids are made before the pairs (set-up, like the table's).
            let baked = dec.baked(wl[0], 1e-3).expect("a file the baked view takes");
            for (a, b) in wis.iter().zip(&wos) {
                sum += black_box(baked.eval(*a, *b)) as f64;
            }
        }
        "table" => {
            for (a, b) in wis.iter().zip(&wos) {
                table.eval(*a, *b, &wl, &mut out[..count]);
                sum += black_box(&out)[0] as f64;
            }
        }
        "none" => {}
        _ => {
            eprintln!("no route {route}");
            std::process::exit(2);
        }
    }
    println!("{name} {route} {count} {n}: sum {sum}");
}

/// The material's file and table, kept in `target/decode_cost/` after the first run.
fn cached(name: &str) -> Option<(Decoder, RawTable)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/decode_cost");
    let (file, tab) = (
        dir.join(format!("{name}.sbrdf")),
        dir.join(format!("{name}.table")),
    );
    if let (Ok(bytes), Ok(t)) = (std::fs::read(&file), std::fs::read(&tab)) {
        let words: Vec<u32> = t
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let (nt, nw) = (words[0] as usize, words[1] as usize);
        let f = |w: &[u32]| w.iter().map(|&b| f32::from_bits(b)).collect::<Vec<f32>>();
        let thetas = f(&words[2..2 + nt]).iter().map(|&v| v as f64).collect();
        let wavelengths = f(&words[2 + nt..2 + nt + nw]);
        let values = f(&words[2 + nt + nw..]);
        let dec = Decoder::from_bytes(&bytes).ok()?;
        return Some((dec, RawTable::new(thetas, wavelengths, values)));
    }
    let (_, dec, bytes, table, _) = materials::material(name)?;
    std::fs::create_dir_all(&dir).ok()?;
    let mut t = Vec::new();
    t.extend((table.thetas.len() as u32).to_le_bytes());
    t.extend((table.wavelengths.len() as u32).to_le_bytes());
    let thetas = table.thetas.iter().map(|&v| v as f32);
    for v in thetas
        .chain(table.wavelengths.iter().copied())
        .chain(table.values.iter().copied())
    {
        t.extend(v.to_le_bytes());
    }
    std::fs::write(&file, &bytes).ok()?;
    std::fs::write(&tab, t).ok()?;
    Some((dec, table))
}
