//! The baked view (`Decoder::baked`, `spec/EVALUATION.md` "Baked views"): on every golden file
//! it takes, 10⁶ random pairs within the tolerance asked of the exact route
//! (|ρ_baked − ρ| ≤ τ·max(ρ, ρ̄)), at three tolerances; the files it does not take refused
//! with a reason; its grids finer (and larger) for a smaller tolerance.

#[path = "../benches/common/materials.rs"]
#[allow(dead_code)] // the table baseline is the benchmark's, unused here
mod materials;

use sbrdf::io::synth::QueryRng;
use sbrdf::{Decoder, Error};
use std::path::PathBuf;

const TOLERANCES: [f32; 3] = [1e-2, 1e-3, 1e-4];
const PAIRS: usize = 1_000_000;

fn golden() -> Vec<(String, Decoder)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples");
    let manifest = std::fs::read_to_string(root.join("golden/MANIFEST")).unwrap();
    let mut files: Vec<PathBuf> = manifest
        .lines()
        .filter(|l| !l.starts_with('#') && l.contains(':'))
        .map(|l| {
            root.join("golden")
                .join(l.split(':').next().unwrap().trim())
        })
        .collect();
    files.push(root.join("ggx_slices.sbrdf"));
    files
        .into_iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, Decoder::open(&p).unwrap())
        })
        .collect()
}

/// The middle of a file's wavelength range.
fn middle(dec: &Decoder) -> f32 {
    let w = &dec.material().wavelengths;
    0.5 * (w[0] + w[w.len() - 1])
}

/// The largest |baked − exact| / max(exact, ρ̄) over `pairs` and the grid side, or why the
/// view was refused.
fn worst(
    dec: &Decoder,
    lambda: f32,
    tol: f32,
    pairs: &[([f32; 3], [f32; 3])],
) -> Result<(f64, usize), String> {
    let baked = match dec.baked(lambda, tol) {
        Ok(b) => b,
        Err(Error::Parameter(why)) => return Err(why),
        Err(e) => panic!("refused with {e:?}"),
    };
    let at = dec.at(lambda);
    let mean = baked.mean_value();
    let mut worst = 0.0f64;
    for &(wi, wo) in pairs {
        let (b, e) = (baked.eval(wi, wo) as f64, at.eval(wi, wo) as f64);
        let err = (b - e).abs() / e.max(mean);
        assert!(err.is_finite(), "{wi:?} {wo:?}: baked {b}, exact {e}");
        worst = worst.max(err);
    }
    Ok((worst, baked.grid_side()))
}

#[test]
fn every_golden_file_it_takes_holds_its_tolerance_on_a_million_pairs() {
    // Held-out pairs: a generator the view never saw, down to the horizon.
    let pairs = QueryRng::new(0x0000_DDBA_11C0_FFEE).direction_pairs(PAIRS, 0.0);
    let mut taken = Vec::new();
    for (name, dec) in golden() {
        let lambda = middle(&dec);
        let mut sides = Vec::new();
        for tol in TOLERANCES {
            match worst(&dec, lambda, tol, &pairs) {
                Ok((w, side)) => {
                    eprintln!("{name} at {lambda} nm, τ = {tol:e}: worst {w:.3e}, side {side}");
                    assert!(w <= tol as f64, "{name}, τ = {tol}: worst {w}");
                    sides.push(side);
                    taken.push((name.clone(), tol));
                }
                Err(why) => {
                    // Refused: a file off the kernel's route (every tolerance), or a tolerance
                    // its largest grid cannot hold; the message says which and what to do.
                    assert!(why.contains("use Decoder::at"), "{name}: {why}");
                    eprintln!("{name}, τ = {tol:e}: not baked ({why})");
                }
            }
        }
        assert!(sides.windows(2).all(|s| s[0] <= s[1]), "{name}: {sides:?}");
        // The ends of the range, on fewer pairs, at the coarsest tolerance it took.
        if let Some(&tol) = TOLERANCES
            .iter()
            .find(|&&t| taken.contains(&(name.clone(), t)))
        {
            let w = &dec.material().wavelengths;
            for lambda in [w[0], w[w.len() - 1]] {
                let (e, _) = worst(&dec, lambda, tol, &pairs[..PAIRS / 10]).unwrap();
                assert!(e <= tol as f64, "{name} at {lambda} nm: worst {e}");
            }
        }
    }
    // The files a renderer's benchmark stands for are among those taken, at every tolerance;
    // a file with its peak in the SH part (paper mode, no lobes) at the coarsest.
    for must in [
        "phong_3inc_default.sbrdf",
        "ggx_3inc_default.sbrdf",
        "ggx_slices.sbrdf",
    ] {
        for tol in TOLERANCES {
            assert!(
                taken.contains(&(must.to_string(), tol)),
                "{must} at {tol}: {taken:?}"
            );
        }
    }
    assert!(taken.contains(&("phong_3inc_direct_f16.sbrdf".to_string(), 1e-2)));
}

