//! The horizon and the singular points (issue 43; `spec/EVALUATION.md`, "Warped tables", Value
//! steps 1 and 5): on every golden and shipped file, a sweep of θi and θo over [85°, 90°] gives
//! finite values no larger than 10× the file's largest value at θ ≤ 85° (warped tables: 160×,
//! see [`WARPED_BOUND`]), and ρ·cos θi·cos θo
//! moves by less than 1% of the file's largest such value from 89.9999° to 90°. Warped tables
//! grew as 1/cos θ of the light's direction (5.9·10¹³ at 90°) before the divisor was bounded.

mod common;
use common::{golden_files, samples_dir};
use sbrdf::Decoder;

/// Outgoing azimuths relative to the incident one: the mirror (180°), the back-scatter (0°)
/// and between.
const DPHI: [f64; 8] = [0.0, 30.0, 90.0, 150.0, 175.0, 180.0, 185.0, 270.0];
const INCIDENT_PHI: [f64; 2] = [0.0, 61.0];
/// Warped tables toward the horizon: 109–115× on the paper and satin golden files, 146× on the
/// ibiza film (`rgl_ibiza_pred_v17`; the same, 145.93×, coded as a 1.6 file: the material's,
/// not the prediction's), all under the divisor 2⁻¹⁰ of Value step 5 (1024×; 2⁻⁶ held them
/// within 7.2× but moved renders, see the spec). Held at 160.
const WARPED_BOUND: f64 = 160.0;

fn files() -> Vec<std::path::PathBuf> {
    let mut out: Vec<_> = golden_files()
        .into_iter()
        .map(|n| samples_dir().join("golden").join(n))
        .collect();
    out.push(samples_dir().join("ggx_slices.sbrdf"));
    out
}

fn lambdas(d: &Decoder) -> [f64; 3] {
    let w = &d.material().wavelengths;
    let (a, b) = (w[0] as f64, w[w.len() - 1] as f64);
    [a, 0.5 * (a + b), b]
}

/// The largest ρ and ρ·cos θi·cos θo over incidences and outgoing directions with θ ≤ 85°.
fn inner_max(d: &Decoder) -> (f64, f64) {
    let l = lambdas(d);
    let mut out = [0.0; 3];
    let (mut rho, mut proj) = (0.0f64, 0.0f64);
    for ti in (0..=17).map(|k| 5.0 * k as f64) {
        for to in (0..=17).map(|k| 5.0 * k as f64) {
            for &pi in &INCIDENT_PHI {
                for dp in (0..24).map(|k| 15.0 * k as f64).chain(DPHI) {
                    d.eval_deg((ti, pi), (to, pi + dp), &l, &mut out);
                    for &v in &out {
                        rho = rho.max(v);
                        proj = proj.max(v * ti.to_radians().cos() * to.to_radians().cos());
                    }
                }
            }
        }
    }
    (rho, proj)
}

