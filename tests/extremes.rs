//! Numerical extremes: needle-sharp and grazing highlights, pure specular and pure diffuse,
//! black, tiny spectra, more terms than wavelengths, fewer samples than SH coefficients. Each
//! must encode (or be refused with a clear message), decode to finite values everywhere, and
//! report an error that the decoder reproduces.

mod common;
use common::{encode_default, encode_with, rel_l2};
use sbrdf::encode::encoder::{encode, EncodeOptions};
use sbrdf::encode::samples::SampleSet;
use sbrdf::io::synth::{paper_grid, sample_material, Phong};
use sbrdf::{Decoder, SpectralBasis};

fn phong(wl: &[f64], kd: f64, ks: f64, n: f64) -> Phong {
    Phong::colorchecker("green", "white", (kd, ks, n), wl).unwrap()
}

fn samples(wl: &[f64], incidences: &[(f64, f64)], step: f64, p: &Phong) -> SampleSet {
    sample_material(wl, incidences, &paper_grid(step, step), |i, o, w| {
        p.value(i, o, w)
    })
}

/// Decodes at the samples (error against them) and over a dense sweep of directions including
/// the pole, the horizon and below it, wavelengths inside and outside the range: every value
/// must be finite and non-NaN. Returns the error at the samples.
fn decode_everywhere(set: &SampleSet, dec: &Decoder) -> f64 {
    let wl = &set.wavelengths;
    let mut out = vec![0.0; wl.len()];
    let (mut approx, mut truth) = (Vec::new(), Vec::new());
    for inc in &set.incidences {
        for (d, dir) in inc.directions.iter().enumerate() {
            dec.eval_deg((inc.theta_i, inc.phi_i), (dir[0], dir[1]), wl, &mut out);
            approx.extend_from_slice(&out);
            truth.extend_from_slice(&inc.values[d * wl.len()..(d + 1) * wl.len()]);
        }
    }
    assert!(approx.iter().all(|v| v.is_finite()));
    let probe: Vec<f32> = [300.0, wl[0], 555.5, wl[wl.len() - 1], 900.0, f64::NAN]
        .iter()
        .map(|&v| v as f32)
        .collect();
    let mut o32 = vec![0.0f32; probe.len()];
    let thetas = [0.0, 1e-6, 0.5, 30.0, 60.0, 89.0, 89.999, 90.0];
    for &ti in &thetas {
        for &to in &thetas {
            for po in [0.0, 90.0, 179.999, 180.0, 180.001, 359.0] {
                for pi in [0.0, 45.0] {
                    let wi = sbrdf::model::angles::dir_from_deg(ti, pi).map(|v| v as f32);
                    let wo = sbrdf::model::angles::dir_from_deg(to, po).map(|v| v as f32);
                    dec.eval(wi, wo, &probe, &mut o32);
                    assert!(
                        o32.iter().all(|v| v.is_finite()),
                        "non-finite at ({ti},{pi}) → ({to},{po}): {o32:?}"
                    );
                }
            }
        }
    }
    // Below the horizon: exactly zero.
    dec.eval([0.0, 0.0, 1.0], [1.0, 0.0, -0.01], &probe, &mut o32);
    assert!(o32.iter().all(|&v| v == 0.0));
    rel_l2(&approx, &truth)
}

fn assert_reported(e: &sbrdf::encode::encoder::Encoded, decoded: f64) {
    assert!(
        (decoded - e.rel_error).abs() <= 1e-4 * e.rel_error.max(1e-6) + 1e-7,
        "decoded error {decoded} vs reported {}",
        e.rel_error
    );
}

#[test]
fn needle_highlight_narrower_than_the_sample_spacing() {
    // Phong n = 1e5: the lobe's half width (≈0.3°) is far below the 5° spacing, so the samples
    // see at most one bright direction. The fit must stay finite and report its error honestly.
    let wl = common::paper_wavelengths();
    let p = phong(&wl, 1.0, 15.0, 1e5);
    let set = samples(&wl, &[(0.0, 0.0), (15.0, 0.0), (45.0, 0.0)], 5.0, &p);
    let e = encode_default(&set, |_| {});
    let dec = Decoder::from_material(e.material.clone()).unwrap();
    assert_reported(&e, decode_everywhere(&set, &dec));
    let e = encode_with(&set, |_| {});
    let dec = Decoder::from_material(e.material.clone()).unwrap();
    assert_reported(&e, decode_everywhere(&set, &dec));
}

#[test]
fn grazing_incidence_pure_specular_and_pure_diffuse() {
    let wl = common::paper_wavelengths();
    for (kd, ks, n, what) in [
        (1.0, 15.0, 50.0, "grazing"),
        (0.0, 15.0, 50.0, "pure specular"),
        (1.0, 0.0, 50.0, "pure diffuse"),
    ] {
        let p = phong(&wl, kd, ks, n);
        let incidences: &[(f64, f64)] = if what == "grazing" {
            &[(80.0, 0.0), (89.0, 0.0)]
        } else {
            &[(0.0, 0.0), (30.0, 0.0), (60.0, 0.0)]
        };
        let set = samples(&wl, incidences, 5.0, &p);
        let e = encode_default(&set, |_| {});
        let dec = Decoder::from_material(e.material.clone()).unwrap();
        let err = decode_everywhere(&set, &dec);
        assert_reported(&e, err);
        let budget = if what == "grazing" { 0.02 } else { 0.005 };
        assert!(err < budget, "{what}: error {err}");
    }
}