#[test]
fn a_baked_view_refuses_what_it_cannot_hold() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("samples/golden");
    let dec = Decoder::open(root.join("ggx_3inc_default.sbrdf")).unwrap();
    for bad in [0.0, -1e-3, 5e-5, 1.0, f32::NAN, f32::INFINITY] {
        assert!(
            matches!(dec.baked(550.0, bad), Err(Error::Parameter(_))),
            "{bad}"
        );
    }
    assert!(matches!(
        dec.baked(f32::NAN, 1e-2),
        Err(Error::Parameter(_))
    ));
    let baked = dec.baked(550.0, 1e-2).unwrap();
    // Below the horizon and degenerate vectors: 0, as the exact route gives.
    assert_eq!(baked.eval([0.3, 0.0, 0.954], [0.0, 0.0, -1.0]), 0.0);
    assert_eq!(baked.eval([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), 0.0);
    assert_eq!(baked.eval([f32::NAN, 0.0, 1.0], [0.0, 0.0, 1.0]), 0.0);
    // A file whose SH part carries its peak: finer grids for a smaller tolerance, and more
    // bytes; past the largest grid, refused.
    let dec = Decoder::open(root.join("phong_3inc_direct_f16.sbrdf")).unwrap();
    let coarse = dec.baked(550.0, 0.1).unwrap();
    let fine = dec.baked(550.0, 0.01).unwrap();
    assert!(fine.grid_side() > coarse.grid_side());
    assert!(fine.resident_bytes() > coarse.resident_bytes());
    assert!(coarse.grid_error() <= 0.5 * 0.1 && fine.grid_error() <= 0.5 * 0.01);
    let Err(Error::Parameter(why)) = dec.baked(550.0, 1e-4) else {
        panic!("a tolerance past the largest grid was taken")
    };
    assert!(why.contains("cannot hold"), "{why}");
}

/// The benchmark's Phong and GGX materials (encoded with the defaults, whose records keep only
/// Y_0^0 on these θ lines): a view with no grid (side 0), its records' constants exact, within
/// every tolerance on 10⁵ held-out pairs. The golden files above all carry higher SH levels, so
/// without this the constants' route would go untested.
#[test]
fn records_of_y00_alone_are_baked_without_a_grid() {
    let pairs = QueryRng::new(0x0000_0BAD_5EED_0001).direction_pairs(PAIRS / 10, 0.0);
    for name in ["phong9", "ggx7"] {
        let (_, dec, _, _, _) = materials::material(name).expect("a benchmark material");
        for tol in TOLERANCES {
            let (w, side) = worst(&dec, 550.0, tol, &pairs).unwrap();
            eprintln!("{name}, τ = {tol:e}: worst {w:.3e}, side {side}");
            assert_eq!(side, 0, "{name}: a grid for constant SH parts");
            assert!(w <= tol as f64, "{name}, τ = {tol}: worst {w}");
        }
    }
}
