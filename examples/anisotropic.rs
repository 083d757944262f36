//! Issue 15's acceptance figures for anisotropic materials: anisotropic GGX (roughness ratios up
//! to 1:5, axes at several angles) over a blue Lambert base with a spectral Schlick Fresnel, on
//! a lattice of 4 θi × 8 φi incidences, 5° outgoing grid, 31 wavelengths, encoded with the
//! defaults. Prints, per material, the relative L2 error at every stored incidence up to 60°,
//! at incidences between the lattice nodes, and the file's ratio to the float32 samples.
//!
//!     cargo run --release --example anisotropic [-- AX AY AXIS_DEG]

#[path = "../tests/common/mod.rs"]
mod common;

use common::*;
use sbrdf::encode::encoder::{encode, EncodeOptions};
use sbrdf::io::synth::{paper_grid, sample_material, Ggx};
use sbrdf::Decoder;

fn error_at(dec: &Decoder, ggx: &Ggx, inc: (f64, f64)) -> f64 {
    error_on_paper_grid(dec, inc, |i, o, w| ggx.value(i, o, w))
}

fn main() {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("numbers: AX AY AXIS_DEG"))
        .collect();
    let materials: Vec<(f64, f64, f64)> = if args.len() == 3 {
        vec![(args[0], args[1], args[2])]
    } else {
        vec![(0.08, 0.35, 30.0), (0.06, 0.3, 117.0), (0.2, 0.4, 75.0)]
    };
    let wl = paper_wavelengths();
    println!("| αx | αy | axis | stored ≤ 60°: worst / mean | between: worst / mean | bytes | ratio | encode s |");
    println!("| ---: | ---: | ---: | --- | --- | ---: | ---: | ---: |");
    for (ax, ay, axis) in materials {
        let ggx = Ggx::colorchecker(ax, 1.0, "blue", "yellow", &wl)
            .unwrap()
            .with_anisotropy(ay, axis);
        let set = sample_material(&wl, &aniso_lattice(), &paper_grid(5.0, 5.0), |i, o, w| {
            ggx.value(i, o, w)
        });
        let t0 = std::time::Instant::now();
        let enc = encode(&set, &EncodeOptions::default()).expect("encode");
        let secs = t0.elapsed().as_secs_f64();
        let bytes = sbrdf::write_material(&enc.material).unwrap().len();
        let kinds: Vec<&str> = enc
            .material
            .records
            .iter()
            .flat_map(|r| r.lobes.iter().map(|l| l.kind.name()))
            .collect();
        if std::env::var_os("SBRDF_DEBUG").is_some() {
            for r in &enc.material.records {
                for l in &r.lobes {
                    eprintln!(
                        "({}, {}) L{} T{} {} {:?} amp0 {:?}",
                        r.theta_i,
                        r.phi_i,
                        r.sh_level,
                        r.terms,
                        l.kind.name(),
                        l.params,
                        &l.amplitude[..4.min(l.amplitude.len())]
                    );
                }
            }
        }
        let dec = Decoder::from_material(enc.material).unwrap();
        if std::env::var_os("SBRDF_DEBUG").is_some() {
            for i in aniso_between() {
                eprintln!("between {i:?}: {:.4}", error_at(&dec, &ggx, i));
            }
        }
        let stats = |incs: &[(f64, f64)]| {
            let e: Vec<f64> = incs.iter().map(|&i| error_at(&dec, &ggx, i)).collect();
            let worst = e.iter().cloned().fold(0.0, f64::max);
            let at = incs[e.iter().position(|&x| x == worst).unwrap()];
            (worst, e.iter().sum::<f64>() / e.len() as f64, at)
        };
        let stored: Vec<(f64, f64)> = aniso_lattice()
            .into_iter()
            .filter(|i| i.0 <= 60.0)
            .collect();
        let (sw, sm, sat) = stats(&stored);
        let (bw, bm, bat) = stats(&aniso_between());
        println!(
            "| {ax} | {ay} | {axis}° | {:.2}% / {:.2}% (worst at {sat:?}) | {:.2}% / {:.2}% (worst at {bat:?}) | {bytes} | {:.0}× | {secs:.1} |",
            100.0 * sw,
            100.0 * sm,
            100.0 * bw,
            100.0 * bm,
            set.raw_f32_bytes() as f64 / bytes as f64
        );
        let aniso = kinds.iter().filter(|k| **k == "microfacet-aniso").count();
        eprintln!("  lobes: {aniso} of {} anisotropic", kinds.len());
    }
}