#[test]
fn values_toward_the_horizon_are_bounded_and_continuous() {
    let near = [85.0, 87.0, 89.0, 89.5, 89.9, 89.99, 89.9999, 90.0];
    let mut report = Vec::new();
    let mut checked = 0;
    for path in files() {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let d = Decoder::open(&path).unwrap();
        let l = lambdas(&d);
        let (rho_max, proj_max) = inner_max(&d);
        assert!(
            rho_max > 0.0 && proj_max > 0.0,
            "{name}: nothing inside 85°"
        );
        let mut out = [0.0; 3];
        let mut worst: f64 = 0.0;
        // Every pair with at least one direction in [85°, 90°] (the other anywhere above).
        let all: Vec<f64> = (0..=17).map(|k| 5.0 * k as f64).chain(near).collect();
        for &ti in &all {
            for &to in &all {
                if ti < 85.0 && to < 85.0 {
                    continue;
                }
                for &pi in &INCIDENT_PHI {
                    for dp in DPHI {
                        d.eval_deg((ti, pi), (to, pi + dp), &l, &mut out);
                        for &v in &out {
                            assert!(
                                v.is_finite() && v >= 0.0,
                                "{name}: ρ({ti}°, {to}°, Δφ {dp}°) = {v}"
                            );
                            worst = worst.max(v / rho_max);
                        }
                    }
                }
            }
        }
        // Warped tables divide by at least 2⁻¹⁰ (Value step 5), 1024× the measurement's ρ·cos θ
        // at most; the other kinds stay within issue 43's 10×.
        let bound = if d.material().warped.is_some() {
            WARPED_BOUND
        } else {
            10.0
        };
        assert!(
            worst <= bound,
            "{name}: ρ toward the horizon {worst:.3}× the largest value inside 85° (bound {bound})"
        );
        // From 89.9999° to 90° on either side, or both: ρ·cos θi·cos θo moves < 1% of its
        // largest value (angles, so 90° is the binary64 cosine of π/2).
        let mut jump: f64 = 0.0;
        let proj = |ti: f64, to: f64, pi: f64, dp: f64, out: &mut [f64; 3]| {
            d.eval_deg((ti, pi), (to, pi + dp), &l, out);
            let c = ti.to_radians().cos().max(0.0) * to.to_radians().cos().max(0.0);
            out.map(|v| v * c)
        };
        for &pi in &INCIDENT_PHI {
            for dp in DPHI {
                for other in [0.0, 30.0, 60.0, 85.0, 89.9999] {
                    for (a, b) in [
                        ((89.9999, other), (90.0, other)),
                        ((other, 89.9999), (other, 90.0)),
                        ((89.9999, 89.9999), (90.0, 90.0)),
                    ] {
                        let p = proj(a.0, a.1, pi, dp, &mut out);
                        let q = proj(b.0, b.1, pi, dp, &mut out);
                        for (x, y) in p.iter().zip(&q) {
                            jump = jump.max((x - y).abs() / proj_max);
                        }
                    }
                }
            }
        }
        assert!(
            jump < 0.01,
            "{name}: ρ·cos·cos moves {jump:.4} of its largest value from 89.9999° to 90°"
        );
        // With vectors, exactly on the horizon (z = 0) as a renderer passes them: finite too.
        let mut o32 = [0.0f32; 1];
        for (wi, wo) in [
            ([1.0f32, 0.0, 0.0], [-1.0f32, 0.0, 0.0]),
            ([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            ([0.0, 1.0, 0.0], [0.6, 0.0, 0.8]),
            ([0.6, 0.0, 0.8], [0.0, -1.0, 0.0]),
        ] {
            d.eval(wi, wo, &[l[1] as f32], &mut o32);
            assert!(
                o32[0].is_finite() && (o32[0] as f64) <= bound * rho_max,
                "{name}: ρ({wi:?}, {wo:?}) = {}",
                o32[0]
            );
        }
        report.push(format!(
            "{name}: largest ρ inside 85° {rho_max:.4e}; toward the horizon at most {worst:.3}× that; \
             ρ·cos·cos moves {jump:.2e} of its largest from 89.9999° to 90°"
        ));
        checked += 1;
    }
    println!("{}", report.join("\n"));
    assert!(checked >= 16, "{checked} files");
}

/// Both directions on the pole, and the exact mirror direction with either on the pole: one
/// value whatever the azimuths say (the half vector on the pole is the pole, and signed zeros
/// of d(0°, φ) change nothing).
#[test]
fn the_pole_and_the_mirror_direction_have_one_value() {
    for name in golden_files() {
        let d = Decoder::open(samples_dir().join("golden").join(&name)).unwrap();
        let l = lambdas(&d);
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        d.eval_deg((0.0, 0.0), (0.0, 0.0), &l, &mut a);
        for (pi, po) in [(0.0, 180.0), (90.0, 270.0), (180.0, 0.0), (-90.0, 33.0)] {
            d.eval_deg((0.0, pi), (0.0, po), &l, &mut b);
            if d.material().isotropic {
                assert_eq!(a, b, "{name}: both on the pole, φ {pi}°, {po}°");
            }
            assert!(b.iter().all(|v| v.is_finite()));
        }
        if d.material().warped.is_some() {
            // The mirror of (θ, φ) from angles (residue ~1e-16) and from exact vectors agree.
            for t in [10.0f64, 45.0, 80.0, 89.9999] {
                d.eval_deg((t, 30.0), (t, 210.0), &l, &mut a);
                let (s, c) = t.to_radians().sin_cos();
                let wi = [s as f32, 0.0, c as f32];
                let wo = [-(s as f32), 0.0, c as f32];
                let mut v = [0.0f32];
                d.eval(wi, wo, &[l[1] as f32], &mut v);
                let rel = (v[0] as f64 - a[1]).abs() / a[1].max(1e-30);
                assert!(rel < 1e-4, "{name}: mirror at {t}°: {} vs {}", v[0], a[1]);
            }
        }
    }
}
