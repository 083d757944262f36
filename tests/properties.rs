//! Property tests (proptest): for random valid materials the decoder reproduces the error the
//! encoder reports, and no query — any direction, any wavelength, NaN and infinities included —
//! makes the decoder panic or answer a non-finite value.

mod common;
use proptest::prelude::*;
use sbrdf::encode::encoder::{encode, EncodeOptions};
use sbrdf::io::synth::{paper_grid, sample_material, Phong, SpectrumTable};
use sbrdf::Decoder;

/// Every golden file the MANIFEST lists ([`common::golden_files`]), in its order, plus the
/// shipped sample.
fn golden_decoders() -> Vec<Decoder> {
    let dir = common::samples_dir().join("golden");
    let mut v: Vec<Decoder> = common::golden_files()
        .iter()
        .map(|n| Decoder::open(dir.join(n)).unwrap())
        .collect();
    v.push(Decoder::open(common::samples_dir().join("ggx_slices.sbrdf")).unwrap());
    v
}

/// Fixed seeds: every run draws the same cases (a failure found is kept in
/// `proptest-regressions/` by proptest itself, and replayed first).
fn fixed(cases: u32, seed: u64) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: proptest::test_runner::RngSeed::Fixed(seed),
        ..ProptestConfig::default()
    }
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -1.5f32..1.5f32,
        1 => any::<f32>(),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(0.0f32),
    ]
}

proptest! {
    #![proptest_config(fixed(500, 0x5B4D_F0A1))]

    /// Each case asks every golden file the same hostile query.
    #[test]
    fn any_query_gives_finite_values(
        wi in [any_f32(), any_f32(), any_f32()],
        wo in [any_f32(), any_f32(), any_f32()],
        wl in proptest::collection::vec(prop_oneof![3 => 300.0f32..900.0, 1 => any::<f32>()], 0..6),
    ) {
        for (i, dec) in golden_decoders_cached().iter().enumerate() {
            let mut out = vec![f32::NAN; wl.len()];
            dec.eval(wi, wo, &wl, &mut out);
            prop_assert!(
                out.iter().all(|v| v.is_finite()),
                "file {} of the manifest: {:?} {:?} {:?} -> {:?}", i, wi, wo, wl, out
            );
        }
    }
}

fn golden_decoders_cached() -> &'static [Decoder] {
    static DECODERS: std::sync::OnceLock<Vec<Decoder>> = std::sync::OnceLock::new();
    DECODERS.get_or_init(golden_decoders)
}

proptest! {
    // Each case is a full encode: few cases, small grids.
    #![proptest_config(fixed(10, 0x5B4D_F0A2))]

    #[test]
    fn decoded_error_is_the_reported_error(
        kd in 0.0f64..2.0,
        ks in 0.0f64..20.0,
        n in 1.0f64..2000.0,
        thetas in proptest::collection::btree_set(0u32..86, 1..3),
        patch in 0usize..24,
        paper in any::<bool>(),
    ) {
        let t = SpectrumTable::colorchecker();
        let wl: Vec<f64> = (0..8).map(|i| 400.0 + 40.0 * i as f64).collect();
        let phong = Phong {
            diffuse: t.sample(patch, &wl).unwrap(),
            specular: t.sample(t.find("white").unwrap(), &wl).unwrap(),
            kd,
            ks,
            n,
        };
        let incidences: Vec<(f64, f64)> = thetas.iter().map(|&t| (t as f64, 0.0)).collect();
        let set = sample_material(&wl, &incidences, &paper_grid(10.0, 10.0), |i, o, w| phong.value(i, o, w));
        let opts = if paper { EncodeOptions { terms: Some(5), ..EncodeOptions::paper() } } else { EncodeOptions::default() };
        let e = encode(&set, &opts).unwrap();
        let bytes = sbrdf::write_material(&e.material).unwrap();
        let dec = Decoder::from_bytes(&bytes).unwrap();
        let (mut approx, mut truth) = (Vec::new(), Vec::new());
        let mut out = vec![0.0; wl.len()];
        for inc in &set.incidences {
            for (d, dir) in inc.directions.iter().enumerate() {
                dec.eval_deg((inc.theta_i, inc.phi_i), (dir[0], dir[1]), &wl, &mut out);
                prop_assert!(out.iter().all(|v| v.is_finite()));
                approx.extend_from_slice(&out);
                truth.extend_from_slice(&inc.values[d * wl.len()..(d + 1) * wl.len()]);
            }
        }
        let err = if truth.iter().all(|&v| v == 0.0) {
            if approx.iter().all(|&v| v == 0.0) { 0.0 } else { f64::INFINITY }
        } else {
            common::rel_l2(&approx, &truth)
        };
        prop_assert!(
            err <= e.rel_error * (1.0 + 1e-4) + 1e-7,
            "decoded {} vs reported {} (kd {} ks {} n {} {:?} paper {})", err, e.rel_error, kd, ks, n, incidences, paper
        );
    }
}
