//! Spectral bases on real spectra: the 24 ColorChecker patches, 400–700 nm every 10 nm.

mod common;
use sbrdf::encode::fit::spectral_projection;
use sbrdf::io::synth::SpectrumTable;
use sbrdf::model::spectral::SpectralBasis;

/// Mean and max relative L2 error of 13-term approximations of the 24 patches.
fn colorchecker_errors(basis: SpectralBasis) -> (f64, f64) {
    let t = SpectrumTable::colorchecker();
    let wl = common::paper_wavelengths();
    let space = sbrdf::encode::basis::spectral_space(basis, 13, &wl);
    let proj = spectral_projection(&space, &wl);
    let syn = space.synthesis(&wl);
    let mut errs = Vec::new();
    for i in 0..t.names.len() {
        let s = t.sample(i, &wl).unwrap();
        let c: Vec<f64> = (0..13)
            .map(|k| (0..wl.len()).map(|w| proj[(k, w)] * s[w]).sum())
            .collect();
        let approx: Vec<f64> = (0..wl.len())
            .map(|w| (0..13).map(|k| syn[w * 13 + k] * c[k]).sum())
            .collect();
        errs.push(common::rel_l2(&approx, &s));
    }
    assert_eq!(errs.len(), 24);
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    (mean, errs.iter().cloned().fold(0.0, f64::max))
}

#[test]
fn cosine_basis_beats_periodic_fourier_on_colorchecker() {
    let (fm, fx) = colorchecker_errors(SpectralBasis::PeriodicFourier);
    let (cm, cx) = colorchecker_errors(SpectralBasis::Cosine);
    eprintln!("fourier: mean {fm:.4} max {fx:.4}; cosine: mean {cm:.4} max {cx:.4}");
    // Independent figures: Fourier 10.9% mean (24% max), cosine 1.5% mean (4.5% max).
    assert!(
        (fm - 0.109).abs() < 0.01 && (fx - 0.24).abs() < 0.02,
        "fourier {fm} {fx}"
    );
    assert!(
        cm <= 0.015 && (cx - 0.045).abs() < 0.005,
        "cosine {cm} {cx}"
    );
}
