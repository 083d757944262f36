//! Spectrum to colour: the CIE table compiled into the crate matches the shipped CSV, and a
//! white material comes out as D65's white point and as sRGB white.

mod common;
use sbrdf::decode::color::{Illuminant, CIE_WAVELENGTHS};
use sbrdf::encode::samples::{IncidentSamples, SampleSet};

#[test]
fn cie_constants_match_the_shipped_table() {
    let path = common::samples_dir().join("cie1931_2deg_d65_380_780_5nm.csv");
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(path)
        .unwrap();
    let rows: Vec<Vec<f64>> = r
        .records()
        .map(|x| x.unwrap().iter().map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), CIE_WAVELENGTHS.len());
    // A spectrum that is 1 at one wavelength picks that row's x̄, ȳ, z̄ (times E / Σ E ȳ).
    let norm: f64 = rows.iter().map(|r| r[2]).sum();
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(CIE_WAVELENGTHS[i] as f64, row[0]);
        let mut s = [0.0f32; 81];
        s[i] = 1.0;
        let xyz = sbrdf::decode::color::spectrum_to_xyz(&s, Illuminant::Equal);
        for j in 0..3 {
            assert!((xyz[j] * norm - row[1 + j]).abs() <= 1e-12, "row {i}");
        }
    }
}

#[test]
fn a_white_material_is_the_illuminants_white() {
    // A constant BRDF of 1 everywhere, encoded and decoded.
    let wl: Vec<f64> = (0..31).map(|i| 400.0 + 10.0 * i as f64).collect();
    let dirs = sbrdf::io::synth::paper_grid(10.0, 30.0);
    let set = SampleSet {
        incidences: vec![IncidentSamples {
            theta_i: 20.0,
            phi_i: 0.0,
            values: vec![1.0; dirs.len() * wl.len()],
            directions: dirs,
        }],
        wavelengths: wl,
    };
    let enc = sbrdf::encode::encoder::encode(&set, &Default::default()).unwrap();
    let dec = sbrdf::Decoder::from_material(enc.material).unwrap();
    let (wi, wo) = ([0.34f32, 0.0, 0.94], [-0.2f32, 0.1, 0.97]);
    let xyz = dec.eval_xyz(wi, wo, Illuminant::D65);
    // D65's white point (CIE 1931 2°), normalised to Y = 1: (0.95047, 1, 1.08883).
    for (got, want) in xyz.iter().zip([0.95047, 1.0, 1.08883]) {
        assert!((got - want).abs() < 2e-3, "{xyz:?}");
    }
    let rgb = dec.eval_linear_srgb(wi, wo, Illuminant::D65);
    for c in rgb {
        assert!((c - 1.0).abs() < 3e-3, "{rgb:?}");
    }
    let e = dec.eval_xyz(wi, wo, Illuminant::Equal);
    assert!(
        (e[0] - e[1]).abs() < 3e-3 && (e[2] - e[1]).abs() < 3e-3,
        "{e:?}"
    );
}