#[test]
fn an_all_black_material_decodes_to_exact_zeros() {
    let wl = common::paper_wavelengths();
    let p = phong(&wl, 0.0, 0.0, 10.0);
    let set = samples(&wl, &[(0.0, 0.0), (40.0, 0.0)], 10.0, &p);
    assert!(set
        .incidences
        .iter()
        .all(|s| s.values.iter().all(|&v| v == 0.0)));
    for paper in [false, true] {
        let e = if paper {
            encode_with(&set, |_| {})
        } else {
            encode_default(&set, |_| {})
        };
        assert_eq!(e.rel_error, 0.0);
        let bytes = sbrdf::write_material(&e.material).unwrap();
        let dec = Decoder::from_bytes(&bytes).unwrap();
        let mut out = vec![1.0; wl.len()];
        for to in [0.0, 10.0, 45.0, 89.0, 90.0] {
            for ti in [0.0, 20.0, 40.0, 70.0] {
                dec.eval_deg((ti, 0.0), (to, 33.0), &wl, &mut out);
                assert!(out.iter().all(|&v| v == 0.0), "paper {paper}: {out:?}");
            }
        }
    }
}

#[test]
fn one_and_two_wavelengths() {
    for wl in [vec![550.0], vec![500.0, 600.0]] {
        let p = phong(&wl, 1.0, 5.0, 15.0);
        let set = samples(&wl, &[(15.0, 0.0), (45.0, 0.0)], 5.0, &p);
        for basis in [
            SpectralBasis::Tabulated,
            SpectralBasis::Cosine,
            SpectralBasis::PeriodicFourier,
        ] {
            // With fewer wavelengths than the basis's default terms, K clamps to the count.
            let opts = EncodeOptions {
                basis,
                ..EncodeOptions::default()
            };
            let e = match encode(&set, &opts) {
                Ok(e) => e,
                Err(e) => panic!("{} wavelengths, {basis:?}: {e}", wl.len()),
            };
            assert!(e.material.spectral.terms <= wl.len());
            let dec = Decoder::from_material(e.material.clone()).unwrap();
            let err = decode_everywhere(&set, &dec);
            assert_reported(&e, err);
            // The periodic series has one term on two samples (its period joins them), so it
            // can only store their mean: an honest, reported error rather than a failure.
            let limit = if basis == SpectralBasis::PeriodicFourier && wl.len() == 2 {
                0.05
            } else {
                0.005
            };
            assert!(err < limit, "{} wavelengths, {basis:?}: {err}", wl.len());
        }
    }
}

#[test]
fn more_terms_than_wavelengths_is_refused_clearly() {
    let wl = vec![500.0, 550.0, 600.0];
    let p = phong(&wl, 1.0, 5.0, 15.0);
    let set = samples(&wl, &[(15.0, 0.0)], 10.0, &p);
    for basis in [SpectralBasis::Cosine, SpectralBasis::Tabulated] {
        let opts = EncodeOptions {
            basis,
            terms: Some(5),
            ..EncodeOptions::default()
        };
        let e = encode(&set, &opts).expect_err("K = 5 > 3 wavelengths");
        let msg = e.to_string();
        assert!(
            msg.contains('5') && msg.contains('3') && msg.contains("wavelength"),
            "{basis:?}: {msg}"
        );
    }
}

#[test]
fn fewer_outgoing_samples_than_sh_coefficients() {
    // 6 outgoing directions per incidence against (6 + 1)² = 49 SH coefficients at level 6:
    // the encoder must lower the level (or regularise), stay finite and say what it stored.
    let wl = common::paper_wavelengths();
    let p = phong(&wl, 1.0, 5.0, 15.0);
    let dirs: Vec<[f64; 2]> = vec![
        [10.0, 0.0],
        [20.0, 90.0],
        [30.0, 180.0],
        [40.0, 270.0],
        [50.0, 45.0],
        [70.0, 200.0],
    ];
    let set = sample_material(&wl, &[(20.0, 0.0)], &dirs, |i, o, w| p.value(i, o, w));
    for paper in [false, true] {
        let mut opts = if paper {
            EncodeOptions::paper()
        } else {
            EncodeOptions::default()
        };
        opts.sh_level = Some(6);
        let e = encode(&set, &opts).unwrap();
        for r in &e.material.records {
            let coefficients = (r.sh_level + 1) * (r.sh_level + 1);
            assert!(
                coefficients <= dirs.len(),
                "paper {paper}: level {} has {coefficients} coefficients for {} samples",
                r.sh_level,
                dirs.len()
            );
        }
        let dec = Decoder::from_material(e.material.clone()).unwrap();
        assert_reported(&e, decode_everywhere(&set, &dec));
    }
}
