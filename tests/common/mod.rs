#![allow(dead_code)]
//! Shared helpers: the paper's test materials, built from the shipped ColorChecker spectra.

use sbrdf::encoder::{encode, EncodeOptions, Encoded};
use sbrdf::samples::SampleSet;
use sbrdf::synth::{paper_grid, sample_material, Phong, SpectrumTable};

/// 400–700 nm every 10 nm, as in the paper.
pub fn paper_wavelengths() -> Vec<f64> {
    (0..31).map(|i| 400.0 + 10.0 * i as f64).collect()
}

/// The paper's Phong material: ColorChecker green diffuse, white specular, kd = 1.
pub fn paper_phong(ks: f64, n: f64) -> Phong {
    let t = SpectrumTable::colorchecker();
    let wl = paper_wavelengths();
    Phong {
        diffuse: t.sample(t.find("green").unwrap(), &wl).unwrap(),
        specular: t.sample(t.find("white").unwrap(), &wl).unwrap(),
        kd: 1.0,
        ks,
        n,
    }
}

/// The paper's setup: θo = 2.5…87.5°, φo = 0…355° every 5°, at the given incidences.
pub fn paper_samples(ks: f64, n: f64, incidences: &[(f64, f64)]) -> SampleSet {
    let p = paper_phong(ks, n);
    sample_material(
        &paper_wavelengths(),
        incidences,
        &paper_grid(5.0, 5.0),
        |i, o, w| p.value(i, o, w),
    )
}

/// Encodes with the paper's options, changed by `f`.
pub fn encode_with(set: &SampleSet, f: impl FnOnce(&mut EncodeOptions)) -> Encoded {
    let mut o = EncodeOptions::paper();
    f(&mut o);
    encode(set, &o).expect("encode")
}

/// Encodes with the defaults (the joint fit within 0.5%), changed by `f`.
pub fn encode_default(set: &SampleSet, f: impl FnOnce(&mut EncodeOptions)) -> Encoded {
    let mut o = EncodeOptions::default();
    f(&mut o);
    encode(set, &o).expect("encode")
}

/// Relative L2 error of `approx` against `reference`.
pub fn rel_l2(approx: &[f64], reference: &[f64]) -> f64 {
    assert_eq!(approx.len(), reference.len());
    let e: f64 = approx
        .iter()
        .zip(reference)
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    let r: f64 = reference.iter().map(|b| b * b).sum();
    (e / r).sqrt()
}

pub fn samples_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("samples")
}
